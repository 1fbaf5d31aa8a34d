"""A deliberately broken Modbus TCP server, for tests of what a client does with replies it must not trust.

It speaks MBAP framing itself (no Modbus library behind it), so it can lie in ways a server library
never would. Use it as a context manager; it serves connections on 127.0.0.1 (a free port) until the
block ends or `lifetime` seconds have passed, and answers every request as its mode says:

    from hostile_server import hostile_server

    with hostile_server("wrong_function_code") as (host, port):
        proc = run_mdl("read", "device.xml", "--host", host, "--port", port, "--timeout", "1")

Reads are functions 1-4, writes 5, 6, 15 and 16; any other function gets exception 1. In an honest
read reply each register holds its own address and each bit is 1 at odd addresses, 0 at even ones.

    honest                correct replies: the control, a client must accept them
    wrong_function_code   a well-formed reply for the neighbouring function: 1 <-> 2, 3 <-> 4, 5 <-> 6, 15 <-> 16
    extra_registers       reads: byte count and data for one register (bits: 8 bits) more than asked;
                          writes: the echo with two bytes more
    short                 reads: byte count and data for one register (bits: 8 bits) fewer;
                          writes: the echo without its last two bytes
    bad_byte_count        reads: the right byte count, followed by data for one register (8 bits) more;
                          writes (no byte count): the echo with its last field changed
    long_byte_count       reads: a byte count two more than the data that follows it; writes as bad_byte_count
    exception             an exception reply, code 4 (SERVER DEVICE FAILURE)
    wrong_transaction_id  an honest reply under the request's transaction id plus one
    wrong_unit            an honest reply from the request's unit id plus one
    garbage               16 random bytes for each request, seeded: the same bytes in every run (none of
                          them starts a Modbus TCP frame: their protocol id is not 0)
    drop                  closes the connection once a request has arrived, without a reply
    reset                 resets the connection (TCP RST) once a request has arrived
    silent                reads requests and never answers

Except in drop and reset, a connection stays open after a lie, so a client that retries meets the
same lie again; a client with a timeout T and R retries ends within about (R + 1) * T seconds.
"""

from __future__ import annotations

import random
import socket
import struct
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress

READS = (1, 2, 3, 4)
WRITES = (5, 6, 15, 16)
NEIGHBOUR = {1: 2, 2: 1, 3: 4, 4: 3, 5: 6, 6: 5, 15: 16, 16: 15}
POLL = 0.1  # seconds between looks at the stop flag


def _count(request: bytes) -> int:
    return int(struct.unpack(">H", request[3:5])[0])


