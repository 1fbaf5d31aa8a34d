"""`mdl sim`: strict addresses, seeding, the ready line, clean stop, several devices on one connection."""

from __future__ import annotations

import json
import signal

import pytest
from pymodbus.client import ModbusTcpClient

from support.common import DATA, EXAMPLE, ROOT
from support.devices import Sim
from support.run import assert_clean_error, run_mdl

ALL = DATA / "all_tables.xml"
TSTAT = EXAMPLE / "temco_tstat.xml"
HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"


@pytest.fixture
def client_for():
    clients = []

    def connect(sim):
        c = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
        assert c.connect()
        clients.append(c)
        return c

    yield connect
    for c in clients:
        c.close()


def test_ready_line_and_clean_stop_on_sigint():
    sim = Sim(ALL, "--unit", "7")
    assert sim.ready_line == f"mdl sim: serving All Tables on 127.0.0.1:{sim.port} unit 7"
    assert sim.stop(signal.SIGINT) == 0
    assert "Traceback" not in sim.stderr


def test_clean_stop_on_sigterm():
    sim = Sim(TSTAT)
    assert sim.stop(signal.SIGTERM) == 0
    assert "Traceback" not in sim.stderr


def test_only_defined_addresses_answer(sim_factory, client_for):
    c = client_for(sim_factory(ALL))
    assert c.read_holding_registers(100, count=6, device_id=1).registers == [0] * 6
    for call, address, count in [
        ("read_holding_registers", 99, 1),
        ("read_holding_registers", 100, 7),
        ("read_holding_registers", 51, 1),
        ("read_input_registers", 4, 1),
        ("read_coils", 2, 1),
        ("read_discrete_inputs", 0, 3),
    ]:
        rr = getattr(c, call)(address, count=count, device_id=1)
        assert rr.isError() and rr.exception_code == 2, (call, address, count)
    assert c.read_coils(0, count=2, device_id=1).bits[:2] == [False, False]


def test_writes_to_read_only_functions_are_refused(sim_factory, client_for):
    c = client_for(sim_factory(ALL))
    rr = c.write_register(110, 5, device_id=1)  # status_bit has access read
    assert rr.isError() and rr.exception_code == 2
    assert not c.write_register(100, 215, device_id=1).isError()
    assert c.read_holding_registers(100, count=1, device_id=1).registers == [215]


def test_other_unit_ids_get_exception_11_and_unit_0_answers_any(sim_factory, client_for):
    c = client_for(sim_factory(ALL, "--unit", "3"))
    assert not c.read_holding_registers(100, count=1, device_id=3).isError()
    for rr in (c.read_holding_registers(100, count=1, device_id=4), c.write_coil(0, True, device_id=4)):
        assert rr.isError() and rr.exception_code == 11
    c = client_for(sim_factory(ALL, "--unit", "0"))
    assert not c.read_holding_registers(100, count=1, device_id=9).isError()


def test_registers_json_then_set(tmp_path, sim_factory, client_for):
    raw = tmp_path / "raw.json"
    raw.write_text(
        json.dumps({"holding": {"100": 215, "101": 2}, "input": {"10": 2301}, "coil": {"1": 1}, "discrete": {"0": 1}})
    )
    sim = sim_factory(
        ALL, "--registers", raw, "--set", "setpoint=19.5", "--set", "label=AB", "--set", "energy=1234.567"
    )
    c = client_for(sim)
    assert c.read_holding_registers(100, count=3, device_id=1).registers == [195, 2, 0x4142]
    assert c.read_input_registers(10, count=1, device_id=1).registers == [2301]
    assert c.read_input_registers(0, count=2, device_id=1).registers == [1234567 & 0xFFFF, 1234567 >> 16]
    assert c.read_coils(1, count=1, device_id=1).bits[0] is True
    assert c.read_discrete_inputs(0, count=1, device_id=1).bits[0] is True


@pytest.mark.parametrize(
    "args, message",
    [
        (["--set", "nosuch=1"], "no function 'nosuch'"),
        (["--set", "setpoint=99"], "above the maximum"),
        (["--set", "setpoint"], "NAME=VALUE"),
        ([TSTAT, "--set", "nosuch=1"], "--set nosuch: no function 'nosuch' in any of the 2 devices"),
    ],
    ids=["unknown", "out-of-range", "no-value", "unknown-in-several"],
)
def test_bad_settings(args, message):
    proc = run_mdl("sim", ALL, "--port", "0", *args, timeout=30)
    assert proc.returncode in (1, 2)
    assert_clean_error(proc, proc.returncode, message)


def test_bad_registers_file(tmp_path):
    raw = tmp_path / "raw.json"
    raw.write_text('{"holding": {"999": 1}}')
    assert_clean_error(run_mdl("sim", ALL, "--port", "0", "--registers", raw), 1, "999", "not defined")
    raw.write_text('{"holding": {"100": 1}')
    assert_clean_error(run_mdl("sim", ALL, "--port", "0", "--registers", raw), 1, f"{raw}:1:")


