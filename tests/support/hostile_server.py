"""A deliberately broken Modbus TCP server, for tests of what a client does with replies it must not trust.

It speaks MBAP framing itself (no Modbus library behind it), so it can lie in ways a server library
never would. Use it as a context manager; it serves connections on 127.0.0.1 (a free port) until the
block ends or `lifetime` seconds have passed, and answers every request as its mode says:

    from support.hostile_server import hostile_server

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

Modes for function 43 / MEI 14 (Read Device Identification); reads are answered honestly in them, and
the identification of an honest unit is VendorName "Hostile", ProductCode "H1", MajorMinorRevision "1.0"
(IDENTITY):

    id_long_length        an object whose length byte says 200 bytes, with 3 after it
    id_extra_count        an object count of 5, with the 3 objects
    id_huge               a PDU of 65,000 bytes (one object after another; Modbus allows 253)
    id_more_forever       "more follows" on every reply, naming the object after the one asked (without end)
    id_more_stuck         "more follows" naming the object asked, again and again
    id_dribble            the honest reply, one byte every `gap` seconds (0.4 by default)
    id_stream             the honest reply, then copies of it every 20 ms until the connection closes

`framing="rtu"` speaks RTU frames over TCP instead (as a serial-to-Ethernet converter does); socat can
put that on a pseudo terminal (`serial_bridge`). `units`: the unit ids that answer at all (all by
default); a request for another gets exception 11 on Modbus TCP, as from a gateway, and no answer on
RTU, as on a bus. `liar`: the one unit that lies (every unit by default); the others answer honestly.

Except in drop and reset, a connection stays open after a lie, so a client that retries meets the
same lie again; a client with a timeout T and R retries ends within about (R + 1) * T seconds.
"""

from __future__ import annotations

import random
import shutil
import socket
import struct
import subprocess
import threading
import time
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager, suppress

from pymodbus.framer import FramerRTU

READS = (1, 2, 3, 4)
WRITES = (5, 6, 15, 16)
NEIGHBOUR = {1: 2, 2: 1, 3: 4, 4: 3, 5: 6, 6: 5, 15: 16, 16: 15}
POLL = 0.1  # seconds between looks at the stop flag
IDENTIFY = 0x2B  # function 43, MEI type 14: Read Device Identification
IDENTITY = (b"Hostile", b"H1", b"1.0")  # an honest unit's basic objects 0, 1, 2


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
    return bytes(sum(bit << j for j, bit in enumerate(bits[k : k + 8])) for k in range(0, len(bits), 8))


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
        return _honest(request) + _read_data(request)[: 2 if request[0] in (3, 4) else 1]
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


def _objects(objects: list[tuple[int, bytes]]) -> bytes:
    return b"".join(bytes([oid, len(data)]) + data for oid, data in objects)


def identification(
    request: bytes, more: int = 0, next_object: int = 0, count: int | None = None, objects: bytes | None = None
) -> bytes:
    """A Read Device Identification reply to `request` (2b 0e CODE OBJECT): the IDENTITY objects from the one
    asked, or what the arguments say instead."""
    first = request[3] if len(request) > 3 else 0
    chosen = [(oid, data) for oid, data in enumerate(IDENTITY) if oid >= first]
    body = _objects(chosen) if objects is None else objects
    return (
        bytes(
            [
                IDENTIFY,
                0x0E,
                request[2] if len(request) > 2 else 1,
                0x01,
                more,
                next_object,
                len(chosen) if count is None else count,
            ]
        )
        + body
    )


def _honest_identification(request: bytes) -> bytes:
    if len(request) != 4 or request[1] != 0x0E:
        return bytes([IDENTIFY | 0x80, 1])
    return identification(request)


