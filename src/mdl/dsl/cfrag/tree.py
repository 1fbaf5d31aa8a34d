"""Typed trees of checked fragments, and C's types on x86-64 (LP64) as the subset uses them.

Expression types: int and unsigned are 32 bits, long and ulong 64, float and double IEEE 754
single and double. A cast to a type narrower than int converts and then promotes to int.
Nodes are tuples whose second item is the expression type:
("num", type, value) ("var", type, name) ("cast", type, target, node)
("unary", type, op, node) ("bin", type, op, left, right, operand type) ("cond", type, c, a, b).
The operand type of a binary node is the type its operands are converted to (None for && and ||;
for shifts, the promoted type of the left operand).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Literal, TypeAlias

from mdl.model.layout import integer_range

if TYPE_CHECKING:
    from fractions import Fraction

IntType: TypeAlias = tuple[int, bool]  # (bits, signed)
CastTarget: TypeAlias = IntType | Literal["float", "double"]

NumNode: TypeAlias = tuple[Literal["num"], str, int | float]
VarNode: TypeAlias = tuple[Literal["var"], str, str]
CastNode: TypeAlias = tuple[Literal["cast"], str, CastTarget, "CNode"]
UnaryNode: TypeAlias = tuple[Literal["unary"], str, str, "CNode"]
BinNode: TypeAlias = tuple[Literal["bin"], str, str, "CNode", "CNode", str | None]
CondNode: TypeAlias = tuple[Literal["cond"], str, "CNode", "CNode", "CNode"]
CNode: TypeAlias = NumNode | VarNode | CastNode | UnaryNode | BinNode | CondNode
# (target, "=", value): compound assignments arrive as `target = target op value`, checked as such
Statement: TypeAlias = tuple[str, str, CNode]

# cast name -> (bits, signed) for integers, or "float"/"double"
CASTS: dict[str, CastTarget] = {
    "int8_t": (8, True),
    "uint8_t": (8, False),
    "int16_t": (16, True),
    "uint16_t": (16, False),
    "int32_t": (32, True),
    "uint32_t": (32, False),
    "int64_t": (64, True),
    "uint64_t": (64, False),
    "int": (32, True),
    "unsigned": (32, False),
    "float": "float",
    "double": "double",
}
# integer expression types: name -> (bits, signed)
INT_TYPES: dict[str, IntType] = {"int": (32, True), "unsigned": (32, False), "long": (64, True), "ulong": (64, False)}
FLOATS = ("float", "double")
COMPARISONS = ("==", "!=", "<", ">", "<=", ">=")
FLT_MAX = float.fromhex("0x1.fffffep127")


def int_type_of(bits: int, signed: bool) -> str:
    """The type a value of a cast has once promoted in an expression."""
    if bits < 32:
        return "int"
    if bits == 32:
        return "int" if signed else "unsigned"
    return "long" if signed else "ulong"


def int_range(t: str | IntType) -> tuple[int, int]:
    bits, signed = INT_TYPES[t] if isinstance(t, str) else t
    return integer_range(bits, signed)


def c_type_name(t: str | IntType) -> str:
    """The C name of an expression type or of an integer cast target."""
    if isinstance(t, tuple):
        return f"{'' if t[1] else 'u'}int{t[0]}_t"
    return {"int": "int32_t", "unsigned": "uint32_t", "long": "int64_t", "ulong": "uint64_t"}.get(t, t)


def arith_type(a: str, b: str) -> str:
    """C's usual arithmetic conversions: the type two operands are converted to."""
    if "double" in (a, b):
        return "double"
    if "float" in (a, b):
        return "float"
    (ab, asg), (bb, bsg) = INT_TYPES[a], INT_TYPES[b]
    if asg == bsg:
        return a if ab >= bb else b
    (sb, st), (ub, ut) = ((ab, a), (bb, b)) if asg else ((bb, b), (ab, a))
    if ub >= sb:
        return ut
    return st  # a 64-bit signed type holds every 32-bit unsigned value


def children(node: CNode) -> list[CNode]:
    """The operands of a node, left to right."""
    match node:
        case ("cast", _, _, inner) | ("unary", _, _, inner):
            return [inner]
        case ("bin", _, _, left, right, _):
            return [left, right]
        case ("cond", _, c, a, b):
            return [c, a, b]
    return []


def round_to_float(q: Fraction) -> float:
    """The IEEE single-precision value nearest to q (ties to even), as a C compiler reads a float literal."""
    from fractions import Fraction  # here: only float literals need it

    if q < 0:
        return -round_to_float(-q)
    if q == 0:
        return 0.0
    e = q.numerator.bit_length() - q.denominator.bit_length()
    if Fraction(2) ** e > q:
        e -= 1  # now 2**e <= q < 2**(e + 1)
    shift = max(e - 23, -149)  # 24 significant bits; subnormals below 2**-126
    value = round(q / Fraction(2) ** shift) * 2.0**shift
    return math.inf if value > FLT_MAX else value
