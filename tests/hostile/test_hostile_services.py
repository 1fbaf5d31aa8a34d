"""mdl's network services under pressure (issue 34, findings 5-7), each run with its open-file limit lowered
(FILES) so that a few hundred idle connections (FLOOD) do what thousands do to a process with the usual limit:

- `mdl read --interval S --publish prometheus://...`: the metrics server holds a bounded number of
  connections, so the poller can still reconnect to its device, and a scrape after the flood is answered;
  a connection that cannot be opened for want of files in mdl is said as such, never blamed on the device.
- `mdl sim` / `mdl serve`: a flood of idle connections neither stops the server answering the clients that
  ask, nor fills stderr with a traceback per refused accept, nor keeps the gateway from its device.
- `mdl serve`: once its device goes silent, no value older than the poll interval plus one request's
  time is served as a number (SPEC 13: "not implemented").

Only loopback traffic; every wait is bounded by a guard that only ends a hang (no timing is asserted,
except that the gateway's values are *older* than its bound when read, which a slow machine only makes more so).
"""

from __future__ import annotations

import errno
import json
import os
import resource
import signal
import socket
import struct
import subprocess
import threading
import time
import urllib.request
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress

import pytest

from support.common import DATA, ROOT
from support.devices import Sim
from support.run import assert_clean_error, cli, mdl_cmd

ALL = DATA / "all_tables.xml"
METER = ROOT / "examples" / "profiles" / "meter_a.xml"
FILES = 256  # the open-file limit of the process under test
FLOOD = 400  # idle connections: more than FILES
GUARD = 30.0  # seconds: only a hang takes this long
READ_HOLDING_100 = (bytes([0x03, 0, 100, 0, 1]), bytes([0x03, 2, 0, 0]))  # all_tables: holding 100 reads 0


def _few_files() -> None:
    hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
    resource.setrlimit(resource.RLIMIT_NOFILE, (FILES, hard))


class Process:
    """An mdl command run with FILES open files at most; its stdout and stderr lines collected as they come."""

    def __init__(self, *args: object) -> None:
        self.proc = subprocess.Popen(
            mdl_cmd(*args),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=_few_files,
            env={**os.environ, "PYTHONWARNINGS": "ignore"},
        )
        self.out: list[str] = []
        self.err: list[str] = []
        self.readers = [
            threading.Thread(target=self._collect, args=(self.proc.stdout, self.out), daemon=True),
            threading.Thread(target=self._collect, args=(self.proc.stderr, self.err), daemon=True),
        ]
        for reader in self.readers:
            reader.start()

    @staticmethod
    def _collect(stream, lines: list[str]) -> None:
        for line in stream:
            lines.append(line)

    def wait_for(self, lines: list[str], wanted: Callable[[str], bool], start: int = 0) -> str:
        """The first line from index `start` on for which `wanted` holds (a hang fails the test)."""
        end = time.monotonic() + GUARD
        while time.monotonic() < end:
            for line in lines[start:]:
                if wanted(line):
                    return line
            assert self.proc.poll() is None, (self.proc.returncode, "".join(self.err)[-3000:])
            time.sleep(0.05)
        said = "".join(lines[start:])[-2000:]
        raise AssertionError(f"no such line in {GUARD} s: {said!r}; its stderr ends {self.err[-2:]!r}")

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=GUARD)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise AssertionError("it did not stop on SIGTERM") from None
        for reader in self.readers:
            reader.join(timeout=GUARD)
        return self.proc.returncode

    @property
    def stderr(self) -> str:
        return "".join(self.err)


@contextmanager
def flood(port: int, count: int = FLOOD) -> Iterator[list[socket.socket]]:
    """`count` idle connections to 127.0.0.1:`port` (fewer if the server stops accepting), closed at the end;
    paced (a pause every 16) so that the kernel's listen queue is drained between them: a full queue drops the
    handshake, and the client's retry a second later would only make the test slow."""
    idle: list[socket.socket] = []
    try:
        for i in range(count):
            if i % 16 == 15:
                time.sleep(0.02)
            try:
                idle.append(socket.create_connection(("127.0.0.1", port), timeout=2))
            except OSError:
                break
        yield idle
    finally:
        for sock in idle:
            sock.close()


def tcp_request(sock: socket.socket, pdu: bytes, tid: int = 7) -> bytes:
    """One Modbus TCP request to unit 1; the reply's PDU (b'' if the server closed the connection)."""
    sock.sendall(struct.pack(">HHHB", tid, 0, len(pdu) + 1, 1) + pdu)
    data = b""
    while len(data) < 7 or len(data) < 6 + struct.unpack(">H", data[4:6])[0]:
        chunk = sock.recv(260)
        if not chunk:
            return b""
        data += chunk
    return data[7:]


# --- finding 5: the Prometheus endpoint -----------------------------------------------------------------


