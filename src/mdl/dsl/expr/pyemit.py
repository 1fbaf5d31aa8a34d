"""Lowered expression operations -> straight-line Python (helpers in pyhelpers.py)."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from pathlib import Path

from mdl.dsl.cfrag import HELPERS_SOURCE as _C_HELPERS
from mdl.dsl.expr.lower import Lowered
from mdl.dsl.expr.ops import Op, OpKind, printer

# the expression runtime, with the C-semantics helpers it shares (_fdiv); generated Python drivers
# copy the functions they call from it (mdl.targets.python.emit)
HELPERS_SOURCE = _C_HELPERS + "\n\n" + (Path(__file__).parent / "pyhelpers.py").read_text(encoding="utf-8")


def _unary(expr: Callable[[str, Op], str]) -> Callable[[Op], str]:
    """An operation of one argument: None where the argument is None, else `expr(a, op)`."""
    return lambda op: f"{op.tmp} = None if {op.args[0]} is None else {expr(op.args[0], op)}"


def _binary(expr: Callable[[str, str, Op], str]) -> Callable[[Op], str]:
    """An operation of two arguments: None where either is None, else `expr(a, b, op)`."""

    def line(op: Op) -> str:
        a, b = op.args
        return f"{op.tmp} = None if {a} is None or {b} is None else {expr(a, b, op)}"

    return line


def _register(expr: str) -> Callable[[Op], str]:
    """A register function (`expr` of `{a}` the registers and `{d}` the data): None where the
    registers are None or a "not implemented" value."""

    def line(op: Op) -> str:
        a, d = op.args[0], op.data
        guard = f"{a} is None" + (f" or {a} in {tuple(d['ni'])!r}" if d["ni"] else "")
        return f"{op.tmp} = None if {guard} else {expr.format(a=a, d=d)}"

    return line


def _label(a: str, op: Op) -> str:
    f, t = op.data["labels"]
    return f"({t!r} if {a} else {f!r})"


def _arith(a: str, b: str, op: Op) -> str:
    expr = f"{a} {op.data['op']} {b}"
    return f"_x_long({expr})" if op.type == "long" else expr


# one line of Python per operation kind (mdl.dsl.expr.ops says what each computes)
PRINTER = printer(
    {
        OpKind.LIT: lambda op: f"{op.tmp} = {op.data['value']!r}",
        OpKind.REGS: lambda op: f"{op.tmp} = _x_regs(r, {tuple(op.data['index'])!r})",
        OpKind.CONST: lambda op: f"{op.tmp} = {[hex(w) for w in op.data['words']]!r}".replace("'", ""),
        OpKind.SWAPBYTES: _unary(lambda a, op: f"_x_swapbytes({a})"),
        OpKind.SWAPENDIAN: _unary(lambda a, op: f"_x_swapendian({a})"),
        OpKind.CONCAT: lambda op: f"{op.tmp} = ''.join(_x_text(v) for v in ({', '.join(op.args)},))",
        OpKind.BIT: _unary(lambda a, op: f"{a}[0] != 0"),
        OpKind.LABEL: _unary(_label),
        OpKind.TODOUBLE: _unary(lambda a, op: f"float({a})"),
        OpKind.NEG: _unary(lambda a, op: f"_x_long(-{a})" if op.type == "long" else f"-{a}"),
        OpKind.ARITH: _binary(_arith),
        OpKind.DIV: _binary(lambda a, b, op: f"_fdiv({a}, {b})"),
        OpKind.POW: _binary(lambda a, b, op: f"_x_pow({a}, {b})"),
        OpKind.INT16: _register("_x_int({a}, 16, True)"),
        OpKind.UINT16: _register("_x_int({a}, 16, False)"),
        OpKind.INT32: _register("_x_int({a}, 32, True)"),
        OpKind.UINT32: _register("_x_int({a}, 32, False)"),
        OpKind.INT64: _register("_x_int({a}, 64, True)"),
        OpKind.UINT64: _register("_x_int({a}, 64, False)"),
        OpKind.IEEE754_32: _register("_x_float({a}, 32)"),
        OpKind.IEEE754_64: _register("_x_float({a}, 64)"),
        OpKind.UTF8: _register("_x_utf8({a})"),
        OpKind.HEXSTRING: _register("_x_hexstring({a})"),
        OpKind.EUI48: _register("_x_eui48({a})"),
        OpKind.IPV4ADDR: _register("_x_ipv4addr({a})"),
        OpKind.IPV6ADDR: _register("_x_ipv6addr({a})"),
        OpKind.ENUM: _register("_x_enum({a}, {d[mapping]!r})"),
        OpKind.BITSET: _register("_x_bitset({a}, {d[mapping]!r})"),
        OpKind.BITSETBIT: _register("_x_uint({a}) >> {d[bit]} & 1 == 1"),
    }
)


def body(lowered: Lowered) -> list[str]:
    """Lines computing the value from `r` (the function's registers, ascending) and p0..pn (a
    plain UINT64 one first taken as the long it is: its 64 bits, lowered.wide). Printed once per
    shape (Lowered.shape: equal shapes have equal operations) and `wide`."""
    if lowered.shape is None:
        return _body(lowered)
    key = (lowered.shape, lowered.wide)
    lines = _BODIES.get(key)
    if lines is None:
        if len(_BODIES) >= _BODIES_KEPT:
            _BODIES.clear()
        lines = _BODIES[key] = _body(lowered)
    return list(lines)


_BODIES: dict[Hashable, list[str]] = {}  # (shape, wide) -> body
_BODIES_KEPT = 4096  # shapes: a device has a few dozen; a process that reads many devices starts again past this


def _body(lowered: Lowered) -> list[str]:
    wide = [f"p{i} = None if p{i} is None else _x_long(p{i})" for i in lowered.wide]
    return wide + [PRINTER[op.kind](op) for op in lowered.ops] + [f"return {lowered.result}"]


def signature(lowered: Lowered) -> str:
    return ", ".join(["r"] + [f"p{i}" for i in range(len(lowered.refs))])
