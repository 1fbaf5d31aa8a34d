"""Translate typed fragment trees to Python with C's semantics (helpers in pyhelpers.py)."""

from __future__ import annotations

from mdl.cfrag.parser import INT_TYPES, CNode, IntType, arith_type, int_type_of

FLOATS = ("float", "double")


def _int_target(t: str | IntType) -> IntType:
    return t if isinstance(t, tuple) else INT_TYPES[t]


def bare(code: str) -> str:
    """`code` without parentheses that enclose all of it: the argument of a call needs none."""
    if not (code.startswith("(") and code.endswith(")")):
        return code
    depth = 0
    for i, ch in enumerate(code):
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if depth == 0 and i < len(code) - 1:
            return code  # the first parenthesis closes before the end: "(a) + (b)"
    return code[1:-1]


def convert(code: str, src: str, dst: str | IntType) -> str:
    """Convert code of expression type `src` to `dst` (a type name or (bits, signed))."""
    if dst == src:
        return code
    if dst == "double":
        return code if src == "float" else f"float({bare(code)})"
    if dst == "float":
        return f"_f32({bare(code)})" if src == "double" else f"_f32(float({bare(code)}))"
    bits, signed = _int_target(dst)
    if src in FLOATS:
        return f"_wrap(_trunc({bare(code)}), {bits}, {signed})"
    sbits, ssigned = INT_TYPES[src]
    if (ssigned == signed and sbits <= bits) or (not ssigned and signed and sbits < bits):
        return code
    return f"_wrap({bare(code)}, {bits}, {signed})"


def _arith(op: str, a: str, b: str, t: str) -> str:
    if t in FLOATS:
        expr = f"_fdiv({bare(a)}, {bare(b)})" if op == "/" else f"({a} {op} {b})"
        return f"_f32({bare(expr)})" if t == "float" else expr
    bits, signed = INT_TYPES[t]
    if op == "/":
        expr = f"_idiv({bare(a)}, {bare(b)})"
    elif op == "%":
        expr = f"_imod({bare(a)}, {bare(b)})"
    else:
        expr = f"{a} {op} {b}"
    return f"_wrap({expr}, {bits}, {signed})"


def _unary(t: str, op: str, inner: CNode) -> str:
    code = emit(inner)
    if op == "!":
        return f"(0 if {code} else 1)"
    if op == "+":
        return code
    if t in FLOATS:
        return f"(-{code})"
    bits, signed = INT_TYPES[t]
    return f"_wrap({op}{code}, {bits}, {signed})"


def _binary(t: str, op: str, left: CNode, right: CNode, optype: str | None) -> str:
    a, b = emit(left), emit(right)
    if op in ("&&", "||"):
        return f"(1 if ({bare(a)}) {'and' if op == '&&' else 'or'} ({bare(b)}) else 0)"
    if op == ">>":
        return f"({a} >> {b})"
    if op == "<<":
        bits, signed = INT_TYPES[t]
        return f"_wrap({a} << {b}, {bits}, {signed})"
    assert optype is not None  # only && and || have none
    a, b = convert(a, left[1], optype), convert(b, right[1], optype)
    if op in ("==", "!=", "<", ">", "<=", ">="):
        return f"(1 if {a} {op} {b} else 0)"
    return _arith(op, a, b, optype)


def emit(node: CNode) -> str:
    match node:
        case ("num", _, value):
            return repr(value)
        case ("var", _, name):
            return name
        case ("cast", rtype, target, inner):
            code = convert(emit(inner), inner[1], target)
            if isinstance(target, tuple) and int_type_of(*target) != rtype:
                raise AssertionError("cast type mismatch")
            return code
        case ("unary", t, op, inner):
            return _unary(t, op, inner)
        case ("cond", t, c, a, b):
            return f"({convert(emit(a), a[1], t)} if {emit(c)} else {convert(emit(b), b[1], t)})"
        case ("bin", t, op, left, right, optype):
            return _binary(t, op, left, right, optype)
    raise AssertionError(f"unknown fragment node {node[0]}")


def statement(target: str, op: str, value: CNode) -> str:
    """One assignment as a Python line."""
    ttype = "double" if target == "arg" else "int"
    if op != "=":
        bop = op[:-1]
        left: CNode = ("var", ttype, target)
        if bop in ("<<", ">>"):
            value = ("bin", ttype, bop, left, value, ttype)
        else:
            optype = arith_type(ttype, value[1])
            value = ("bin", optype, bop, left, value, optype)
    dst: str | IntType = "double" if target == "arg" else (16, False)
    return f"{target} = {bare(convert(emit(value), value[1], dst))}"
