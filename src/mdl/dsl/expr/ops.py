"""The straight-line operations an expression lowers to (mdl.dsl.expr.lower), each kind with
exactly what it computes, as mdl.ir.steps does for the value IR's steps: every printer (Python,
mdl.dsl.expr.pyemit; C++, mdl.targets.cpp.expressions; C, mdl.targets.c.expressions) is a table
with one entry per kind (`printer` checks it), so a kind added here is printed everywhere or
fails at import.

An operation `Op(tmp, kind, type, args, data)` sets its temporary `tmp` (of expression type `type`:
long, double, string, bool, list, or regs for register values) from the earlier temporaries or
parameters `args`. Every value may be null; an operation with a null operand is null unless its
kind says otherwise. `r` is the function's registers in address order, `present` which of them
were answered.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import TypedDict, TypeVar


class OpKind(Enum):
    """What an operation computes (each member's docstring says exactly what)."""

    def __new__(cls, value: str, doc: str) -> OpKind:
        member = object.__new__(cls)
        member._value_ = value
        member.__doc__ = doc
        return member

    LIT = ("lit", "`data.value`: a long, double, text or bool literal; never null.")
    REGS = ("regs", "`r[i]` for each i of `data.index` (`data.count` registers); null unless every one was answered.")
    CONST = ("const", "the register values `data.words` (`data.count` of them); never null.")
    SWAPBYTES = ("swapbytes", "the registers `args[0]`, each with its two bytes swapped.")
    SWAPENDIAN = ("swapendian", "the registers `args[0]`, each with its 16 bits in reverse order.")
    CONCAT = (
        "concat",
        "the text of each of `args` (of the types `data.types`) joined: a null as '', a bool as "
        "true/false, a double as Java's Double.toString, a list as [a, b]; never null.",
    )
    BIT = ("bit", "a bool: the one coil or discrete input `args[0]` is not 0.")
    LABEL = ("label", "`data.labels[1]` where the bool `args[0]` is true, else `data.labels[0]`.")
    TODOUBLE = ("todouble", "the long `args[0]` as a double.")
    NEG = ("neg", "minus `args[0]`: a long wraps in 64 bits, two's complement, a double is negated.")
    ARITH = ("arith", "`args[0] data.op args[1]` (+, - or *): of two longs, wrapping in 64 bits; else of two doubles.")
    DIV = ("div", "the double `args[0] / args[1]`, IEEE 754 (x/0 is an infinity or NaN).")
    POW = ("pow", "the double `args[0] ^ args[1]` (C's pow: an overflow is an infinity, a domain error NaN).")
    INT16 = ("int16", "the one register `args[0]` as a signed 16-bit integer (a long).")
    UINT16 = ("uint16", "the one register `args[0]` as an unsigned 16-bit integer (a long).")
    INT32 = ("int32", "the two registers `args[0]`, first most significant, as a signed 32-bit integer.")
    UINT32 = ("uint32", "the two registers `args[0]`, first most significant, as an unsigned 32-bit integer.")
    INT64 = ("int64", "the four registers `args[0]`, first most significant, as a signed 64-bit integer.")
    UINT64 = ("uint64", "the four registers `args[0]` as an unsigned 64-bit integer; null above 2^63 - 1.")
    IEEE754_32 = ("ieee754_32", "the two registers `args[0]`, first most significant, as an IEEE 754 float (a double).")
    IEEE754_64 = ("ieee754_64", "the four registers `args[0]`, first most significant, as an IEEE 754 double.")
    UTF8 = ("utf8", "the registers' bytes, high byte first, up to the first NUL, as UTF-8 (malformed: U+FFFD).")
    HEXSTRING = ("hexstring", "the registers' bytes as `0xAB` each, separated by spaces.")
    EUI48 = ("eui48", "the last three registers' six bytes as `AA:BB:CC:DD:EE:FF`.")
    IPV4ADDR = ("ipv4addr", "the two registers' four bytes as dotted decimal.")
    IPV6ADDR = ("ipv6addr", "the eight registers as `XXXX:...` (four hex digits each, not shortened).")
    ENUM = (
        "enum",
        "the label `data.mapping` gives the registers as a signed integer of their bits, else "
        "`No mapping for value ` and their hexstring.",
    )
    BITSET = (
        "bitset",
        "a list: the label (`data.mapping`, else `Bit N`) of each set bit N of the registers "
        "(bit 0 the least significant of the last register), lowest first.",
    )
    BITSETBIT = ("bitsetbit", "a bool: bit `data.bit` of the registers (bit 0 the least significant of the last).")


# the kinds that read registers `args[0]`: null where those are null or equal one of the "not
# implemented" values `data.ni`
REGISTER_FUNCTIONS = frozenset(
    {
        OpKind.INT16,
        OpKind.UINT16,
        OpKind.INT32,
        OpKind.UINT32,
        OpKind.INT64,
        OpKind.UINT64,
        OpKind.IEEE754_32,
        OpKind.IEEE754_64,
        OpKind.UTF8,
        OpKind.HEXSTRING,
        OpKind.EUI48,
        OpKind.IPV4ADDR,
        OpKind.IPV6ADDR,
        OpKind.ENUM,
        OpKind.BITSET,
        OpKind.BITSETBIT,
    }
)


class OpData(TypedDict, total=False):
    """What an operation needs besides its arguments; which keys depend on its kind."""

    value: int | float | str | bool  # lit
    count: int  # regs, const, swaps, register functions: the number of registers
    index: list[int]  # regs: positions in the function's registers
    words: list[int]  # const
    op: str  # arith, div, pow: the operator
    types: list[str]  # concat: the type of each part
    labels: tuple[str, str]  # label: (false text, true text)
    ni: list[list[int]]  # register functions: the "not implemented" register values
    mapping: dict[int, str]  # enum, bitset
    bit: int | None  # bitsetbit


@dataclass
class Op:
    tmp: str
    kind: OpKind
    type: str
    args: list[str] = field(default_factory=list)
    data: OpData = field(default_factory=OpData)


H = TypeVar("H", bound=Callable[..., object])


def printer(table: Mapping[OpKind, H]) -> Mapping[OpKind, H]:
    """A target's printer: `table` checked to print every kind (TypeError naming those it misses)."""
    missing = [kind.value for kind in OpKind if kind not in table]
    if missing:
        raise TypeError(f"the printer misses the operation kinds {', '.join(missing)}")
    return table
