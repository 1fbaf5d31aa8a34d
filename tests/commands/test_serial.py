"""Modbus RTU on serial lines and over TCP (SPEC section 9): `mdl read`/`mdl write` and the generated Python
driver against `mdl sim --serial` on a socat pseudo terminal pair, and against `mdl sim --framer rtu`."""

from __future__ import annotations

import asyncio
import json
import os
import select
import socket
import subprocess
import termios
import threading
import time
from contextlib import contextmanager

import pytest
from pymodbus.client import AsyncModbusSerialClient, ModbusSerialClient

from support.common import DATA, EXAMPLE, import_generated
from support.hostile_server import LIES
from support.run import assert_clean_error, cli, run_mdl

ALL = DATA / "all_tables.xml"
TSTAT = EXAMPLE / "temco_tstat.xml"
RUN = 30  # seconds any one command may take
SILENT_BOUND = 10  # seconds a read of a silent unit may take with --timeout 0.5 (2 tries: about 1 s)
SETTINGS = [
    "--set",
    "setpoint=21.5",
    "--set",
    "mode=Cool",
    "--set",
    "label=Hall",
    "--set",
    "energy=1234.567",
    "--set",
    "power=-12.5",
    "--set",
    "pump=1",
    "--set",
    "flow=12.3",
    "--set",
    "big=-5000000000",
]
NO_HOST = "127.0.0.1", "1"  # refused at once


