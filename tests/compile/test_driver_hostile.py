"""The generated C and C++ drivers against a lying Modbus server (tests/support/hostile_server.py), one suite
parametrized by target (`Native`, tests/support/drivers.py), built with ASan and UBSan
(-fno-sanitize-recover=all): every lie and every connection failure is -1 with errno, within the timeout,
without a sanitizer report, and without a value stored (the test programs abort when a failed read changed
its out-parameter, tests/support/c_harness.py and cpp_harness.py). docs/cpp-api.md ("Replies") lists the lies
libmodbus 3.1.6 lets through; the table below pins them, for both drivers: they sit on the same libmodbus
calls, so they must fail alike.
"""

from __future__ import annotations

import errno
import shutil
import socket
import subprocess
import threading
import time
from contextlib import suppress

import pytest

from mdl.formats.mdl import load_device
from support.common import DATA
from support.cpp_harness import MODBUS_ENOBASE, Harness
from support.drivers import NATIVES, TARGETS
from support.hostile_server import MODES, hostile_server

pytestmark = pytest.mark.exhaustive  # slow (sanitizer builds): CI runs it

TIMEOUT_MS = 500
CALL_BOUND = 2.5  # seconds a call may take: the response timeout, a byte timeout, and sanitizer overhead
EMBXSFAIL = MODBUS_ENOBASE + 4
EMBBADDATA = MODBUS_ENOBASE + 13
DISCONNECTED = {errno.ECONNRESET, errno.EPIPE}
OK = "ok"

# command -> what it sends (all_tables.xml); `all` is read_all, one request per group of every table
READS = {
    "read pump": "FC01",
    "read door_open": "FC02",
    "read setpoint": "FC03",
    "read label": "FC03",
    "read energy": "FC04",
    "read flow": "FC03",
    "all": "all",
}
WRITES = {"write pump 1": "FC05", "write setpoint 5": "FC06", "write big 7": "FC16", "write label 41": "FC16"}


def _libmodbus_version() -> str:
    pkg = shutil.which("pkg-config")
    assert pkg is not None  # the sanitized driver was built with it
    return subprocess.run([pkg, "--modversion", "libmodbus"], capture_output=True, text=True).stdout.strip()


def expected(mode: str, command: str, version: str) -> set[object]:
    """The outcomes allowed for a command in a mode: OK, or an errno."""
    fc = READS.get(command) or WRITES[command]
    read = command in READS
    if mode == "honest":
        return {OK}
    if mode in ("wrong_function_code", "extra_registers", "wrong_transaction_id", "garbage"):
        return {EMBBADDATA}
    if mode == "short":
        return {EMBBADDATA} if read else {errno.ETIMEDOUT}  # a write's echo is waited for to its end
    if mode in ("bad_byte_count", "long_byte_count") and fc in ("FC05", "FC06"):
        # libmodbus 3.1.6 does not compare a single write's echoed value (newer sources do)
        return {OK} if version == "3.1.6" else {OK, EMBBADDATA}
    if mode == "bad_byte_count":
        return {EMBBADDATA}
    if mode == "long_byte_count":
        return {errno.ETIMEDOUT} if read else {EMBBADDATA}  # a read waits for the bytes it was promised
    if mode == "exception":
        return {EMBXSFAIL}
    if mode == "wrong_unit":
        return {OK} if version == "3.1.6" else {OK, EMBBADDATA, MODBUS_ENOBASE + 17}  # + EMBBADSLAVE
    if mode == "silent":
        return {errno.ETIMEDOUT}
    assert mode in ("drop", "reset"), mode
    return DISCONNECTED


def outcome(lines: list[str]) -> object:
    if lines and lines[0].startswith("error "):
        return int(lines[0].split()[1])
    return OK if lines else None


@pytest.fixture(scope="module", params=TARGETS)
def sanitized(request, tmp_path_factory):
    """The sanitized test program of all_tables.xml's driver, for each target."""
    native = NATIVES[request.param]
    path = DATA / "all_tables.xml"
    return native.build_sanitized(load_device(path), tmp_path_factory.mktemp(f"{native}_hostile"), path.name)


def assert_no_report(err: str) -> None:
    assert not any(word in err for word in ("runtime error", "AddressSanitizer", "LeakSanitizer")), err


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
            assert h.ask("write setpoint 5") == [OK]
        finally:
            assert_no_report(h.close())


class Relay:
    """A TCP relay on 127.0.0.1 to the port in `upstream` when a connection arrives; replies are passed
    on `delay` seconds after they arrive. When either side closes, both are closed."""

    def __init__(self, upstream: int):
        self.upstream = upstream
        self.delay = 0.0
        self.stop = threading.Event()
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.settimeout(0.1)
        self.port = self.listener.getsockname()[1]
        self.sockets: list[socket.socket] = []
        self.threads = [threading.Thread(target=self._accept, daemon=True)]
        self.threads[0].start()

    def _accept(self) -> None:
        while not self.stop.is_set():
            try:
                client, _ = self.listener.accept()
            except TimeoutError:
                continue
            server = socket.create_connection(("127.0.0.1", self.upstream))
            for sock in (client, server):
                sock.settimeout(0.1)
                self.sockets.append(sock)
            for src, dst, delayed in ((client, server, False), (server, client, True)):
                thread = threading.Thread(target=self._pump, args=(src, dst, delayed), daemon=True)
                self.threads.append(thread)
                thread.start()

    def _pump(self, src: socket.socket, dst: socket.socket, delayed: bool) -> None:
        with suppress(OSError):
            while not self.stop.is_set():
                try:
                    data = src.recv(4096)
                except TimeoutError:
                    continue
                if not data:
                    break
                if delayed:
                    time.sleep(self.delay)
                dst.sendall(data)
        for sock in (src, dst):
            with suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)

    def close(self) -> None:
        self.stop.set()
        for thread in self.threads:
            thread.join(timeout=5)
        for sock in (self.listener, *self.sockets):
            sock.close()


def test_a_dropped_connection_fails_until_the_caller_connects_again(sanitized):
    with hostile_server("drop") as (_, dropping), hostile_server("honest") as (_, honest):
        relay = Relay(dropping)
        h = Harness(sanitized, relay.port, TIMEOUT_MS)
        try:
            assert h.values("read setpoint")["error"] in DISCONNECTED
            assert h.values("write setpoint 5")["error"] in DISCONNECTED  # the socket stays broken
            assert h.values("read setpoint")["error"] in DISCONNECTED
            assert h.values("all")["error"] in DISCONNECTED
            relay.upstream = honest
            assert h.ask("connect") == [OK]  # modbus_close + modbus_connect on the same context
            assert h.values("read setpoint") == {"setpoint": 10.0}
            assert h.ask("write setpoint 5") == [OK]
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
