"""The generated C and C++ drivers over a `modbus_new_rtu` context, on real RTU framing, one suite parametrized
by target (`Native`, tests/support/drivers.py): the test program on one end of a socat pseudo terminal pair,
`mdl sim --serial` on the other, and `mdl read` on the same line to agree with (SPEC section 9). Without socat
or libmodbus the tests are skipped, under CI=true they fail."""

from __future__ import annotations

import errno
import json
import os
import select
import subprocess
import threading
import time
import tty
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import pytest

from mdl.device.output import shown
from mdl.formats.mdl import load_device
from support.common import DATA, EXAMPLE
from support.cpp_harness import MODBUS_ENOBASE, Harness, rtu
from support.drivers import NATIVES, TARGETS, Native
from support.hostile_server import LIES
from support.raw_images import ALL_SETTINGS
from support.run import run_mdl

ALL = DATA / "all_tables.xml"
TSTAT = EXAMPLE / "temco_tstat.xml"
RUN = 30  # seconds any one command may take
TIMEOUT_MS = 500  # the harness' response and byte timeouts
SILENT_BOUND = 5  # seconds a call to a unit that does not answer may take (one try of 0.5 s)


class Built(NamedTuple):
    native: Native
    all_tables: Path  # the test program of all_tables.xml's driver
    tstat: Path  # of the TEMCO thermostat's


@pytest.fixture(scope="module", params=TARGETS)
def built(request, tmp_path_factory) -> Built:
    native = NATIVES[request.param]
    return Built(
        native,
        native.build(load_device(ALL), tmp_path_factory.mktemp(f"serial_all_{native}"), ALL.name),
        native.build(load_device(TSTAT), tmp_path_factory.mktemp(f"serial_tstat_{native}"), TSTAT.name),
    )