def read_json(connection, path, *args):
    proc = run_mdl("read", path, *connection, *args, "--format", "json", timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_read_and_write_on_a_serial_line_as_on_tcp(serial_line, sim_factory, tmp_path):
    raw = tmp_path / "raw.json"
    raw.write_text(json.dumps({"input": {"10": 2301}, "coil": {"1": 1}, "discrete": {"0": 1, "1": 1}}))
    on_line = sim_factory(ALL, "--registers", raw, *SETTINGS, serial=serial_line.ends[0])
    assert on_line.ready_line == f"mdl sim: serving All Tables on {serial_line.ends[0]} unit 1"
    on_tcp = sim_factory(ALL, "--registers", raw, *SETTINGS)
    client_end = ["--serial", serial_line.ends[1]]
    values = read_json(client_end, ALL)
    assert values == read_json(on_tcp.connection, ALL)
    assert values["setpoint"] == 21.5 and values["voltage"] == 230.1 and values["door_open"] is True
    proc = run_mdl("write", ALL, *client_end, "setpoint=19", "label=Den", "fan=1", timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    assert read_json(client_end, ALL, "setpoint", "label", "fan") == {"setpoint": 19.0, "label": "Den", "fan": True}


def test_two_devices_on_one_line_and_a_unit_that_is_not_there(serial_line, sim_factory):
    device, client_end = serial_line.ends
    sim = sim_factory(
        [ALL, TSTAT],
        "--unit",
        "3",
        "--unit",
        "7",
        "--set",
        "setpoint=19.5",
        "--set",
        "occupied_setpoint=22",
        serial=device,
    )
    assert sim.ready_lines == [
        f"mdl sim: serving All Tables on {device} unit 3",
        f"mdl sim: serving TEMCO Tstat on {device} unit 7",
    ]
    assert read_json(["--serial", client_end, "--unit", "3"], ALL, "setpoint") == {"setpoint": 19.5}
    assert read_json(["--serial", client_end, "--unit", "7"], TSTAT, "occupied_setpoint") == {"occupied_setpoint": 22}
    started = time.monotonic()
    proc = run_mdl(
        "read", TSTAT, "--serial", client_end, "--unit", "5", "--timeout", "0.5", "occupied_setpoint", timeout=RUN
    )
    elapsed = time.monotonic() - started
    assert_clean_error(
        proc,
        3,
        f"{client_end} (19200 8N1) unit 5: ",
        "no reply within 0.5 s (2 tries)",
        "check baud rate, parity and unit id",
    )
    assert elapsed < SILENT_BOUND, elapsed
    # the silent unit did not upset the line: the devices on it still answer
    assert read_json(["--serial", client_end, "--unit", "7"], TSTAT, "occupied_setpoint") == {"occupied_setpoint": 22}


class UartLine:
    """Two pseudo terminals wired like two UARTs: bytes pass unchanged while both ends are set to the same
    speed, and arrive changed when they are not, as a receiver sampling at the wrong speed reads other bits.

    A pseudo terminal carries bytes whatever speed its programs set (socat's pairs too), so this line
    looks at the speed each end's program set (a master's termios are its terminal's) for every chunk."""

    def __init__(self):
        self.masters, self.terminals, self.ends = [], [], []
        for _ in range(2):
            master, terminal = os.openpty()  # the terminal stays open here too: the line lives between opens
            self.masters.append(master)
            self.terminals.append(terminal)
            self.ends.append(os.ttyname(terminal))
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._carry, daemon=True)
        self.thread.start()

    def _speed(self, master: int) -> int:
        return termios.tcgetattr(master)[5]  # ospeed

    def _carry(self) -> None:
        while not self.stopping.is_set():
            ready, _, _ = select.select(self.masters, [], [], 0.05)
            for master in ready:
                data = os.read(master, 4096)
                other = self.masters[1 - self.masters.index(master)]
                if self._speed(master) != self._speed(other):
                    data = bytes(b ^ 0xFF for b in data)
                os.write(other, data)

    def close(self) -> None:
        self.stopping.set()
        self.thread.join(timeout=5)
        for fd in self.masters + self.terminals:
            os.close(fd)


@pytest.fixture
def uart_line():
    line = UartLine()
    try:
        yield line
    finally:
        line.close()


def test_wrong_baud_rate_on_one_side_gets_no_answer(uart_line, sim_factory):
    device, client_end = uart_line.ends
    sim_factory(TSTAT, "--baud", "9600", "--set", "occupied_setpoint=22", serial=device)
    assert read_json(["--serial", client_end, "--baud", "9600"], TSTAT, "occupied_setpoint") == {
        "occupied_setpoint": 22
    }
    started = time.monotonic()
    proc = run_mdl(
        "read", TSTAT, "--serial", client_end, "--baud", "19200", "--timeout", "0.5", "occupied_setpoint", timeout=RUN
    )
    assert_clean_error(proc, 3, f"{client_end} (19200 8N1) unit 1: ", "check baud rate, parity and unit id")
    assert time.monotonic() - started < SILENT_BOUND


def test_rtu_frames_over_tcp(sim_factory):
    sim = sim_factory(TSTAT, "--framer", "rtu", "--set", "occupied_setpoint=22", "--unit", "4")
    rtu = [*sim.connection, "--framer", "rtu", "--unit", "4"]
    proc = run_mdl("write", TSTAT, *rtu, "occupied_setpoint=23.5", "fan_speed=2", timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    assert read_json(rtu, TSTAT, "occupied_setpoint", "fan_speed") == {"occupied_setpoint": 23.5, "fan_speed": 2}
    # a unit the converter's line does not have: no answer, as on the line itself
    proc = run_mdl(
        "read", TSTAT, *sim.connection, "--framer", "rtu", "--unit", "5", "--timeout", "0.5", "fan_speed", timeout=RUN
    )
    assert_clean_error(
        proc, 3, f"{sim.host}:{sim.port} (RTU over TCP) unit 5: ", "no reply within 0.5 s", "check the unit id"
    )


@contextmanager
def lying_rtu_device(answer):
    """A TCP server that answers each RTU request with `answer(request)`, until the block ends."""
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.1)
    stopping = threading.Event()

    def serve():
        while not stopping.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            with conn:
                conn.settimeout(0.1)
                while not stopping.is_set():
                    try:
                        request = conn.recv(256)
                    except TimeoutError:
                        continue
                    if not request:
                        break
                    conn.sendall(answer(request))

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield listener.getsockname()[1]
    finally:
        stopping.set()
        thread.join(timeout=5)
        listener.close()


@pytest.mark.parametrize("lie", sorted(LIES))
def test_rtu_replies_are_checked_before_they_are_trusted(lie):
    answer, message = LIES[lie]
    with lying_rtu_device(answer) as port:
        proc = cli(
            "read",
            TSTAT,
            "--host",
            "127.0.0.1",
            "--port",
            port,
            "--framer",
            "rtu",
            "--timeout",
            "0.3",
            "--retries",
            "0",
            "occupied_setpoint",
        )
    assert_clean_error(proc, 3, f"127.0.0.1:{port} (RTU over TCP) unit 1: reading 1 holding from ", message)


def test_serial_device_that_cannot_be_opened(tmp_path):
    missing = tmp_path / "ttyUSB9"
    for command in (["read", TSTAT, "--unit", "7"], ["write", TSTAT, "--unit", "7", "fan_speed=1"]):
        assert_clean_error(
            cli(*command, "--serial", missing),
            3,
            f"cannot open serial device {missing} for unit 7: No such file or directory",
        )
    assert_clean_error(cli("read", TSTAT, "--serial", " "), 2, "give the serial device's name")
    not_a_terminal = tmp_path / "plain"
    not_a_terminal.write_text("")
    assert_clean_error(cli("read", TSTAT, "--serial", not_a_terminal), 3, "not a serial device")
    assert_clean_error(
        run_mdl("sim", TSTAT, "--serial", missing, timeout=RUN),
        1,
        f"cannot serve on {missing}: No such file or directory",
    )


def test_settings_a_serial_device_refuses(serial_line):
    """Parity on a pseudo terminal: some kernels refuse it (EINVAL), others take it. Either it works,
    or every command says which settings the device refused: exit 3 (read) or 1 (sim), no traceback."""
    end = serial_line.ends[0]
    try:
        proc = run_mdl("sim", TSTAT, "--serial", end, "--parity", "E", timeout=5)
    except subprocess.TimeoutExpired:  # it serves: this kernel takes parity on a pseudo terminal
        return
    assert_clean_error(proc, 1, f"cannot serve on {end}: ")
    assert_clean_error(
        cli("read", TSTAT, "--serial", end, "--parity", "E"),
        3,
        f"cannot open serial device {end} for unit 1: it refuses 19200 8E1 (",
    )


def test_a_serial_device_another_program_has_open(serial_line, sim_factory):
    sim_factory(TSTAT, serial=serial_line.ends[0])
    assert_clean_error(
        cli("read", TSTAT, "--serial", serial_line.ends[0]),
        3,
        f"cannot open serial device {serial_line.ends[0]} for unit 1: another program has it open",
    )


@pytest.mark.parametrize(
    "args, message",
    [
        ([], "give --host HOST (Modbus TCP) or --serial DEVICE (Modbus RTU)"),
        (["--serial", "/dev/ttyUSB0", "--host", NO_HOST[0]], "--serial and --host: give one connection"),
        (["--serial", "/dev/ttyUSB0", "--port", "503"], "--serial and --port"),
        (["--serial", "/dev/ttyUSB0", "--framer", "tcp"], "a serial line carries RTU frames"),
        (["--host", NO_HOST[0], "--baud", "9600"], "--baud sets a serial line: it needs --serial DEVICE"),
        (["--host", NO_HOST[0], "--parity", "X"], "--parity"),
        (["--host", NO_HOST[0], "--stopbits", "3"], "--stopbits"),
    ],
    ids=[
        "none",
        "serial-and-host",
        "serial-and-port",
        "serial-tcp-framer",
        "baud-without-serial",
        "parity",
        "stopbits",
    ],
)
def test_connection_options_that_contradict_each_other(args, message):
    assert_clean_error(cli("read", TSTAT, *args), 2, message)


def test_sim_refuses_contradicting_connection_options():
    assert_clean_error(cli("sim", TSTAT, "--serial", "/dev/ttyUSB0", "--port", "0"), 2, "--serial and --port")
    assert_clean_error(cli("sim", TSTAT, "--parity", "E"), 2, "--parity sets a serial line")


@pytest.fixture(scope="module")
def tstat_driver(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial_driver")
    proc = run_mdl("gen", TSTAT, "--lang", "python", "-o", out, timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    return import_generated(out / "temco_tstat.py", "temco_tstat_serial_driver")


def test_generated_driver_over_a_sync_serial_client(tstat_driver, serial_line, sim_factory):
    sim_factory(
        TSTAT,
        "--unit",
        "9",
        "--set",
        "occupied_setpoint=22",
        "--set",
        "room_temperature=21.5",
        serial=serial_line.ends[0],
    )
    client = ModbusSerialClient(serial_line.ends[1], baudrate=19200, timeout=2, retries=1)
    assert client.connect()
    try:
        dev = tstat_driver.TemcoTstat(client, unit=9)
        assert dev.read_room_temperature() == 21.5
        dev.write_occupied_setpoint(23.5)
        values = dev.read_all()
        assert values["occupied_setpoint"] == 23.5 and values["room_temperature"] == 21.5
        silent = tstat_driver.TemcoTstat(client, unit=10)  # nobody at unit 10: no answer
        with pytest.raises(tstat_driver.CommunicationError):
            silent.read_room_temperature()
        assert dev.read_occupied_setpoint() == 23.5  # the driver connects again after the failure
    finally:
        client.close()


def test_generated_driver_over_an_async_serial_client(tstat_driver, serial_line, sim_factory):
    sim_factory(TSTAT, "--set", "occupied_setpoint=22", serial=serial_line.ends[0])

    async def main():
        client = AsyncModbusSerialClient(serial_line.ends[1], baudrate=19200, timeout=2, retries=1)
        assert await client.connect()
        try:
            dev = tstat_driver.AsyncTemcoTstat(client)
            assert await dev.read_occupied_setpoint() == 22
            await dev.write_fan_speed(3)
            values = await dev.read_all()
            assert values["fan_speed"] == 3 and values["occupied_setpoint"] == 22
        finally:
            client.close()

    asyncio.run(asyncio.wait_for(main(), RUN))