def _huge(request: bytes) -> bytes:
    objects = [(i % 3, bytes([0x41 + i % 26]) * 250) for i in range(65_000 // 252)]
    return identification(request, count=len(objects) % 256, objects=_objects(objects))


ID_LIES: dict[str, Callable[[bytes], bytes]] = {
    "id_long_length": lambda r: identification(r, count=1, objects=bytes([0, 200]) + b"abc"),
    "id_extra_count": lambda r: identification(r, count=5),
    "id_huge": _huge,
    "id_more_forever": lambda r: identification(
        r, more=0xFF, next_object=(r[3] + 1) & 0xFF, count=1, objects=_objects([(r[3], b"x")])
    ),
    "id_more_stuck": lambda r: identification(
        r, more=0xFF, next_object=r[3], count=1, objects=_objects([(r[3], b"x")])
    ),
    "id_dribble": _honest_identification,
    "id_stream": _honest_identification,
}
MODES = (*PDU_LIES, *CONNECTION_LIES)  # lies a driver meets (it never asks for the identification)
ALL_MODES = (*MODES, *ID_LIES)  # and the identification's, which only mdl discover meets


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


def _rtu_request_size(data: bytes) -> int:
    """The length of the RTU request frame at the start of `data`; 0: more bytes needed; -1: not a request."""
    if len(data) < 2:
        return 0
    fc = data[1]
    if fc in (*READS, 5, 6):
        return 8  # unit id, function code, address, count or value, CRC
    if fc in (15, 16):
        return 9 + data[6] if len(data) > 6 else 0
    return 7 if fc == IDENTIFY else -1  # unit id, 2b 0e, read code, object id, CRC


def rtu_frame(unit: int, pdu: bytes) -> bytes:
    frame = bytes([unit]) + pdu
    return frame + FramerRTU.compute_CRC(frame).to_bytes(2, "big")


class _Server:
    def __init__(
        self,
        mode: str,
        lifetime: float,
        framing: str = "tcp",
        units: Collection[int] | None = None,
        liar: int | None = None,
        gap: float = 0.4,
    ):
        if mode not in ALL_MODES:
            raise ValueError(f"unknown mode {mode!r}; modes: {', '.join(ALL_MODES)}")
        if framing not in ("tcp", "rtu"):
            raise ValueError(f"unknown framing {framing!r}: tcp or rtu")
        self.mode, self.rtu, self.units, self.liar, self.gap = mode, framing == "rtu", units, liar, gap
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

    def _requests(self, conn: socket.socket) -> Iterator[tuple[int, int, bytes]]:
        """(transaction id, unit id, PDU) of each request that arrives (transaction id 0 on RTU)."""
        if not self.rtu:
            while (header := _recv_exactly(conn, 7, self.stop)) is not None:
                tid, _pid, length, unit = struct.unpack(">HHHB", header)
                request = _recv_exactly(conn, length - 1, self.stop) if length > 1 else b""
                if not request:
                    return
                yield tid, unit, request
            return
        data = b""
        while (chunk := _recv_exactly(conn, 1, self.stop)) is not None:
            data += chunk
            size = _rtu_request_size(data)
            if size < 0:
                data = b""  # not a request this server knows: dropped, as noise on a line
            elif size and len(data) >= size:
                frame, data = data[:size], data[size:]
                yield 0, frame[0], frame[1:-2]

    def _serve(self, conn: socket.socket) -> None:
        with conn:
            for tid, unit, request in self._requests(conn):
                if self.units is not None and unit not in self.units:
                    if not self.rtu:  # a gateway: nothing answers behind it
                        with suppress(OSError):
                            conn.sendall(self._frame(tid, unit, bytes([request[0] | 0x80, 11])))
                    continue
                mode = self.mode if self.liar is None or unit == self.liar else "honest"
                if mode in ("drop", "reset"):
                    if mode == "reset":
                        conn.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                    return
                if mode == "silent":
                    continue
                try:
                    self._send(conn, mode, tid, unit, request)
                except OSError:
                    return

    def _send(self, conn: socket.socket, mode: str, tid: int, unit: int, request: bytes) -> None:
        identify = request[0] == IDENTIFY and (mode in ID_LIES or self.mode in ID_LIES)
        if not identify or mode not in ("id_dribble", "id_stream"):
            conn.sendall(self._reply(mode, tid, unit, request))
            return
        reply = self._frame(tid, unit, ID_LIES[mode](request))
        if mode == "id_dribble":
            for byte in reply:
                if self.stop.wait(self.gap):
                    return
                conn.sendall(bytes([byte]))
            return
        while not self.stop.is_set():  # id_stream: without end
            conn.sendall(reply)
            self.stop.wait(0.02)

    def _reply(self, mode: str, tid: int, unit: int, request: bytes) -> bytes:
        if mode == "garbage":
            return self.garbage.randbytes(16)
        if request[0] == IDENTIFY and (mode in ID_LIES or self.mode in ID_LIES):
            pdu = ID_LIES.get(mode, _honest_identification)(request)
        else:
            pdu = PDU_LIES.get(mode, _honest)(request)
        if mode == "wrong_transaction_id":
            tid = (tid + 1) & 0xFFFF
        if mode == "wrong_unit":
            unit = (unit + 1) & 0xFF
        return self._frame(tid, unit, pdu)

    def _frame(self, tid: int, unit: int, pdu: bytes) -> bytes:
        if self.rtu:
            return rtu_frame(unit, pdu)
        return struct.pack(">HHHB", tid, 0, (len(pdu) + 1) & 0xFFFF, unit) + pdu

    def close(self) -> None:
        self.stop.set()
        for thread in self.threads:
            thread.join(timeout=5)
        self.listener.close()
        for conn in self.connections:
            with suppress(OSError):
                conn.close()


@contextmanager
def hostile_server(
    mode: str,
    lifetime: float = 60.0,
    framing: str = "tcp",
    units: Collection[int] | None = None,
    liar: int | None = None,
    gap: float = 0.4,
) -> Iterator[tuple[str, int]]:
    """Serve `mode` (see the module's docstring) on 127.0.0.1; yields (host, port)."""
    server = _Server(mode, lifetime, framing, units, liar, gap)
    try:
        yield server.address
    finally:
        server.close()


@contextmanager
def serial_bridge(port: int, timeout: float = 10) -> Iterator[str]:
    """A pseudo terminal wired to 127.0.0.1:`port` by socat (a hostile server with framing="rtu" then stands
    for a device on a serial line); yields the terminal's name. socat must be installed."""
    from support.devices import read_lines  # the same line reader the serial fixtures use

    if shutil.which("socat") is None:
        raise RuntimeError("socat is not installed")
    proc = subprocess.Popen(
        ["socat", "-d", "-d", "pty,raw,echo=0", f"tcp:127.0.0.1:{port}"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lines = read_lines(proc.stderr, lambda got: any(" PTY is " in line for line in got), proc, timeout)
        ends = [line.split(" PTY is ", 1)[1].strip() for line in lines if " PTY is " in line]
        if not ends:
            raise RuntimeError(f"socat made no pseudo terminal: {lines!r}")
        yield ends[0]
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        proc.stderr.close()


def rtu(frame: bytes) -> bytes:
    return frame + FramerRTU.compute_CRC(frame).to_bytes(2, "big")


LIES = {  # an RTU-over-TCP device's answer to a read of one holding register -> what `mdl read` says of it
    "other_unit": (lambda request: rtu(bytes([request[0] + 1, 3, 2, 0, 7])), "the reply comes from unit 2"),
    "short": (lambda request: rtu(bytes([request[0], 3, 0])), "the reply carries 0 data bytes, expected 2"),
    "bad_crc": (
        lambda request: bytes([request[0], 3, 2, 0, 7, 0, 0]),
        "the reply is not a Modbus RTU frame (7 bytes: 01 03 02 00 07 00 00); check the unit id",
    ),
}