def test_a_flood_of_metrics_connections_never_starves_the_poller(sim_factory):
    sim = sim_factory(ALL)
    poller = Process(
        "read", ALL, *sim.connection, "--interval", "0.2", "--format", "json", "--timeout", "1", "--retries", "0",
        "--publish", "prometheus://127.0.0.1:0",
    )  # fmt: skip
    try:
        note = poller.wait_for(poller.err, lambda line: "serving Prometheus metrics on" in line)
        port = int(note.rsplit(":", 1)[1].split("/", 1)[0])
        with flood(port) as idle:
            sim.stop()  # the device restarts: the poller must open a new connection to it
            poller.wait_for(poller.err, lambda line: "error" in line)  # a poll failed: the connection is gone
            again = Sim(ALL, port=sim.port)
            try:
                since = len(poller.out)
                record = poller.wait_for(poller.out, lambda line: line.startswith("{"), since)
                assert "time" in json.loads(record)  # a whole record: the device read again
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=GUARD) as reply:
                    metrics = reply.read().decode()
                assert 'mdl_poll_up{device="all_tables",unit="1"}' in metrics, metrics
            finally:
                assert again.stop() == 0
            assert len(idle) == FLOOD  # the server went on accepting (and closing the oldest idle ones)
    finally:
        poller.stop()
    assert "Traceback" not in poller.stderr, poller.stderr[-3000:]
    assert "open files" not in poller.stderr, poller.stderr[-3000:]


def test_clients_that_trickle_their_headers_never_hold_the_metrics_shut(sim_factory):
    """16 clients (the most the endpoint holds) send a request line and then a header now and then: they
    have not asked yet, so a scraper pushes them out, and every scrape is answered."""
    sim = sim_factory(ALL)
    poller = Process("read", ALL, *sim.connection, "--interval", "0.5", "--publish", "prometheus://127.0.0.1:0")
    hogs: list[socket.socket] = []
    try:
        note = poller.wait_for(poller.err, lambda line: "serving Prometheus metrics on" in line)
        port = int(note.rsplit(":", 1)[1].split("/", 1)[0])
        for _ in range(16):
            hog = socket.create_connection(("127.0.0.1", port), timeout=GUARD)
            hog.sendall(b"GET /metrics HTTP/1.0\r\nX-a: 1\r\n")
            hogs.append(hog)
        time.sleep(0.3)
        for _ in range(3):
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=GUARD) as reply:
                assert reply.status == 200
            for hog in hogs:
                with suppress(OSError):
                    hog.sendall(b"X-b: 1\r\n")  # never idle long enough to be closed for it
            time.sleep(0.3)
    finally:
        for hog in hogs:
            hog.close()
        poller.stop()
    assert "Traceback" not in poller.stderr, poller.stderr[-3000:]


def test_the_gateway_serves_a_slow_lines_values_between_its_polls():
    """A poll that takes longer than the interval (a slow RTU line answering every request) leaves its
    values served until the next poll should have ended: a slow device is no silent one."""
    from mdl.device.server.serve import Poller

    poller = Poller.__new__(Poller)
    poller.interval, poller.timeout = 1.0, 3.0
    now = time.monotonic()
    poller.latest = ({"power_w": 1.0}, now - 6.0, 5.0)  # a 5 s poll ended 6 s ago: the next is still running
    assert poller.current() == {"power_w": 1.0}
    poller.latest = ({"power_w": 1.0}, now - 8.5, 5.0)  # past its own time plus a request's: stale
    assert poller.current() is None
    poller.latest = ({"power_w": 1.0}, now - 4.5, 0.1)  # a quick poll: the interval plus a request's time
    assert poller.current() is None


def test_a_local_shortage_of_files_is_not_blamed_on_the_device(sim_factory, monkeypatch):
    """The system refuses mdl a socket (EMFILE) while the device is up: the message says it is mdl's."""
    sim = sim_factory(ALL)

    def out_of_files(self, *args, **kwargs):
        raise OSError(errno.EMFILE, os.strerror(errno.EMFILE))

    monkeypatch.setattr(socket.socket, "__init__", out_of_files)
    proc = cli("read", ALL, *sim.connection, "--format", "json")
    monkeypatch.undo()
    assert_clean_error(proc, 3, "too many open files in mdl", "the device was not asked")
    assert "no Modbus TCP device answers" not in proc.stderr, proc.stderr


# --- finding 6: mdl sim and mdl serve ------------------------------------------------------------------


def test_sim_keeps_answering_its_clients_through_a_flood_and_says_it_once():
    sim = Process("sim", ALL, "--port", "0")
    try:
        ready = sim.wait_for(sim.out, lambda line: line.startswith("mdl sim: serving"))
        port = int(ready.rsplit(" unit ", 1)[0].rsplit(":", 1)[1])
        request, reply = READ_HOLDING_100
        with socket.create_connection(("127.0.0.1", port), timeout=GUARD) as client:
            assert tcp_request(client, request) == reply
            with flood(port) as idle:
                assert len(idle) > FILES
                assert tcp_request(client, request) == reply  # the client that asks is still answered
                with socket.create_connection(("127.0.0.1", port), timeout=GUARD) as late:
                    assert tcp_request(late, request) == reply  # and a new one too
    finally:
        status = sim.stop()
    assert status == 0, sim.stderr[-3000:]
    assert "Traceback" not in sim.stderr, sim.stderr[:3000]
    assert len(sim.err) <= 4, sim.stderr[:3000]  # one line, at most every 10 s, and one at the end
    assert "closed for newer ones" in sim.stderr, sim.stderr