def mdl_read(path, client_end: str, *args) -> dict:
    proc = run_mdl("read", path, "--serial", client_end, *args, "--format", "json", timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def as_shown(path, values: dict) -> dict:
    """The harness' values as `mdl read` prints them: enumeration text where the function names it."""
    return {fn.name: shown(fn, values[fn.name]) for fn in load_device(path).functions if fn.name in values}


def read_all(exe, path, client_end: str, unit: int = 1) -> dict:
    """read_all by the harness at `unit`, as `mdl read` prints it; the harness has closed the line when this
    returns, so that `mdl read` can open it."""
    with Harness(exe, rtu(client_end), TIMEOUT_MS, unit=unit, ask_timeout=RUN) as h:
        values = h.values()
    assert "error" not in values, values
    return as_shown(path, values)


def test_read_all_and_writes_agree_with_mdl_read_on_the_line(built, serial_line, sim_factory):
    native = built.native
    device, client_end = serial_line.ends
    sim_factory(ALL, *ALL_SETTINGS, serial=device)
    got = read_all(built.all_tables, ALL, client_end)
    assert got["setpoint"] == 21.5 and got["mode"] == "Cool" and got["label"] == "Hall" and got["pump"] is True
    assert got["big"] == -5000000000 and got["energy"] == 1234.567 and got["door_open"] is True
    native.assert_agree(got, mdl_read(ALL, client_end))
    with Harness(built.all_tables, rtu(client_end), TIMEOUT_MS, ask_timeout=RUN) as h:
        for write in ("setpoint 19.5", f"label {b'Den'.hex()}", "fan 1", "big 7", "low_byte -7", "serial 4000000000"):
            assert h.ask(f"write {write}") == ["ok"], write
        assert h.values("read label") == {"label": "Den"}
    assert mdl_read(ALL, client_end, "setpoint", "label", "fan", "big", "low_byte", "serial") == {
        "setpoint": 19.5,
        "label": "Den",
        "fan": True,
        "big": 7,
        "low_byte": -7,
        "serial": 4000000000,
    }
    proc = run_mdl("write", ALL, "--serial", client_end, "setpoint=23", "mode=Heat", timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    after = read_all(built.all_tables, ALL, client_end)
    assert after["setpoint"] == 23.0 and after["mode"] == "Heat" and after["label"] == "Den"
    native.assert_agree(after, mdl_read(ALL, client_end))


def test_two_devices_on_one_line_at_their_unit_ids(built, serial_line, sim_factory):
    native = built.native
    device, client_end = serial_line.ends
    sim = sim_factory(
        [ALL, TSTAT],
        "--set",
        "setpoint=19.5",
        "--set",
        "occupied_setpoint=22",
        "--set",
        "room_temperature=21.5",
        serial=device,
    )
    assert sim.units == [1, 2]
    table = read_all(built.all_tables, ALL, client_end, unit=1)
    tstat = read_all(built.tstat, TSTAT, client_end, unit=2)
    assert table["setpoint"] == 19.5
    assert tstat["occupied_setpoint"] == 22 and tstat["room_temperature"] == 21.5
    native.assert_agree(table, mdl_read(ALL, client_end, "--unit", "1"))
    native.assert_agree(tstat, mdl_read(TSTAT, client_end, "--unit", "2"))


def test_a_unit_that_does_not_answer_times_out(built, serial_line, sim_factory):
    device, client_end = serial_line.ends
    sim_factory(TSTAT, "--set", "occupied_setpoint=22", serial=device)
    with Harness(built.tstat, rtu(client_end), TIMEOUT_MS, unit=5, ask_timeout=RUN) as h:
        for ask in ("read occupied_setpoint", "all", "write fan_speed 2"):
            started = time.monotonic()
            assert h.values(ask) == {"error": errno.ETIMEDOUT}, ask
            assert time.monotonic() - started < SILENT_BOUND, ask
    # the silent unit did not upset the line: the device on it still answers, and was not written
    assert read_all(built.tstat, TSTAT, client_end)["occupied_setpoint"] == 22
    assert mdl_read(TSTAT, client_end, "fan_speed") == {"fan_speed": 0}


def test_a_serial_device_that_cannot_be_opened(built, tmp_path):
    missing = tmp_path / "ttyUSB9"
    proc = subprocess.run(
        [str(built.all_tables), rtu(str(missing))], input="", capture_output=True, text=True, timeout=RUN
    )
    assert (proc.returncode, proc.stdout) == (1, "connect failed: No such file or directory\n")


@contextmanager
def lying_device(device: str, answer):
    """On `device` (one end of a serial line), answer each 8-byte RTU request with `answer(request)`."""
    fd = os.open(device, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    stopping = threading.Event()

    def serve():
        request = b""
        while not stopping.is_set():
            if select.select([fd], [], [], 0.05)[0]:
                request += os.read(fd, 256)
                if len(request) >= 8:
                    os.write(fd, answer(request[:8]))
                    request = request[8:]

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stopping.set()
        thread.join(timeout=5)
        os.close(fd)


RTU_ERRNO = {
    "other_unit": MODBUS_ENOBASE + 17,
    "short": MODBUS_ENOBASE + 13,  # EMBBADSLAVE, EMBBADDATA
    "bad_crc": MODBUS_ENOBASE + 12,
}  # EMBBADCRC


@pytest.mark.parametrize("lie", sorted(RTU_ERRNO))
def test_rtu_replies_are_checked_before_they_are_trusted(built, serial_line, lie):
    """The harness aborts when a failed read stores a value: -1 with errno, and nothing read."""
    device, client_end = serial_line.ends
    with (
        lying_device(device, LIES[lie][0]),
        Harness(built.all_tables, rtu(client_end), TIMEOUT_MS, ask_timeout=RUN) as h,
    ):
        started = time.monotonic()
        assert h.values("read setpoint") == {"error": RTU_ERRNO[lie]}
        assert time.monotonic() - started < SILENT_BOUND
