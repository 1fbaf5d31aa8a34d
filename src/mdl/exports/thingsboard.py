"""`mdl export --to thingsboard`: the ThingsBoard IoT Gateway's Modbus connector configuration (SPEC 11;
docs/fleet.md, "ThingsBoard").

JSON `{"master": {"slaves": [...]}}` as the gateway's modbus connector reads it (thingsboard-gateway 3.8:
connectors/modbus slave.py, bytes_modbus_uplink_converter.py). The gateway reads byteOrder and wordOrder
per slave, so the device is one slave per byte and word order its functions need, every one with the
device's name (the gateway joins their data into one device), the connection of the command line, unitId
(--unit) and pollPeriod (--interval, in ms). Each readable function is a point of `timeseries` (numbers,
flags) or `attributes` (text, and functions marked immutable or system): `tag` (the function's name),
`type` (8int ... 64uint, 32float, 64float, string, bits), `functionCode` (1-4), `address`,
`objectsCount` (registers or coils), `divider` or `multiplier` (mdl's scale), `variants` (an
enumeration's labels) and `round` for a float (324 places: Python's round then gives the value itself; the
gateway rounds to 6 places unless told). Each writable function is also in `attributeUpdates` (a shared
attribute of that name writes it) and `rpc` (a method of that name writes its params), with the function
code mdl writes with (5/15, 6/16).
Whatever the gateway cannot express is said with one warning per kind of loss (base.Notes).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mdl.exchange.export import Export
from mdl.exchange.text import json_text
from mdl.exports.base import (
    Notes,
    bits_detail,
    connection_of,
    factor_detail,
    left_out_unreadable,
    nothing_left,
    plain_number,
    register_bit,
    scale_of,
    warn_patterns,
    write_code,
    written_by_fragment,
)

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.resolver import ResolvedDevice, ResolvedFunction

ENGINE = "ThingsBoard"
NOT_IMPLEMENTED = "no 'not implemented' value: the values that mean it read as values"
KEEP_FLOAT = 324  # round(x, n) returns x itself for n > 323 (CPython's float.__round__)
Point = dict[str, Any]
Orders = tuple[str, str | None]  # (byteOrder, wordOrder) a point needs; None: either word order


def _read_code(f: ResolvedFunction) -> int:
    return {"coil": 1, "discrete": 2, "holding": 3, "input": 4}[f.layout.table]


def _kind(f: ResolvedFunction, notes: Notes) -> tuple[Point, Orders] | None:
    """The point's type and objectsCount, and the byte and word order it is read with; or None (warned)."""
    lay = f.layout
    n = len(lay.addresses)
    if lay.table in ("coil", "discrete"):
        return {"type": "bits", "objectsCount": 1}, ("BIG", None)
    if lay.kind == "bool":
        notes.warn(f, "shows the register's number, not true or false (mdl: true when the register is not 0)")
        return {"type": "16uint", "objectsCount": 1}, ("BIG", None)
    if lay.unit in ("low", "high") or (n == 1 and lay.bits == 8):
        if lay.unit == "low" or (lay.unit == "word" and lay.byte_order == "big"):
            notes.warn(f, "8int and 8uint read a register's first byte as sent, never its low byte: left out")
            return None
        return {"type": f"8{'int' if lay.signed else 'uint'}", "objectsCount": 1}, ("BIG", None)
    orders: Orders = (lay.byte_order.upper(), lay.word_order.upper() if n > 1 else None)
    if lay.kind == "string":
        if lay.byte_order == "little" or (n > 1 and lay.word_order == "little"):
            notes.warn(f, "text is read as its registers are sent, bytes and words in order: left out")
            return None
        notes.warn(f, "the text keeps the NUL padding and trailing spaces mdl strips")
        return {"type": "string", "objectsCount": n}, orders
    if lay.bits != 16 * n or lay.bits not in (16, 32, 64) or lay.kind not in ("int", "float"):
        notes.warn(f, "no type reads it: left out", f"a {lay.bits}-bit {lay.kind} in {n} registers")
        return None
    name = "float" if lay.kind == "float" else ("int" if lay.signed else "uint")
    point: Point = {"type": f"{lay.bits}{name}", "objectsCount": n}
    if lay.kind == "float":
        point["round"] = KEEP_FLOAT
    return point, orders


BITS_FIRST = 8  # the bit a `bits` point of one register reads: the first of its first byte as sent (LSB first)


def _bit(f: ResolvedFunction, notes: Notes) -> tuple[Point, Orders] | None:
    """A one-bit function as a `bits` point: the gateway decodes the register's bytes as sent, each least
    significant bit first, and keeps as many bits as it reads registers (objectsCount): one register gives
    bit 8. Another bit, or a range, is left out (warned)."""
    found = register_bit(f)
    if found is None or found[1] != BITS_FIRST:
        where = f"bit {found[1]} of register {found[0]}" if found is not None else bits_detail(f.fn)
        notes.warn(
            f,
            "a bits point of one register reads its bit 8 only (the count is also the registers read): left out",
            where,
        )
        return None
    return {"type": "bits", "objectsCount": 1, "address": found[0]}, ("BIG", None)


def _scale(f: ResolvedFunction, point: Point, notes: Notes) -> bool:
    """divider or multiplier on the point; False (warned) when an offset makes it inexpressible."""
    step = scale_of(f)
    if step is None:
        return True
    if step.offset != 0:
        notes.warn(
            f, "a point has no offset, only a divider or multiplier: left out", f"offset {plain_number(step.offset)}"
        )
        return False
    if step.divisor:
        point["divider"] = step.divisor
    elif step.multiplier != 1:
        point["multiplier"] = step.multiplier
    return True


