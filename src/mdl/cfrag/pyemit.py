"""Translate typed fragment trees to Python with C's semantics (helpers in pyhelpers.py)."""

from __future__ import annotations

from mdl.cfrag.parser import INT_TYPES, arith_type, int_type_of

FLOATS = ("float", "double")


def _int_target(t):
    return t if isinstance(t, tuple) else INT_TYPES[t]


def convert(code: str, src: str, dst) -> str:
    """Convert code of expression type `src` to `dst` (a type name or (bits, signed))."""
    if dst == src:
        return code
    if dst == "double":
        return code if src == "float" else f"float({code})"
    if dst == "float":
        return f"_f32({code})" if src == "double" else f"_f32(float({code}))"
    bits, signed = _int_target(dst)
    if src in FLOATS:
        return f"_wrap(_trunc({code}), {bits}, {signed})"
    sbits, ssigned = INT_TYPES[src]
    if (ssigned == signed and sbits <= bits) or (not ssigned and signed and sbits < bits):
        return code
    return f"_wrap({code}, {bits}, {signed})"


def _arith(op: str, a: str, b: str, t: str) -> str:
    if t in FLOATS:
        expr = f"_fdiv({a}, {b})" if op == "/" else f"({a} {op} {b})"
        return f"_f32({expr})" if t == "float" else expr
    bits, signed = INT_TYPES[t]
    if op == "/":
        expr = f"_idiv({a}, {b})"
    elif op == "%":
        expr = f"_imod({a}, {b})"
    else:
        expr = f"({a} {op} {b})"
    return f"_wrap({expr}, {bits}, {signed})"


def emit(node) -> str:
    kind = node[0]
    if kind == "num":
        return repr(node[2])
    if kind == "var":
        return node[2]
    if kind == "cast":
        _, rtype, target, inner = node
        code = convert(emit(inner), inner[1], target)
        if isinstance(target, tuple) and int_type_of(*target) != rtype:
            raise AssertionError("cast type mismatch")
        return code
    if kind == "unary":
        _, t, op, inner = node
        code = emit(inner)
        if op == "!":
            return f"(0 if {code} else 1)"
        if op == "+":
            return code
        if t in FLOATS:
            return f"(-{code})"
        bits, signed = INT_TYPES[t]
        return f"_wrap({op}{code}, {bits}, {signed})"
    if kind == "cond":
        _, t, c, a, b = node
        return f"({convert(emit(a), a[1], t)} if {emit(c)} else {convert(emit(b), b[1], t)})"
    _, t, op, left, right, optype = node
    a, b = emit(left), emit(right)
    if op in ("&&", "||"):
        return f"(1 if ({a}) {'and' if op == '&&' else 'or'} ({b}) else 0)"
    if op in ("<<", ">>"):
        if op == ">>":
            return f"({a} >> {b})"
        bits, signed = INT_TYPES[t]
        return f"_wrap({a} << {b}, {bits}, {signed})"
    a, b = convert(a, left[1], optype), convert(b, right[1], optype)
    if op in ("==", "!=", "<", ">", "<=", ">="):
        return f"(1 if {a} {op} {b} else 0)"
    return _arith(op, a, b, optype)


def statement(target: str, op: str, value) -> str:
    """One assignment as a Python line."""
    ttype = "double" if target == "arg" else "int"
    if op != "=":
        bop = op[:-1]
        left = ("var", ttype, target)
        if bop in ("<<", ">>"):
            value = ("bin", ttype, bop, left, value, ttype)
        else:
            optype = arith_type(ttype, value[1])
            value = ("bin", optype, bop, left, value, optype)
    dst = "double" if target == "arg" else (16, False)
    return f"{target} = {convert(emit(value), value[1], dst)}"
