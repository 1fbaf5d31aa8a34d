"""`mdl sim` against clients that send frames it cannot serve: each gets the right exception (never a traceback,
never exception 4 or a reply with function code 0x80), on Modbus TCP and RTU over TCP; and what pymodbus logs
under a burst of bad frames from several clients is rate-limited per client, with a count of what was left out."""

from __future__ import annotations

import io
import logging
import os
import random
import signal
import socket
import struct
import threading
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.device.server.sim import FILES_KEPT, LOG_PER_CLIENT, LOG_TOTAL, LogLimiter
from support.common import DATA
from support.hostile_server import rtu_frame

ALL = DATA / "all_tables.xml"
BURST = 3.0  # seconds each client of the burst sends bad frames

REFUSED = [  # request PDU -> the reply PDU
    (bytes([0x08, 0x12, 0x34, 0, 0]), bytes([0x88, 1])),  # diagnostics, an unknown sub-function
    (bytes([0x08, 0xFF, 0xFF]), bytes([0x88, 1])),
    (bytes([0x81, 0, 0, 0, 1]), bytes([0x81, 1])),  # the exception bit set
    (bytes([0x81]), bytes([0x81, 1])),
    (bytes([0xFF, 1, 2]), bytes([0xFF, 1])),
    (bytes([0x63]), bytes([0xE3, 1])),  # a function code pymodbus does not know
    (bytes([0x2B, 0x0D]), bytes([0xAB, 1])),  # function 43, an MEI type other than 14
    (bytes([0x15, 0x09, 0xDD, 0xE1, 0x4D, 0x8E, 0x35, 0x44, 0x1D, 0x23, 0x3F]), bytes([0x95, 1])),  # no file records
    (bytes([0x11]), bytes([0x91, 1])),  # Report Server ID: pymodbus's own, not the device's
    (bytes([0x03]), bytes([0x83, 3])),  # too short for its function: ILLEGAL DATA VALUE
    (bytes([0x03, 0, 100]), bytes([0x83, 3])),
    (bytes([0x10, 0, 100]), bytes([0x90, 3])),
]
SERVED = (bytes([0x03, 0, 100, 0, 1]), bytes([0x03, 2, 0, 0]))  # the control: holding register 100 reads 0


def tcp_request(sock: socket.socket, pdu: bytes, unit: int = 1, tid: int = 7) -> bytes:
    """Send one Modbus TCP request; the reply's PDU, after checking its header echoes the request's."""
    sock.sendall(struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu)
    header = recv_exactly(sock, 7)
    got_tid, protocol, length, got_unit = struct.unpack(">HHHB", header)
    assert (got_tid, protocol, got_unit) == (tid, 0, unit), header
    return recv_exactly(sock, length - 1)