def _served_w(port: int) -> object:
    """Point W of model 201 as pysunspec2's client reads it from the gateway (None: not implemented)."""
    client = pytest.importorskip("sunspec2.modbus.client")
    device = client.SunSpecModbusClientDeviceTCP(slave_id=1, ipaddr="127.0.0.1", ipport=port, timeout=5)
    try:
        device.scan()
        return device.models[201][0].points["W"].cvalue
    finally:
        device.close()


def _raw_meter(tmp_path) -> str:
    path = tmp_path / "raw.json"  # meter A: 1.5 kW (INT32 in W x 1, holding 0-1), see test_sunspec_gateway
    path.write_text(json.dumps({"holding": {"0": 0, "1": 1500}}), encoding="ascii")
    return str(path)


def _until(read: Callable[[], object], wanted: Callable[[object], bool]) -> object:
    end = time.monotonic() + GUARD
    while True:
        got = read()
        if wanted(got) or time.monotonic() > end:
            return got
        time.sleep(0.2)


def test_serve_reaches_its_device_again_through_a_flood(sim_factory, tmp_path):
    raw = _raw_meter(tmp_path)
    backend = sim_factory(METER, "--registers", raw)
    gateway = Process(
        "serve", METER, "--from", f"127.0.0.1:{backend.port}", "--as", "sunspec", "--port", "0",
        "--interval", "0.2", "--timeout", "1", "--retries", "0",
    )  # fmt: skip
    try:
        ready = gateway.wait_for(gateway.out, lambda line: line.startswith("mdl serve: serving"))
        port = int(ready.rsplit(" unit ", 1)[0].rsplit(":", 1)[1])
        assert _served_w(port) == 1500
        with flood(port) as idle:
            assert len(idle) > FILES
            backend.stop()
            gateway.wait_for(gateway.err, lambda line: "does not answer" in line)
            again = Sim(METER, "--registers", raw, port=backend.port)
            try:
                assert _until(lambda: _served_w(port), lambda w: w is not None) == 1500
            finally:
                assert again.stop() == 0
    finally:
        status = gateway.stop()
    assert status == 0, gateway.stderr[-3000:]
    assert "Traceback" not in gateway.stderr, gateway.stderr[:3000]
    assert "open files" not in gateway.stderr, gateway.stderr[-3000:]


# --- finding 7: the gateway never serves old numbers -------------------------------------------------------


class Muffler:
    """A TCP relay on 127.0.0.1 (self.port) to a device; while `silent` is set it passes nothing either way,
    as a device that stops answering (its connections stay open)."""

    def __init__(self, upstream: int) -> None:
        self.upstream, self.silent, self.stop = upstream, threading.Event(), threading.Event()
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.settimeout(0.1)
        self.port = self.listener.getsockname()[1]
        self.sockets: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while not self.stop.is_set():
            try:
                client, _ = self.listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            device = socket.create_connection(("127.0.0.1", self.upstream), timeout=GUARD)
            self.sockets += [client, device]
            for a, b in ((client, device), (device, client)):
                threading.Thread(target=self._pass, args=(a, b), daemon=True).start()

    def _pass(self, source: socket.socket, sink: socket.socket) -> None:
        source.settimeout(0.1)
        while not self.stop.is_set():
            try:
                data = source.recv(4096)
            except TimeoutError:
                continue
            except OSError:
                return
            if not data:
                with suppress(OSError):
                    sink.shutdown(socket.SHUT_WR)
                return
            if not self.silent.is_set():
                with suppress(OSError):
                    sink.sendall(data)

    def close(self) -> None:
        self.stop.set()
        self.listener.close()
        for sock in self.sockets:
            sock.close()


def test_serve_never_serves_numbers_older_than_a_poll_and_a_request(sim_factory, tmp_path):
    interval, timeout = 0.5, 1.0  # a silent poll lasts 3 x 1 s; the values must go after 0.5 + 1 s
    backend = sim_factory(METER, "--registers", _raw_meter(tmp_path))
    relay = Muffler(backend.port)
    gateway = Process(
        "serve", METER, "--from", f"127.0.0.1:{relay.port}", "--as", "sunspec", "--port", "0",
        "--interval", str(interval), "--timeout", str(timeout), "--retries", "2",
    )  # fmt: skip
    try:
        ready = gateway.wait_for(gateway.out, lambda line: line.startswith("mdl serve: serving"))
        port = int(ready.rsplit(" unit ", 1)[0].rsplit(":", 1)[1])
        assert _served_w(port) == 1500
        relay.silent.set()
        time.sleep(interval + timeout + 0.5)  # the last answer is at least this old now
        assert _served_w(port) is None  # not implemented: no old number
        relay.silent.clear()
        assert _until(lambda: _served_w(port), lambda w: w is not None) == 1500  # the device is back
    finally:
        status = gateway.stop()
        relay.close()
    assert status == 0, gateway.stderr[-3000:]
    assert "Traceback" not in gateway.stderr, gateway.stderr[:3000]