def test_port_in_use_is_a_clean_error_that_says_so(sim_factory):
    """The port another program holds is said as such, with what to do, and no line of pymodbus's
    (which labelled its "Failed to start server" as a client's message; issue 37)."""
    sim = sim_factory(ALL)
    proc = run_mdl("sim", ALL, "--port", sim.port, timeout=30)
    assert_clean_error(
        proc,
        1,
        f"cannot serve on 127.0.0.1:{sim.port}: address already in use",
        "choose another --port, or --port 0 for a free one",
    )
    assert proc.stderr.count("\n") == 1 and "client" not in proc.stderr


@pytest.mark.parametrize(
    "raw",
    ['{"holding": {"100": Infinity}}', '{"holding": {"100": 1.5}}', '{"holding": {"100": ' + "1" * 5000 + "}}"],
    ids=["infinity", "fraction", "huge"],
)
def test_registers_json_refuses_what_is_no_register_value(raw, tmp_path):
    (tmp_path / "raw.json").write_text(raw)
    assert_clean_error(run_mdl("sim", ALL, "--port", "0", "--registers", tmp_path / "raw.json"), 1, "raw.json")


def read_json(sim, path, unit, *names):
    return run_mdl("read", path, "--host", sim.host, "--port", sim.port, "--unit", unit, *names, "--format", "json")


def test_devices_share_a_connection_at_their_units(sim_factory):
    sim = sim_factory(
        [ALL, TSTAT], "--unit", "3", "--unit", "7", "--set", "setpoint=19.5", "--set", "occupied_setpoint=22"
    )
    assert sim.ready_lines == [
        f"mdl sim: serving All Tables on 127.0.0.1:{sim.port} unit 3",
        f"mdl sim: serving TEMCO Tstat on 127.0.0.1:{sim.port} unit 7",
    ]
    proc = read_json(sim, ALL, 3, "setpoint")
    assert json.loads(proc.stdout) == {"setpoint": 19.5}, proc.stderr
    proc = read_json(sim, TSTAT, 7, "occupied_setpoint")
    assert json.loads(proc.stdout) == {"occupied_setpoint": 22.0}, proc.stderr
    assert_clean_error(
        read_json(sim, TSTAT, 5, "occupied_setpoint"),
        3,
        f"127.0.0.1:{sim.port} unit 5: ",
        "Modbus exception 11 (GATEWAY TARGET DEVICE FAILED TO RESPOND)",
    )


def test_units_registers_and_settings_by_position(tmp_path, sim_factory, client_for):
    first, second = tmp_path / "first.json", tmp_path / "second.json"
    first.write_text('{"holding": {"101": 1}}')
    second.write_text('{"holding": {"101": 2}}')
    sim = sim_factory([ALL, ALL], "--registers", first, "--registers", second, "--set", "setpoint=19.5")
    assert sim.units == [1, 2]
    c = client_for(sim)
    for unit in (1, 2):  # --set went to both
        assert c.read_holding_registers(100, count=2, device_id=unit).registers == [195, unit]


def test_scenarios_by_position(sim_factory):
    sim = sim_factory([HEAT_PUMP, HEAT_PUMP], "--scenario", "Heating", "--scenario", "Sensor fault")
    assert sim.ready_lines == [f"mdl sim: serving heat_pump on 127.0.0.1:{sim.port} unit {unit}" for unit in (1, 2)]
    for unit, want in (
        (1, {"Mode": "Heating", "FlowTemperature": 35.5}),
        (2, {"Mode": "Off", "FlowTemperature": None}),
    ):
        proc = read_json(sim, HEAT_PUMP, unit, "Mode", "FlowTemperature")
        assert json.loads(proc.stdout) == want, proc.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        ([ALL, TSTAT, "--unit", "3"], "--unit is given 1 time for 2 FILEs: give it once per FILE"),
        ([ALL, "--registers", ALL, "--registers", ALL], "--registers is given 2 times for 1 FILE"),
        ([HEAT_PUMP, HEAT_PUMP, "--scenario", "Heating"], "--scenario is given 1 time for 2 FILEs"),
        ([ALL, TSTAT, "--unit", "4", "--unit", "4"], "--unit 4 is given to more than one FILE"),
        ([ALL, TSTAT, "--unit", "0", "--unit", "4"], "--unit 0 (any unit) serves one FILE only"),
    ],
    ids=["units", "registers", "scenarios", "duplicate-unit", "unit-0"],
)
def test_options_by_position_must_match_the_files(args, message):
    assert_clean_error(run_mdl("sim", *args, "--port", "0", timeout=30), 2, message)


def test_an_expression_cannot_be_set():
    proc = run_mdl("sim", HEAT_PUMP, "--port", "0", "--set", "FlowTemperature=20", timeout=30)
    assert_clean_error(
        proc,
        1,
        "--set FlowTemperature=20: 'FlowTemperature' is an expression, computed from "
        "registers: set the functions or registers it reads instead",
    )