def recv_exactly(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        assert chunk, f"the sim closed the connection after {data!r}"
        data += chunk
    return data


def assert_clean(sim) -> list[str]:
    """Stop the sim; its stderr lines, which are never a traceback and all its own."""
    assert sim.stop() == 0
    lines = sim.stderr.splitlines()
    assert "Traceback" not in sim.stderr, sim.stderr[:3000]
    assert all(line.startswith("mdl sim: ") for line in lines), [line for line in lines if "mdl sim" not in line][:5]
    return lines


def test_requests_it_cannot_serve_get_the_right_exception_on_tcp(sim_factory):
    sim = sim_factory(ALL, "--unit", "1")
    with socket.create_connection((sim.host, sim.port), timeout=10) as sock:
        for request, reply in [*REFUSED, SERVED]:
            assert tcp_request(sock, request) == reply, request.hex(" ")
        assert tcp_request(sock, REFUSED[0][0], unit=9) == bytes([0x88, 11])  # no device at unit 9: as for reads
        assert tcp_request(sock, SERVED[0]) == SERVED[1]  # the connection still serves
    assert_clean(sim)


def test_requests_it_cannot_serve_get_the_right_exception_on_rtu_over_tcp(sim_factory):
    sim = sim_factory(ALL, "--unit", "1", "--framer", "rtu")
    with socket.create_connection((sim.host, sim.port), timeout=10) as sock:
        # RTU frames have no length: only requests whose size the function code tells can be answered
        for request, reply in [
            (bytes([0x08, 0x12, 0x34, 0, 0]), bytes([0x88, 1])),
            (bytes([0x81, 0]), bytes([0x81, 1])),
            SERVED,
        ]:
            sock.sendall(rtu_frame(1, request))
            expected = rtu_frame(1, reply)
            assert recv_exactly(sock, len(expected)) == expected, request.hex(" ")
    assert_clean(sim)


def _flood(host: str, port: int, seed: int, stop: threading.Event, sent: list[int]) -> None:
    """Bad frames as fast as the sim takes them, on one connection after another: refused requests (each
    answered), then a frame with a random protocol id (logged by pymodbus, each with its own text), after
    which the connection is of no more use."""
    rng = random.Random(seed)
    count = 0
    while not stop.is_set():
        try:
            with socket.create_connection((host, port), timeout=5) as sock:
                for _ in range(rng.randrange(1, 5)):
                    tcp_request(sock, rng.choice(REFUSED)[0])
                    count += 1
                sock.sendall(struct.pack(">HHHB", rng.randrange(65536), rng.randrange(1, 65536), 2, 1) + bytes([3]))
                count += 1
        except OSError:
            continue
    sent.append(count)


@pytest.mark.parametrize("clients", [6])
def test_a_burst_from_several_clients_is_logged_within_bounds(sim_factory, clients):
    sim = sim_factory(ALL, "--unit", "1")
    stop, sent = threading.Event(), []
    threads = [threading.Thread(target=_flood, args=(sim.host, sim.port, seed, stop, sent)) for seed in range(clients)]
    started = time.monotonic()
    for thread in threads:
        thread.start()
    stop.wait(BURST)
    stop.set()
    for thread in threads:
        thread.join(timeout=30)
    with socket.create_connection((sim.host, sim.port), timeout=10) as sock:  # still serving after the burst
        assert tcp_request(sock, SERVED[0]) == SERVED[1]
    elapsed = time.monotonic() - started
    lines = assert_clean(sim)
    logged = [line for line in lines if "suppressed" not in line]
    summaries = [line for line in lines if "suppressed" in line]
    assert sum(sent) > 10 * len(lines), (sum(sent), len(lines))  # far more bad frames than lines
    assert summaries and all(" more message" in line and "(from " in line for line in summaries), lines[-5:]
    # at most LOG_TOTAL lines and one summary per window of a second (a window starts at the first message)
    windows = elapsed + 2
    assert len(logged) <= LOG_TOTAL * windows and len(summaries) <= windows + 1, (len(logged), len(summaries))
    per_client: dict[str, int] = {}
    for line in logged:
        client = line.split(": ", 2)[1]
        per_client[client] = per_client.get(client, 0) + 1
    assert max(per_client.values()) <= LOG_PER_CLIENT * windows, per_client
    assert all(len(line) < 300 for line in lines)  # first lines only, never a frame dump


def test_fuzz_any_request_gets_a_reply_of_its_function_and_no_traceback(sim_factory):
    """Random PDUs (of the function codes pymodbus knows and others) on one connection: each gets a reply for
    its own function code, a normal one or an exception, and the connection goes on serving."""
    sim = sim_factory(ALL, "--unit", "1")
    codes = st.sampled_from([1, 2, 3, 4, 5, 6, 7, 8, 11, 12, 15, 16, 17, 20, 21, 22, 23, 24, 43, 0x81, 0x90, 99])
    with socket.create_connection((sim.host, sim.port), timeout=10) as sock:

        @settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
        @given(
            st.one_of(
                st.builds(lambda fc, rest: bytes([fc]) + rest, codes, st.binary(max_size=12)),
                st.binary(min_size=1, max_size=12),
            )
        )
        def answered(pdu):
            reply = tcp_request(sock, pdu)
            assert reply[0] & 0x7F == pdu[0] & 0x7F, (pdu.hex(" "), reply.hex(" "))
            assert not reply[0] & 0x80 or pdu[0] & 0x80 or len(reply) == 2, (pdu.hex(" "), reply.hex(" "))

        answered()
        assert tcp_request(sock, SERVED[0]) == SERVED[1]
    assert_clean(sim)


def test_a_client_leaving_before_its_reply_is_not_said(sim_factory):
    """A client that sends a request and leaves at once (its connection reset before the reply): the sim says
    nothing (pymodbus logs "Cancel send, because not connected!" as it drops the reply), and goes on serving."""
    sim = sim_factory(ALL, "--unit", "1")
    for _ in range(200):
        sock = socket.create_connection((sim.host, sim.port), timeout=10)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # close sends a reset
        sock.sendall(struct.pack(">HHHB", 7, 0, len(SERVED[0]) + 1, 1) + SERVED[0])
        sock.close()
    with socket.create_connection((sim.host, sim.port), timeout=10) as sock:
        assert tcp_request(sock, SERVED[0]) == SERVED[1]
    assert assert_clean(sim) == []


def test_clients_gone_before_their_connections_are_read_are_not_said_closed_for_newer_ones(sim_factory):
    """More clients than the sim holds connect, ask and reset while it is held (SIGSTOP), so that it accepts
    them in one burst before it reads from any: those already gone make room without a word, and a new
    client is served. (A loaded machine does this to the test above: the sim said it closed connections for
    newer ones when the clients had left.)"""
    sim = sim_factory(ALL, "--unit", "1", files=FILES_KEPT + 2 * 6)  # 6 connections at once at most
    os.kill(sim.proc.pid, signal.SIGSTOP)
    try:
        for _ in range(3 * 6):  # fewer than the listen backlog: all wait to be accepted
            sock = socket.create_connection((sim.host, sim.port), timeout=10)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            sock.sendall(struct.pack(">HHHB", 7, 0, len(SERVED[0]) + 1, 1) + SERVED[0])
            sock.close()
    finally:
        os.kill(sim.proc.pid, signal.SIGCONT)
    with socket.create_connection((sim.host, sim.port), timeout=10) as sock:
        assert tcp_request(sock, SERVED[0]) == SERVED[1]
    assert assert_clean(sim) == []


def test_what_says_nothing_is_not_logged():
    """pymodbus's error lines carry its last frames after the message; the message alone decides."""
    out = io.StringIO()
    limiter = LogLimiter("client", out)
    for msg in (
        "Cancel send, because not connected!",
        "Cancel send, because not connected!\n 0x0 0x7",
        "Repeating....",
    ):
        limiter.emit(logging.LogRecord("pymodbus", logging.ERROR, __file__, 1, msg, None, None))
    assert out.getvalue() == ""
    limiter.emit(logging.LogRecord("pymodbus", logging.ERROR, __file__, 1, "Unable to decode frame", None, None))
    assert out.getvalue() == "mdl sim: client: Unable to decode frame\n"
