"""How Home Assistant's modbus integration reads and writes a layout (`mdl export --to homeassistant`; docs/fleet.md).

A sensor or climate unpacks its registers with a struct format: `data_type` (int16 ... uint64, float32/64,
string with its `count`, or `custom` with a `structure` for one byte of a register), after `swap` (byte: each
register's bytes; word: the registers' order; word_byte: both; base_platform.py `_swap_registers`). `ha_type`
gives the keys that read a layout as mdl does, or why none does; `unpacked` what Home Assistant unpacks from
registers, `packed` the registers its climate writes for a value (climate.py `async_set_temperature`).
"""

from __future__ import annotations

import struct
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mdl.model.layout import Layout

TYPES = {
    ("int", 16, True): "int16",
    ("int", 16, False): "uint16",
    ("int", 32, True): "int32",
    ("int", 32, False): "uint32",
    ("int", 64, True): "int64",
    ("int", 64, False): "uint64",
    ("float", 32, True): "float32",
    ("float", 64, True): "float64",
}
STRUCT = {
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "int64": "q",
    "uint64": "Q",
    "float32": "f",
    "float64": "d",
}
INTEGERS = frozenset(("int16", "uint16", "int32", "uint32", "int64", "uint64"))
NO_DATA_TYPE = "no data_type holds its value"


def shape(lay: Layout) -> str:
    return f"a {lay.bits}-bit {lay.kind} in {len(lay.addresses)} registers"


def ha_type(lay: Layout) -> dict[str, Any] | str:
    """data_type with its swap, count or structure, as Home Assistant reads the layout; or why none does
    (NO_DATA_TYPE: `shape` says what the value is)."""
    n = len(lay.addresses)
    if lay.unit in ("low", "high") or (n == 1 and lay.bits == 8):
        code = "b" if lay.signed else "B"
        low = lay.unit == "low" or (lay.unit == "word" and lay.byte_order == "big")
        return {"data_type": "custom", "structure": f">x{code}" if low else f">{code}x", "count": 1}
    swap = {
        ("big", "big"): None,
        ("little", "big"): "byte",
        ("big", "little"): "word",
        ("little", "little"): "word_byte",
    }[(lay.byte_order, lay.word_order if n > 1 else "big")]
    if lay.kind == "string":
        if swap not in (None, "byte"):
            return "text in more than one register never has its words swapped"
        return {"data_type": "string", "count": n, **({"swap": swap} if swap else {})}
    data_type = TYPES.get((lay.kind, lay.bits, lay.signed))
    if data_type is None or lay.bits != 16 * n:
        return NO_DATA_TYPE
    return {"data_type": data_type, **({"swap": swap} if swap else {})}


def _swapped(kind: dict[str, Any], registers: list[int]) -> list[int]:
    if kind.get("swap") in ("byte", "word_byte"):
        registers = [((r & 0xFF) << 8) | (r >> 8) for r in registers]
    if kind.get("swap") in ("word", "word_byte"):
        registers.reverse()
    return registers


def unpacked(kind: dict[str, Any], registers: tuple[int, ...]) -> Any:
    """What Home Assistant unpacks from `registers` for a sensor of this kind (base_platform.py)."""
    regs = _swapped(kind, list(registers))
    data = b"".join(r.to_bytes(2, "big") for r in regs)
    structure = kind.get("structure") or ">" + STRUCT[kind["data_type"]]
    return struct.unpack(structure, data)[0]


def packed(entity: dict[str, Any], value: float) -> list[int] | None:
    """The registers Home Assistant's climate writes for the target temperature `value` (climate.py
    async_set_temperature): (value - offset) / scale, cut to an integer by int() for an integer type, packed
    and swapped; None where it cannot pack it (out of the type's range)."""
    target = (float(value) - float(entity.get("offset", 0))) / float(entity.get("scale", 1))
    data_type = entity["data_type"]
    try:
        data = struct.pack(">" + STRUCT[data_type], int(target) if data_type in INTEGERS else target)
    except (struct.error, OverflowError, ValueError):
        return None
    return _swapped(entity, [int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2)])
