"""Lowered expression operations -> straight-line Python (helpers in pyhelpers.py)."""

from __future__ import annotations

from pathlib import Path

from mdl.lang.cfrag import HELPERS_SOURCE as _C_HELPERS
from mdl.lang.expr.lower import Lowered, Op

# the expression runtime, with the C-semantics helpers it shares (_fdiv); generated Python drivers
# copy the functions they call from it (mdl.targets.python.emit)
HELPERS_SOURCE = _C_HELPERS + "\n\n" + (Path(__file__).parent / "pyhelpers.py").read_text(encoding="utf-8")

_CONVERT = {"int16": "_x_int({a}, 16, True)", "uint16": "_x_int({a}, 16, False)", "int32": "_x_int({a}, 32, True)",
            "uint32": "_x_int({a}, 32, False)", "int64": "_x_int({a}, 64, True)", "uint64": "_x_int({a}, 64, False)",
            "ieee754_32": "_x_float({a}, 32)", "ieee754_64": "_x_float({a}, 64)", "utf8": "_x_utf8({a})",
            "hexstring": "_x_hexstring({a})", "eui48": "_x_eui48({a})", "ipv4addr": "_x_ipv4addr({a})",
            "ipv6addr": "_x_ipv6addr({a})"}


def _line(op: Op) -> str:
    a = op.args[0] if op.args else None
    d = op.data
    if op.kind == "lit":
        return f"{op.tmp} = {d['value']!r}"
    if op.kind == "regs":
        return f"{op.tmp} = _x_regs(r, {tuple(d['index'])!r})"
    if op.kind == "const":
        return f"{op.tmp} = {[hex(w) for w in d['words']]!r}".replace("'", "")
    if op.kind in ("swapbytes", "swapendian"):
        return f"{op.tmp} = None if {a} is None else _x_{op.kind}({a})"
    if op.kind == "bit":
        return f"{op.tmp} = None if {a} is None else {a}[0] != 0"
    if op.kind == "label":
        f, t = d["labels"]
        return f"{op.tmp} = None if {a} is None else ({t!r} if {a} else {f!r})"
    if op.kind == "concat":
        return f"{op.tmp} = ''.join(_x_text(v) for v in ({', '.join(op.args)},))"
    if op.kind == "todouble":
        return f"{op.tmp} = None if {a} is None else float({a})"
    if op.kind == "neg":
        expr = f"_x_long(-{a})" if op.type == "long" else f"-{a}"
        return f"{op.tmp} = None if {a} is None else {expr}"
    if op.kind in ("arith", "div", "pow"):
        b = op.args[1]
        if op.kind == "div":
            expr = f"_fdiv({a}, {b})"
        elif op.kind == "pow":
            expr = f"_x_pow({a}, {b})"
        elif op.type == "long":
            expr = f"_x_long({a} {d['op']} {b})"
        else:
            expr = f"{a} {d['op']} {b}"
        return f"{op.tmp} = None if {a} is None or {b} is None else {expr}"
    # register functions: null registers or a "not implemented" value give null
    guard = f"{a} is None" + (f" or {a} in {tuple(d['ni'])!r}" if d["ni"] else "")
    if op.kind == "enum":
        expr = f"_x_enum({a}, {d['mapping']!r})"
    elif op.kind == "bitset":
        expr = f"_x_bitset({a}, {d['mapping']!r})"
    elif op.kind == "bitsetbit":
        expr = f"_x_uint({a}) >> {d['bit']} & 1 == 1"
    else:
        expr = _CONVERT[op.kind].format(a=a)
    return f"{op.tmp} = None if {guard} else {expr}"


def body(lowered: Lowered) -> list[str]:
    """Lines computing the value from `r` (the function's registers, ascending) and p0..pn (a
    plain UINT64 one first taken as the long it is: its 64 bits, lowered.wide)."""
    wide = [f"p{i} = None if p{i} is None else _x_long(p{i})" for i in lowered.wide]
    return wide + [_line(op) for op in lowered.ops] + [f"return {lowered.result}"]


def signature(lowered: Lowered) -> str:
    return ", ".join(["r"] + [f"p{i}" for i in range(len(lowered.refs))])
