"""Generated Python drivers (sync and asyncio) against `mdl sim`: values, writes, errors, plan."""

from __future__ import annotations

import asyncio

import pytest
from conftest import DATA, EXAMPLE, fn_xml, import_generated, run_mdl
from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient

ALL = DATA / "all_tables.xml"


@pytest.fixture(scope="module")
def all_tables(tmp_path_factory):
    out = tmp_path_factory.mktemp("py")
    proc = run_mdl("gen", ALL, "--lang", "python", "-o", out)
    assert proc.returncode == 0, proc.stderr
    return import_generated(out / "all_tables.py", "all_tables_driver")


def test_sync_driver_reads_and_writes(all_tables, sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5", "--set", "mode=Cool", "--set", "label=Hall",
                      "--set", "energy=1234.567", "--set", "power=-12.5", "--set", "big=-5000000000",
                      "--set", "temp_offset=-10", "--set", "serial=305419896", "--set", "low_byte=-3",
                      "--set", "high_byte=200", "--set", "pump=1", "--set", "flow=12.3")
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        dev = all_tables.AllTables(client, unit=1)
        assert dev.read_setpoint() == 21.5
        assert dev.read_mode() == 2
        assert dev.read_label() == "Hall"
        assert dev.read_energy() == 1234.567
        assert dev.read_power() == -12.5
        assert dev.read_big() == -5000000000
        assert dev.read_temp_offset() == -10.0
        assert dev.read_serial() == 305419896
        assert dev.read_low_byte() == -3
        assert dev.read_high_byte() == 200
        assert dev.read_pump() is True
        assert dev.read_flow() == pytest.approx(12.3, abs=1e-5)
        assert dev.read_voltage() == 0.0
        dev.write_setpoint(19.0)
        dev.write_fan(True)
        dev.write_label("Kitchen")
        dev.write_flow(7.5)
        dev.write_alarm_reset(True)
        values = dev.read_all()
        assert values["setpoint"] == 19.0 and values["fan"] is True and values["label"] == "Kitchen"
        assert values["flow"] == 7.5 and values["status_bit"] == 0.0
        assert "alarm_reset" not in values  # write-only
        assert set(values) == {"pump", "fan", "door_open", "filter_dirty", "energy", "power", "voltage", "gap_low",
                               "gap_high", "setpoint", "mode", "label", "status_bit", "flow", "big", "temp_offset",
                               "serial", "low_byte", "high_byte"}
        with pytest.raises(all_tables.ValueRangeError):
            dev.write_setpoint(40)
        with pytest.raises(ValueError):
            dev.write_label("far too long a label")
        assert not hasattr(dev, "write_status_bit") and not hasattr(dev, "write_energy")
        assert not hasattr(dev, "write_door_open") and not hasattr(dev, "read_alarm_reset")
    finally:
        client.close()


def test_not_implemented_reads_none(all_tables, sim_factory, tmp_path):
    raw = tmp_path / "raw.json"
    raw.write_text('{"input": {"10": 65535}}')
    sim = sim_factory(ALL, "--registers", raw)
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        dev = all_tables.AllTables(client)
        assert dev.read_voltage() is None
        assert dev.read_all()["voltage"] is None
    finally:
        client.close()


def test_async_driver(all_tables, sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=22.5")

    async def main():
        client = AsyncModbusTcpClient(sim.host, port=sim.port, timeout=5)
        await client.connect()
        try:
            dev = all_tables.AsyncAllTables(client)
            assert await dev.read_setpoint() == 22.5
            await dev.write_setpoint(23.0)
            values = await dev.read_all()
            assert values["setpoint"] == 23.0
            with pytest.raises(all_tables.ModbusExceptionError):
                await dev._read("holding", 99, 1)
        finally:
            client.close()

    asyncio.run(main())


def test_modbus_exception_carries_code(all_tables, sim_factory, write_device):
    other = write_device(fn_xml("setpoint", "100", format="INT16"), filename="other.xml")
    sim = sim_factory(other)  # a device without most of the registers
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        dev = all_tables.AllTables(client)
        with pytest.raises(all_tables.ModbusExceptionError) as exc:
            dev.read_mode()
        assert exc.value.code == 2
        assert isinstance(exc.value, all_tables.DeviceError)
    finally:
        client.close()


def test_unreachable_device_raises_communication_error(all_tables):
    client = ModbusTcpClient("127.0.0.1", port=1, timeout=1, retries=0)
    client.connect()
    dev = all_tables.AllTables(client)
    with pytest.raises(all_tables.CommunicationError):
        dev.read_setpoint()


class CountingClient:
    def __init__(self, client):
        self.client = client
        self.requests = []

    def __getattr__(self, name):
        attr = getattr(self.client, name)
        if not name.startswith(("read_", "write_")):
            return attr

        def call(*args, **kw):
            self.requests.append((name, args[0], kw.get("count")))
            return attr(*args, **kw)

        return call


def test_read_all_uses_the_plan_and_falls_back_on_exception_2(tmp_path, write_device, sim_factory):
    # the description knows a write-only register at 11 between 10 and 12: the plan reads 10..12 at once
    described = write_device(fn_xml("a", "10", format="UINT16") + fn_xml("cmd", "11", format="UINT16", access="write")
                             + fn_xml("b", "12", format="UINT16"), name="Planned", filename="planned.xml")
    # the real device refuses to read its write-only register
    actual = write_device(fn_xml("a", "10", format="UINT16") + fn_xml("b", "12", format="UINT16"),
                          name="Planned", filename="actual.xml")
    assert run_mdl("gen", described, "--lang", "python", "-o", tmp_path).returncode == 0
    module = import_generated(tmp_path / "planned.py", "planned_driver")
    sim = sim_factory(actual, "--set", "a=1", "--set", "b=2")
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        counting = CountingClient(client)
        dev = module.Planned(counting)
        assert dev.read_all() == {"a": 1, "b": 2}
        assert counting.requests == [("read_holding_registers", 10, 3), ("read_holding_registers", 10, 1),
                                     ("read_holding_registers", 12, 1)]
        counting.requests.clear()
        assert dev.read_all() == {"a": 1, "b": 2}  # remembered: no second try of the refused group
        assert counting.requests == [("read_holding_registers", 10, 1), ("read_holding_registers", 12, 1)]
    finally:
        client.close()


def test_temco_example_driver(sim_factory, tmp_path):
    module = import_generated(EXAMPLE / "temco_tstat.py", "temco_example")
    sim = sim_factory(EXAMPLE / "temco_tstat.xml", "--set", "room_temperature=21.5", "--set", "serial_number=123456",
                      "--set", "occupied_setpoint=22", "--set", "occupancy=1")
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        counting = CountingClient(client)
        dev = module.TemcoTstat(counting)
        values = dev.read_all()
        assert values["room_temperature"] == 21.5 and values["serial_number"] == 123456
        assert values["occupied_setpoint"] == 22.0 and values["occupancy"] == 1.0
        # 0-7, 121, 128, 137, 140, 184, 255-259, 345-346, 348: one request per run of defined addresses
        assert len(counting.requests) == 9
        dev.write_fan_relay_on(1)
        assert dev.read_fan_relay_on() == 1
    finally:
        client.close()
