"""Modbus frames as they cross the wire, checked before a reply is trusted: pymodbus decodes a reply
for a function other than the one asked, more or fewer registers than asked, or a byte count that
disagrees with the data, without a word. `Wire` (the client's trace hook) keeps the bytes of each
request and of what came back (Modbus TCP or RTU frames); `reply_problem` holds a reply against its
request. The read session (mdl.device.runtime) and discovery (mdl.device.replies) judge by these.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator

from pymodbus.framer import FramerRTU

MBAP = struct.Struct(">HHHB")  # transaction id, protocol id (0), length of what follows, unit id
RTU_MIN = 4  # unit id, function code, CRC (2 bytes)
Frame = tuple[int, int, bytes]  # transaction id (0 on RTU), unit id, PDU


def frames(data: bytes) -> Iterator[Frame]:
    """(transaction id, unit id, PDU) of each whole Modbus TCP frame at the start of `data`."""
    while len(data) > MBAP.size:
        tid, protocol, length, unit = MBAP.unpack_from(data)
        end = MBAP.size - 1 + length
        if protocol != 0 or length < 2 or end > len(data):
            return
        yield tid, unit, data[MBAP.size : end]
        data = data[end:]


def rtu_frames(data: bytes) -> Iterator[Frame]:
    """(0, unit id, PDU) of each Modbus RTU reply frame with a good CRC in `data`; bytes that start no
    such frame are skipped, as a client hunting for a frame on a noisy line skips them."""
    start = 0
    while len(data) - start >= RTU_MIN:
        size = _rtu_reply_size(data[start:])
        end = start + size
        if (
            size
            and end <= len(data)
            and FramerRTU.compute_CRC(data[start : end - 2]) == int.from_bytes(data[end - 2 : end], "big")
        ):
            yield 0, data[start], data[start + 1 : end - 2]
            start = end
        else:
            start += 1


def _rtu_reply_size(data: bytes) -> int:
    """The length of the RTU reply frame at the start of `data`, from its function code (0: not a reply)."""
    fc = data[1]
    if fc & 0x80:
        return 5  # unit, function code, exception code, CRC
    if fc in (1, 2, 3, 4):
        return 5 + data[2] if len(data) > 2 else 0  # unit, function code, byte count, data, CRC
    if fc == 22:
        return 10  # unit, function code, address, AND mask, OR mask, CRC
    return 8 if fc in (5, 6, 15, 16) else 0  # unit, function code, address, value or count, CRC


def reply_problem(request: bytes, reply: bytes) -> str | None:
    """What is wrong with the PDU `reply` as the answer to the PDU `request` (functions 1-6, 15, 16, 22), or None."""
    fc = request[0]
    if reply[0] & 0x7F != fc:
        return f"the reply has function code {reply[0] & 0x7F}, expected {fc}"
    if reply[0] & 0x80:
        return None if len(reply) == 2 else f"the exception reply has {len(reply)} bytes, expected 2"
    if fc in (5, 6, 22):  # the echo of the request
        expected = request
    elif fc in (15, 16):  # the echo of the address and the count
        expected = request[:5]
    else:
        return _read_reply_problem(request, reply)
    return None if reply == expected else f"the reply {reply.hex(' ')} does not echo the request {expected.hex(' ')}"


def _read_reply_problem(request: bytes, reply: bytes) -> str | None:
    _, count = struct.unpack_from(">HH", request, 1)
    registers = request[0] in (3, 4)
    size = 2 * count if registers else (count + 7) // 8  # bits come padded to whole bytes
    if len(reply) < 2 or reply[1] != len(reply) - 2:
        said = f"byte count {reply[1]}" if len(reply) > 1 else "no byte count"
        return f"the reply's {said} does not match the {max(len(reply) - 2, 0)} data bytes that follow"
    if reply[1] != size:
        kind = "register" if registers else "bit"
        return f"the reply carries {reply[1]} data bytes, expected {size} for {count} {kind}{'s' * (count != 1)}"
    return None


class Wire:
    """The bytes of the last request and of what came back, from pymodbus's packet trace hook."""

    def __init__(self, rtu: bool = False) -> None:
        self.rtu = rtu
        self.request = b""
        self.received: list[bytes] = []  # the client's receive buffer each time data arrived

    def clear(self) -> None:
        """Forget the last request: nothing stale is blamed on a request that failed before it was sent."""
        self.request, self.received = b"", []

    def trace(self, sending: bool, data: bytes) -> bytes:
        if sending:
            self.request, self.received = data, []
        else:
            self.received.append(data)
        return data

    def _sent(self) -> Frame:
        """(transaction id, unit id, PDU) of the last request."""
        if self.rtu:
            return 0, self.request[0], self.request[1:-2]
        tid, _, _, unit = MBAP.unpack_from(self.request)
        return tid, unit, self.request[MBAP.size :]

    def _frames(self, data: bytes) -> Iterator[Frame]:
        return rtu_frames(data) if self.rtu else frames(data)

    def accepted_problem(self) -> str | None:
        """What is wrong with the reply the client accepted: the frame it decoded is in its last buffer."""
        tid, unit, request = self._sent()
        pdu = next(
            (pdu for t, u, pdu in self._frames(self.received[-1] if self.received else b"") if (t, u) == (tid, unit)),
            None,
        )
        if pdu is None:
            return "the reply the client decoded is not in the bytes received"
        return reply_problem(request, pdu)

    def refused_problem(self) -> str | None:
        """What is wrong with what came back for a request the client got no reply to, or None if nothing did."""
        if not self.received:
            return None
        data = self.received[0]  # from where the reply began
        found = next(self._frames(data), None)
        if found is None:
            kind = "RTU" if self.rtu else "TCP"
            return f"the reply is not a Modbus {kind} frame ({len(data)} bytes: {data[:16].hex(' ')})"
        tid, unit, request = self._sent()
        if found[0] != tid:
            return f"the reply's transaction id is {found[0]}, expected {tid}"
        if found[1] != unit:
            return f"the reply comes from unit {found[1]}"
        return reply_problem(request, found[2]) or "the reply could not be decoded"