def _read_point(f: ResolvedFunction, notes: Notes) -> tuple[Point, Orders] | None:
    if left_out_unreadable(f, notes):
        return None
    if f.fn.factor is not None:
        notes.warn(
            f,
            "a point's divider or multiplier is a constant, never another register's value: left out",
            factor_detail(f.fn),
        )
        return None
    found = _bit(f, notes) if f.fn.bits is not None else _kind(f, notes)
    if found is None:
        return None
    kind, orders = found
    point: Point = {"tag": f.name, "functionCode": _read_code(f), "address": f.layout.addresses[0], **kind}
    if not _scale(f, point, notes):
        return None
    if f.fn.values and "divider" not in point and "multiplier" not in point:
        point["variants"] = {str(key): label for key, label in f.fn.values.items()}
    elif f.fn.values:
        notes.warn(f, "variants match the scaled number's text: the labels are left out, the number shown")
    warn_patterns(f, notes, NOT_IMPLEMENTED)
    return point, orders


def _write_point(f: ResolvedFunction, notes: Notes) -> tuple[Point, Orders] | None:
    """The point that writes `f` (attributeUpdates, rpc), or None (warned where mdl could write it)."""
    if written_by_fragment(f):
        notes.warn(f, "a write fragment encodes it, which the gateway cannot: not writable here")
        return None
    if f.fn.bits is not None:
        notes.warn(f, "the gateway writes whole registers, not some bits of one: not writable here", bits_detail(f.fn))
        return None
    if f.layout.unit in ("low", "high"):
        notes.warn(f, "the gateway writes whole registers, not one byte of one: not writable here")
        return None
    found = _kind(f, notes)  # (Notes says each loss once)
    if found is None:
        return None
    kind, orders = found
    kind.pop("round", None)
    step = scale_of(f)
    if step is not None and (step.multiplier != 1 or step.offset != 0):
        notes.warn(f, "the gateway writes the value it is given into the registers, unscaled (the register value)")
    return {"tag": f.name, **kind, "functionCode": write_code(f), "address": f.layout.addresses[0]}, orders


def _attribute(f: ResolvedFunction) -> bool:
    """Whether the function is a device attribute (text, or marked immutable or system) rather than telemetry."""
    return f.layout.kind == "string" or bool(f.fn.immutable) or bool(f.fn.system)


def _connection(settings: Settings, notes: Notes) -> dict[str, Any]:
    conn = connection_of(settings, notes)
    common = {"timeout": conn.timeout, "retries": conn.retries}
    if conn.serial is not None:
        return {
            "type": "serial",
            "method": "rtu",
            "port": conn.serial,
            "baudrate": conn.baud,
            "bytesize": conn.bytesize,
            "parity": conn.parity.upper(),
            "stopbits": conn.stopbits,
            **common,
        }
    return {"type": "tcp", "method": "rtu" if conn.rtu else "socket", "host": conn.host, "port": conn.port, **common}


SECTIONS = ("timeseries", "attributes", "attributeUpdates", "rpc")


def export_thingsboard(resolved: ResolvedDevice, settings: Settings) -> Export:
    notes = Notes(resolved, ENGINE)
    connection = _connection(settings, notes)
    groups: dict[Orders, dict[str, list[Point]]] = {}
    for f in resolved.functions:
        points: list[tuple[str, Point, Orders]] = []
        if f.fn.readable:
            read = _read_point(f, notes)
            if read is not None:
                points.append(("attributes" if _attribute(f) else "timeseries", *read))
        if f.fn.writable:
            write = _write_point(f, notes)
            if write is not None:
                points += [("attributeUpdates", *write), ("rpc", dict(write[0]), write[1])]
        if not f.fn.readable and not f.fn.writable:
            notes.warn(f, "neither readable nor writable here: left out")
        for section, point, orders in points:
            groups.setdefault(orders, {}).setdefault(section, []).append(point)
    if not groups:
        raise nothing_left(resolved, ENGINE, notes)
    slaves = []
    for (byte_order, word_order), sections in _merged(groups).items():
        slave = {
            **connection,
            "unitId": settings.unit,
            "deviceName": settings.name or resolved.name,
            "deviceType": "default",
            "byteOrder": byte_order,
            "wordOrder": word_order,
            "pollPeriod": max(1, round(settings.interval * 1000)),
        }
        slaves.append({**slave, **{name: sections.get(name, []) for name in SECTIONS}})
    if len(slaves) > 1:
        notes.note(
            f"{len(slaves)} slaves, one per byte and word order the functions need (the gateway reads them per "
            "slave), all named after the device: the gateway joins their data into one device"
        )
    return Export(text=json_text({"master": {"slaves": slaves}}, 2), warnings=notes.found)


def _merged(groups: dict[Orders, dict[str, list[Point]]]) -> dict[tuple[str, str], dict[str, list[Point]]]:
    """The slaves: a point that reads one register (either word order) joins a slave of its byte order, the
    first in the description's order (BIG words where none has one)."""
    out: dict[tuple[str, str], dict[str, list[Point]]] = {}
    for (byte_order, word_order), sections in groups.items():
        if word_order is None:
            word_order = next((w for b, w in groups if b == byte_order and w is not None), "BIG")
        target = out.setdefault((byte_order, word_order), {})
        for name, points in sections.items():
            target.setdefault(name, []).extend(points)
    return out
