"""What a unit's reply is (SPEC 10, docs/discovery.md "Replies that are not to be trusted"): a Read
Device Identification reply checked byte by byte, whether bytes on the wire are the asked unit's reply
(its transaction and unit id on TCP, its address and CRC on RTU), and a serial line drained of what a
late unit still sends. `mdl discover` asks; this module only judges what came back."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from pymodbus.constants import DeviceInformation
from pymodbus.framer import FramerRTU

from mdl.device.frames import MBAP, Wire, frames, rtu_frames
from mdl.device.server.sim import IDENTIFICATION
from mdl.diagnostics import DeviceError

OBJECT_NAMES = tuple(name for name, _ in IDENTIFICATION)  # the basic objects, by object id
MAX_PDU = 253  # bytes in a Modbus PDU at most (function code and data)
MEI_FUNCTION, MEI_READ_DEVICE_ID = 0x2B, 0x0E
MORE_FOLLOWS = {0x00: False, 0xFF: True}
DRAIN_TIMEOUTS, DRAIN_MIN = 30, 15.0  # a serial line is drained for at most max(30 timeouts, 15 s)
RTU_MAX = 256  # bytes in a Modbus RTU frame at most


class LineLost(DeviceError):
    """The connection cannot be opened again, or a serial line never goes quiet: the scan cannot go on."""


@dataclass(frozen=True)
class IdReply:
    """A well-formed Read Device Identification reply: its objects (id, bytes) and where the next one is."""

    objects: tuple[tuple[int, bytes], ...]
    more: bool
    next_object: int


def parse_identification(pdu: bytes, object_id: int) -> IdReply | int:
    """The PDU of a reply to Read Device Identification (basic objects, asked from `object_id`): the
    exception code of an exception reply, else the reply. ValueError saying what is wrong with it: longer
    than a PDU may be, a header other than the request's, an object whose length byte runs past the
    end, an object count other than the objects sent, bytes after them, or a "more follows" that does not
    name a later basic object."""
    if len(pdu) > MAX_PDU:
        raise ValueError(f"the reply is {len(pdu)} bytes long, more than a Modbus PDU's {MAX_PDU}")
    if pdu[:1] == bytes([MEI_FUNCTION | 0x80]):
        if len(pdu) != 2:
            raise ValueError(f"the exception reply has {len(pdu)} bytes, expected 2")
        return pdu[1]
    if len(pdu) < 7:
        raise ValueError(f"the reply has {len(pdu)} bytes, fewer than the 7 of its header ({pdu.hex(' ')})")
    if (pdu[0], pdu[1], pdu[2]) != (MEI_FUNCTION, MEI_READ_DEVICE_ID, DeviceInformation.BASIC):
        raise ValueError(f"the reply starts {pdu[:3].hex(' ')}, expected 2b 0e 01 (function 43, MEI 14, basic objects)")
    if pdu[4] not in MORE_FOLLOWS:
        raise ValueError(f"its 'more follows' byte is 0x{pdu[4]:02x}, expected 0x00 or 0xff")
    more, next_object, count = MORE_FOLLOWS[pdu[4]], pdu[5], pdu[6]
    objects: list[tuple[int, bytes]] = []
    at = 7
    while len(objects) < count and at < len(pdu):
        if at + 2 > len(pdu):
            raise ValueError(f"object {len(objects) + 1} of {count} is cut off after its id")
        oid, size = pdu[at], pdu[at + 1]
        if at + 2 + size > len(pdu):
            raise ValueError(f"object 0x{oid:02x}'s length byte says {size} bytes, {len(pdu) - at - 2} follow")
        objects.append((oid, pdu[at + 2 : at + 2 + size]))
        at += 2 + size
    if len(objects) < count:
        raise ValueError(f"it says {count} objects and carries {len(objects)}")
    if at < len(pdu):
        raise ValueError(f"{len(pdu) - at} bytes follow its {count} object{'s' * (count != 1)}")
    if more and not object_id < next_object < len(OBJECT_NAMES):
        why = "does not advance" if next_object <= object_id else "is not a basic object (0x00-0x02)"
        raise ValueError(f"'more follows' names object 0x{next_object:02x} next, which {why}")
    return IdReply(tuple(objects), more, next_object)


def _rtu_identification_size(data: bytes) -> int:
    """The length of the RTU frame of a function 43 reply at the start of `data` (unit id first), as its
    object count and length bytes say; 0 where `data` ends first."""
    if data[1] & 0x80:
        return 5  # unit id, function code, exception code, CRC
    at = 8  # unit id and the 7 bytes of the PDU's header
    if len(data) < at:
        return 0
    for _ in range(data[7]):
        if at + 2 > len(data):
            return 0
        at += 2 + data[at + 1]  # an object: its id, its length byte, its bytes
    return at + 2 if at + 2 <= len(data) else 0


def reply_pdu(wire: Wire, unit: int) -> bytes | None:
    """The PDU of the reply to the last request among the bytes received (on Modbus TCP the frame with
    the request's transaction id and unit id; on RTU the first function 43 frame of the unit with a good
    CRC); None if there is none."""
    data = wire.received[-1] if wire.received else b""
    if not wire.rtu:
        tid = MBAP.unpack_from(wire.request)[0] if len(wire.request) >= MBAP.size else -1
        return next((pdu for t, u, pdu in frames(data) if (t, u) == (tid, unit)), None)
    for at in range(min(len(data) - 4, RTU_MAX)):  # the client skips noise before a reply, not more than a frame
        if data[at] != unit or data[at + 1] & 0x7F != MEI_FUNCTION:
            continue
        size = _rtu_identification_size(data[at:])
        end = at + size
        if size and FramerRTU.compute_CRC(data[at : end - 2]) == int.from_bytes(data[end - 2 : end], "big"):
            return data[at + 1 : end - 2]
    return None


def came_from(wire: Wire, unit: int) -> bool:
    """Whether the bytes received for the last request hold its reply, or the start of it: on Modbus TCP a
    frame (or the head of one) with the request's transaction id and unit id after any whole frames of
    other requests; on RTU a frame of the unit with a good CRC, or bytes that start as its reply would.
    Late bytes of another unit's reply are not this unit's answer."""
    if not wire.received:
        return False
    if not wire.rtu:
        return any(_tcp_came_from(data, wire.request, unit) for data in (wire.received[0], wire.received[-1]))
    fc = wire.request[1] if len(wire.request) > 1 else -1
    first = wire.received[0]  # the client empties its buffer before it sends: the reply starts here
    if first[:1] == bytes([unit]) and (len(first) == 1 or first[1] & 0x7F == fc):
        return True
    return any(u == unit for _, u, _ in rtu_frames(wire.received[-1][: 4 * RTU_MAX])) or (
        fc == MEI_FUNCTION and reply_pdu(wire, unit) is not None
    )


def _tcp_came_from(data: bytes, request: bytes, unit: int) -> bool:
    """Whether `data` holds a Modbus TCP frame, or the head of one, with the transaction id and unit id of
    `request`, after any whole frames of other requests."""
    if len(request) < MBAP.size:
        return False
    head = request[:4]  # the transaction id and protocol id 0 the reply must carry
    at = 0
    while at < len(data):
        rest = data[at:]
        if len(rest) < MBAP.size:
            return head.startswith(rest[:4])
        _, protocol, length, got = MBAP.unpack_from(rest)
        if rest[:4] == head and got == unit:
            return True
        if protocol != 0 or length < 2:
            return False
        at += MBAP.size - 1 + length
    return False


def refused_problem(wire: Wire, unit: int, object_id: int, timeout: float) -> str:
    """What was wrong with the bytes that came back for an identification request the client did not take."""
    pdu = reply_pdu(wire, unit) if not wire.rtu else rtu_whole_frame(wire, unit)
    if pdu is not None:
        try:
            parse_identification(pdu, object_id)
        except ValueError as exc:
            return str(exc)
    if wire.rtu and max(map(len, wire.received)) > RTU_MAX:
        return f"more than {RTU_MAX} bytes came, more than a Modbus RTU frame holds"
    data = wire.received[0] if wire.received else b""  # from where the reply began
    shown = data[:16].hex(" ") + (" ..." if len(data) > 16 else "")
    return f"no whole reply within {timeout:g} s ({len(data)} bytes came: {shown})"


def rtu_whole_frame(wire: Wire, unit: int) -> bytes | None:
    """The PDU of an RTU function 43 reply of `unit` that the client did not take because its own count and
    length bytes size it wrong: the bytes received from its start up to the first good CRC; None if none."""
    for data in dict.fromkeys((wire.received[-1], wire.received[0])):
        if len(data) > RTU_MAX or data[:2] != bytes([unit, MEI_FUNCTION]):
            continue
        for end in range(4, len(data) + 1):
            if FramerRTU.compute_CRC(data[: end - 2]) == int.from_bytes(data[end - 2 : end], "big"):
                return data[1 : end - 2]
    return None


def drain(port: Any, quiet: float, limit: float) -> bytes | None:
    """Read and drop what a serial line brings until nothing has come for `quiet` seconds: None then;
    the first bytes dropped if `limit` seconds pass with the line still busy."""
    started = last = time.monotonic()
    first = b""
    while True:
        now = time.monotonic()
        waiting = port.in_waiting
        if waiting:
            data = port.read(waiting)
            first = first or data[:8]
            last = now
        elif now - last >= quiet:
            return None
        if now - started >= limit:
            return first
        time.sleep(min(quiet / 10, 0.02))
