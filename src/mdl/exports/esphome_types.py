"""How ESPHome's modbus_controller reads a layout (`mdl export --to esphome`; docs/fleet.md, "ESPHome").

ESPHome reads every register's bytes most significant first (modbus helpers get_data), and the words of a
value most significant first (U_WORD, S_WORD, U_DWORD, S_DWORD, U_QWORD, S_QWORD, FP32) or least
significant first (the `_R` types); `bitmask` keeps the bits it sets and shifts them down to bit 0
(mask_and_shift_by_rightbit; not for the QWORD types). A sensor's value is then a 32-bit float.
`value_type` gives the type and bitmask that read a layout exactly as mdl does, or why none does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from mdl.ir.steps import Bits, Mask, Scale, SignExtend, ToFloat, find_step

if TYPE_CHECKING:
    from mdl.model.layout import Layout
    from mdl.resolver import ResolvedFunction

FLOAT_EXACT = 1 << 24  # the integers a 32-bit float holds exactly: up to 2^24
_INT = {16: "WORD", 32: "DWORD", 64: "QWORD"}
LITTLE_BYTES = "each register's bytes are read most significant first (no byte swap)"


@dataclass(frozen=True)
class ValueType:
    """An ESPHome value_type, the bitmask it takes (None: the default, every bit), and whether the value is a
    signed byte (ESPHome reads it unsigned: a filter makes it signed)."""

    name: str
    bitmask: int | None = None
    signed_byte: bool = False


def _byte(lay: Layout) -> ValueType:
    low = lay.unit == "low" or (lay.unit == "word" and lay.byte_order == "big")
    return ValueType("U_WORD", 0x00FF if low else 0xFF00, lay.signed)


def value_type(lay: Layout) -> ValueType | str:
    """The value_type (and bitmask) that reads `lay` as mdl does, or why none does."""
    n = len(lay.addresses)
    if lay.unit in ("low", "high") or (n == 1 and lay.bits == 8):
        return _byte(lay)
    if lay.byte_order == "little":
        return LITTLE_BYTES
    reversed_words = "_R" if n > 1 and lay.word_order == "little" else ""
    if lay.bits != 16 * n:
        return f"no value type reads a {lay.bits}-bit {lay.kind} in {n} registers"
    if lay.kind == "float":
        return ValueType("FP32" + reversed_words) if lay.bits == 32 else "no value type reads a 64-bit float"
    if lay.kind == "int" and lay.bits in _INT:
        return ValueType(("S_" if lay.signed else "U_") + _INT[lay.bits] + reversed_words)
    return f"no value type reads a {lay.bits}-bit {lay.kind}"


def with_bits(f: ResolvedFunction, vt: ValueType) -> ValueType | str:
    """`vt` with the bitmask of the function's `bits` range (a range of an unsigned whole value), or why not."""
    step = find_step(f.codec.decode, Bits)
    if step is None:
        return vt
    if vt.bitmask is not None or "QWORD" in vt.name or vt.name.startswith(("S_", "FP")):
        return "a bitmask takes bits of an unsigned 16- or 32-bit value only"
    if any(find_step(f.codec.decode, kind) is not None for kind in (SignExtend, ToFloat, Mask)):
        return "a bitmask takes bits of an unsigned 16- or 32-bit value only"
    return ValueType(vt.name, ((1 << step.width) - 1) << step.shift)


def rounds(f: ResolvedFunction, vt: ValueType) -> bool:
    """Whether ESPHome's 32-bit float may round the integers `f` reads (beyond 2^24): a 32- or 64-bit integer
    without a bitmask under 2^24 or an unscaled minimum and maximum within it."""
    if not vt.name.endswith(("DWORD", "DWORD_R", "QWORD", "QWORD_R")):
        return False
    if vt.bitmask is not None and vt.bitmask < FLOAT_EXACT:
        return False
    low, high = f.fn.minimum, f.fn.maximum
    bounded = low is not None and high is not None and max(abs(low), abs(high)) <= FLOAT_EXACT
    return not (bounded and find_step(f.codec.decode, Scale) is None)
