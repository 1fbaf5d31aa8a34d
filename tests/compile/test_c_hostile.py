"""The generated C99 driver against a lying Modbus server (tests/support/hostile_server.py), built with ASan and
UBSan (-fno-sanitize-recover=all), as tests/compile/test_cpp_hostile.py does for the C++ driver: every lie and
every connection failure is -1 with errno, within the timeout, without a sanitizer report, and without
a value stored (the C harness aborts when a failed read changed its out-parameter, tests/support/c_harness.py).
The outcomes allowed for each mode and command are test_cpp_hostile's table: both drivers sit on the
same libmodbus calls, so they must fail alike.
"""

from __future__ import annotations

import errno
import subprocess
import time
from pathlib import Path

import pytest
from test_cpp_hostile import (
    CALL_BOUND,
    DISCONNECTED,
    READS,
    TIMEOUT_MS,
    WRITES,
    Relay,
    _libmodbus_version,
    assert_no_report,
    expected,
    outcome,
)

from mdl.formats.mdl import load_device
from mdl.targets import render
from support.c_harness import STRICT, harness_source, tool
from support.common import DATA
from support.cpp_harness import Harness, modbus_flags
from support.hostile_server import MODES, hostile_server

pytestmark = pytest.mark.exhaustive  # slow (a sanitizer build): CI runs it

SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-g", "-O1"]


def build_sanitized(workdir: Path, path: Path = DATA / "all_tables.xml") -> Path:
    """The C driver of the description at `path` (all_tables by default) and the C harness, compiled
    by gcc with ASan and UBSan: the driver with the strict flags docs/c-api.md promises, the harness
    (test code) with -std=c99."""
    gcc = tool("gcc")
    cflags, libs = modbus_flags()
    device = load_device(path)
    files = render(device, path.name, "c")
    stem = next(name for name in files if name.endswith(".c"))[:-2]
    for name, text in files.items():
        (workdir / name).write_text(text, encoding="utf-8")
    (workdir / "c_harness.c").write_text(harness_source(device, stem), encoding="utf-8")
    driver = workdir / f"{stem}.o"
    proc = subprocess.run(
        [gcc, *STRICT, *SANITIZE, *cflags, "-c", str(workdir / f"{stem}.c"), "-o", str(driver)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    exe = workdir / "c_harness_san"
    proc = subprocess.run(
        [gcc, "-std=c99", *SANITIZE, *cflags, "-o", str(exe), str(workdir / "c_harness.c"), str(driver), *libs, "-lm"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    return exe


@pytest.fixture(scope="module")
def sanitized(tmp_path_factory):
    return build_sanitized(tmp_path_factory.mktemp("c_hostile"))


def test_the_harness_is_sanitized(sanitized):
    """The control for the tests below: the sanitizers are in the program (a report would be seen)."""
    nm = subprocess.run(["nm", str(sanitized)], capture_output=True, text=True).stdout
    assert "__asan_init" in nm and "__ubsan_handle" in nm


@pytest.mark.parametrize("mode", MODES)
def test_every_lie_is_minus_one_with_errno(sanitized, mode):
    version = _libmodbus_version()
    transcript = []
    with hostile_server(mode) as (_, port):
        h = Harness(sanitized, port, TIMEOUT_MS)
        try:
            for command in (*READS, *WRITES):
                began = time.monotonic()
                lines = h.ask(command)
                took = time.monotonic() - began
                transcript.append(f"{mode} {command}: {lines[0] if lines else '(nothing)'} ({took:.2f} s)")
                assert outcome(lines) in expected(mode, command, version), "\n".join(transcript)
                assert took < CALL_BOUND, "\n".join(transcript)
        finally:
            err = h.close()
    print("\n".join(transcript))
    assert_no_report(err)


def test_honest_replies_give_the_addresses_back(sanitized):
    """The control: each register holds its own address, bits are 1 at odd addresses."""
    with hostile_server("honest") as (_, port):
        h = Harness(sanitized, port, TIMEOUT_MS)
        try:
            values = h.values()
            assert values["pump"] is False and values["fan"] is True and values["filter_dirty"] is True
            assert values["setpoint"] == 10.0 and values["mode"] == 101
            assert values["energy"] == 65.536  # word order little: 1 << 16 | 0
            assert h.values("read mode") == {"mode": 101}
            assert h.ask("write setpoint 5") == ["ok"]
        finally:
            assert_no_report(h.close())


def test_a_dropped_connection_fails_until_the_caller_connects_again(sanitized):
    with hostile_server("drop") as (_, dropping), hostile_server("honest") as (_, honest):
        relay = Relay(dropping)
        h = Harness(sanitized, relay.port, TIMEOUT_MS)
        try:
            assert h.values("read setpoint")["error"] in DISCONNECTED
            assert h.values("write setpoint 5")["error"] in DISCONNECTED  # the socket stays broken
            assert h.values("all")["error"] in DISCONNECTED
            relay.upstream = honest
            assert h.ask("connect") == ["ok"]  # modbus_close + modbus_connect on the same context
            assert h.values("read setpoint") == {"setpoint": 10.0}
            assert h.ask("write setpoint 5") == ["ok"]
            assert h.values()["mode"] == 101
        finally:
            assert_no_report(h.close())
            relay.close()


def test_a_late_reply_is_dropped_before_the_next_request(sanitized):
    """A reply that arrives after its call timed out is not read as the next call's reply."""
    with hostile_server("honest") as (_, honest):
        relay = Relay(honest)
        h = Harness(sanitized, relay.port, TIMEOUT_MS)
        try:
            relay.delay = 1.0
            assert h.values("read mode") == {"error": errno.ETIMEDOUT}
            relay.delay = 0.0
            time.sleep(2.0)  # the late reply of `read mode` (101) waits in the socket
            assert h.values("read setpoint") == {"setpoint": 10.0}
            assert h.values("read mode") == {"mode": 101}
        finally:
            assert_no_report(h.close())
            relay.close()