def _read_data(request: bytes, extra: int = 0) -> bytes:
    """The data of an honest read reply, for `extra` more (or fewer) registers or bytes of bits."""
    fc = request[0]
    (address,) = struct.unpack(">H", request[1:3])
    if fc in (3, 4):
        count = _count(request) + extra
        return b"".join(struct.pack(">H", (address + i) & 0xFFFF) for i in range(max(count, 0)))
    nbytes = max((_count(request) + 7) // 8 + extra, 0)
    bits = [(address + i) % 2 for i in range(nbytes * 8)]
    return bytes(sum(bit << j for j, bit in enumerate(bits[k:k + 8])) for k in range(0, len(bits), 8))


def _honest(request: bytes) -> bytes:
    fc = request[0]
    if fc in READS:
        data = _read_data(request)
        return bytes([fc, len(data)]) + data
    if fc in WRITES:  # the echo: 5 and 6 echo the whole request, 15 and 16 its address and count
        return request[:5]
    return bytes([fc | 0x80, 1])


def _changed_last_field(echo: bytes) -> bytes:
    if echo[0] == 5:  # a coil's echoed value is 0xFF00 or 0x0000: the other one
        return echo[:3] + (b"\x00\x00" if echo[3:5] == b"\xff\x00" else b"\xff\x00")
    return echo[:3] + struct.pack(">H", (struct.unpack(">H", echo[3:5])[0] + 1) & 0xFFFF)


def _wrong_function_code(request: bytes) -> bytes:
    other = NEIGHBOUR.get(request[0])
    if other is None:
        return _honest(request)
    reply = _honest(bytes([other]) + request[1:])
    if other == 5:  # a well-formed function 5 echo carries 0xFF00 or 0x0000
        reply = reply[:3] + b"\xff\x00"
    return reply


def _resized(extra_registers: int) -> Callable[[bytes], bytes]:
    def lie(request: bytes) -> bytes:
        if request[0] in READS:
            data = _read_data(request, extra_registers)
            return bytes([request[0], len(data)]) + data
        echo = _honest(request)
        return echo + b"\x00\x00" if extra_registers > 0 else echo[:-2]
    return lie


def _bad_byte_count(request: bytes) -> bytes:
    if request[0] in READS:
        return _honest(request) + _read_data(request)[:2 if request[0] in (3, 4) else 1]
    return _changed_last_field(_honest(request))


def _long_byte_count(request: bytes) -> bytes:
    if request[0] in READS:
        honest = _honest(request)
        return bytes([honest[0], honest[1] + 2]) + honest[2:]
    return _changed_last_field(_honest(request))


PDU_LIES: dict[str, Callable[[bytes], bytes]] = {
    "honest": _honest,
    "wrong_function_code": _wrong_function_code,
    "extra_registers": _resized(1),
    "short": _resized(-1),
    "bad_byte_count": _bad_byte_count,
    "long_byte_count": _long_byte_count,
    "exception": lambda request: bytes([request[0] | 0x80, 4]),
    "wrong_transaction_id": _honest,
    "wrong_unit": _honest,
}
CONNECTION_LIES = ("garbage", "drop", "reset", "silent")
MODES = (*PDU_LIES, *CONNECTION_LIES)


def _recv_exactly(conn: socket.socket, size: int, stop: threading.Event) -> bytes | None:
    """`size` bytes, or None when the peer closed the connection or the server is stopping."""
    data = b""
    while len(data) < size:
        if stop.is_set():
            return None
        try:
            chunk = conn.recv(size - len(data))
        except TimeoutError:
            continue
        except OSError:
            return None
        if not chunk:
            return None
        data += chunk
    return data


class _Server:
    def __init__(self, mode: str, lifetime: float):
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; modes: {', '.join(MODES)}")
        self.mode = mode
        self.deadline = time.monotonic() + lifetime
        self.stop = threading.Event()
        self.garbage = random.Random(8)
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.settimeout(POLL)
        self.address: tuple[str, int] = self.listener.getsockname()[:2]
        self.connections: list[socket.socket] = []
        self.threads = [threading.Thread(target=self._accept, daemon=True)]
        self.threads[0].start()

    def _accept(self) -> None:
        while not self.stop.is_set() and time.monotonic() < self.deadline:
            try:
                conn, _ = self.listener.accept()
            except TimeoutError:
                continue
            except OSError:
                break
            conn.settimeout(POLL)
            self.connections.append(conn)
            thread = threading.Thread(target=self._serve, args=(conn,), daemon=True)
            self.threads.append(thread)
            thread.start()
        self.stop.set()

    def _serve(self, conn: socket.socket) -> None:
        with conn:
            while (header := _recv_exactly(conn, 7, self.stop)) is not None:
                tid, _pid, length, unit = struct.unpack(">HHHB", header)
                request = _recv_exactly(conn, length - 1, self.stop) if length > 1 else b""
                if not request:
                    return
                if self.mode in ("drop", "reset"):
                    if self.mode == "reset":
                        conn.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                    return
                if self.mode == "silent":
                    continue
                with suppress(OSError):
                    conn.sendall(self._reply(tid, unit, request))

    def _reply(self, tid: int, unit: int, request: bytes) -> bytes:
        if self.mode == "garbage":
            return self.garbage.randbytes(16)
        pdu = PDU_LIES[self.mode](request)
        if self.mode == "wrong_transaction_id":
            tid = (tid + 1) & 0xFFFF
        if self.mode == "wrong_unit":
            unit = (unit + 1) & 0xFF
        return struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu

    def close(self) -> None:
        self.stop.set()
        for thread in self.threads:
            thread.join(timeout=5)
        self.listener.close()
        for conn in self.connections:
            with suppress(OSError):
                conn.close()


@contextmanager
def hostile_server(mode: str, lifetime: float = 60.0) -> Iterator[tuple[str, int]]:
    """Serve `mode` (see the module's docstring) on 127.0.0.1; yields (host, port)."""
    server = _Server(mode, lifetime)
    try:
        yield server.address
    finally:
        server.close()
