"""Typed fragment trees -> Python with the semantics of docs/fragments.md (helpers in pyhelpers.py)."""

from __future__ import annotations

import math
from functools import cache, lru_cache
from pathlib import Path
from typing import Any

from mdl.dsl.cfrag.tree import COMPARISONS, FLOATS, INT_TYPES, CNode, IntType, children, int_type_of

HELPERS_SOURCE = (Path(__file__).parent / "pyhelpers.py").read_text(encoding="utf-8")
# helpers whose errors a translated fragment can raise
FALLIBLE = ("_idiv", "_imod", "_f2i", "_store")


@cache
def helpers_namespace() -> dict[str, Any]:
    """The helpers, run: the globals translated fragments are evaluated in (never modified): pyhelpers.py
    imported, its compiled code cached as every module's is (HELPERS_SOURCE is the same file's text)."""
    from mdl.dsl.cfrag import pyhelpers

    return dict(vars(pyhelpers))


def _int_target(t: str | IntType) -> IntType:
    return t if isinstance(t, tuple) else INT_TYPES[t]


def bare(code: str) -> str:
    """`code` without parentheses that enclose all of it: the argument of a call needs none. A
    comma inside them (C's comma operator) keeps them."""
    if not (code.startswith("(") and code.endswith(")")):
        return code
    depth = 0
    for i, ch in enumerate(code):
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if (depth == 0 and i < len(code) - 1) or (depth == 1 and ch == ","):
            return code  # the first parenthesis closes before the end, "(a) + (b)", or "(f(a), b)"
    return code[1:-1]


def convert(code: str, src: str, dst: str | IntType) -> str:
    """Convert code of expression type `src` to `dst` (a type name or (bits, signed))."""
    if dst == src:
        return code
    if dst == "double":
        return code if src == "float" else f"float({bare(code)})"
    if dst == "float":
        return f"_f32({bare(code)})" if src == "double" else f"_i2f32({bare(code)})"
    bits, signed = _int_target(dst)
    if src in FLOATS:
        return f"_f2i({bare(code)}, {bits}, {signed})"
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
    if op in ("&", "|", "^") or (op in ("/", "%") and not signed):
        return f"({expr})"  # cannot leave the type
    return f"_wrap({expr}, {bits}, {signed})"


def _literal(value: int | float) -> str:
    return f"({value!r})" if str(value).startswith("-") else repr(value)


def operand(node: CNode, t: str) -> str:
    """`node` converted to type t: a literal where it is a constant."""
    value = constant_value(node, t)
    return _literal(value) if value is not None else convert(emit(node), node[1], t)


def truth(node: CNode) -> str:
    """A Python condition true where C takes the value of `node` as true."""
    match node:
        case ("unary", _, "!", inner):
            return f"not {truth(inner)}"
        case ("bin", _, op, left, right, optype) if op in ("&&", "||"):
            return f"({truth(left)} {'and' if op == '&&' else 'or'} {truth(right)})"
        case ("bin", _, op, left, right, optype) if optype is not None and op in COMPARISONS:
            return f"({operand(left, optype)} {op} {operand(right, optype)})"
    return emit(node)


def _unary(t: str, op: str, inner: CNode) -> str:
    if op == "!":
        return f"(0 if {truth(inner)} else 1)"
    code = emit(inner)
    if op == "+":
        return code
    if t in FLOATS:
        return f"(-{code})"
    bits, signed = INT_TYPES[t]
    return f"_wrap({op}{code}, {bits}, {signed})"


def _binary(t: str, op: str, left: CNode, right: CNode, optype: str | None) -> str:
    if op in ("&&", "||") or op in COMPARISONS:
        condition = truth(("bin", t, op, left, right, optype))
        return f"(1 if {bare(condition)} else 0)"
    if op in ("<<", ">>"):
        a, b = emit(left), emit(right)
        bits, signed = INT_TYPES[t]
        if op == "<<":
            return f"_shl({bare(a)}, {bare(b)}, {bits}, {signed})"
        return f"_shr({bare(a)}, {bare(b)}, {bits})"
    assert optype is not None  # only && and || have none
    return _arith(op, operand(left, optype), operand(right, optype), optype)


def emit(node: CNode, fold: bool = True) -> str:
    """Python code computing the value of `node`, of its expression type; a constant expression
    as its value unless `fold` is false."""
    if fold and node[0] != "num":
        value = constant_value(node)
        if value is not None:
            return _literal(value)
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
            return f"({operand(a, t)} if {truth(c)} else {operand(b, t)})"
        case ("bin", t, op, left, right, optype):
            return _binary(t, op, left, right, optype)
    raise AssertionError(f"unknown fragment node {node[0]}")


def _has_variable(node: CNode) -> bool:
    return node[0] == "var" or any(_has_variable(child) for child in children(node))


@lru_cache(maxsize=4096)
def constant_value(node: CNode, as_type: str | None = None) -> int | float | None:
    """The value of a node that names no variable (converted to `as_type` if given), as the
    translation computes it; None for a node naming a variable, or of a value that is not finite."""
    if _has_variable(node):
        return None
    code = emit(node, fold=False)
    if as_type is not None:
        code = convert(code, node[1], as_type)
    try:
        value: int | float = evaluate(code)
    except ArithmeticError:  # no value: computed where it runs, and fails there (the checker refuses it in a fragment)
        return None
    return None if isinstance(value, float) and not math.isfinite(value) else value


def register_ready(node: CNode) -> bool:
    """Whether a node's value is an integer in 0..65535 whatever the registers: an assignment to a
    register stores it as it is."""
    match node:
        case ("var", _, name):
            return name != "arg"
        case ("cast", _, (bits, False), _):
            return bool(bits <= 16)
    value = constant_value(node)
    return node[1] in INT_TYPES and isinstance(value, int) and 0 <= value <= 0xFFFF


def stored_constant(target: str, value: CNode) -> int | float | None:
    """What an assignment of a constant value stores (ArithmeticError if it cannot), or None."""
    const = constant_value(value, "double" if target == "arg" else None)
    if const is None or target == "arg":
        return const
    stored: int = helpers_namespace()["_store"](const, target)
    return stored


def store(target: str, value: CNode) -> str:
    """The value of an assignment to `target` (arg or rN), converted as the assignment converts it."""
    const = stored_constant(target, value)
    if const is not None:
        return repr(const)
    if target == "arg":
        return bare(operand(value, "double"))
    if register_ready(value):
        return bare(emit(value))
    return f"_store({bare(emit(value))}, {target!r})"


def statement(target: str, op: str, value: CNode) -> str:
    """One checked assignment (`target = value`, as the parser gives it) as a Python line."""
    if op != "=":
        raise AssertionError(f"compound assignment {op} reached the translation")
    return f"{target} = {store(target, value)}"


def evaluate(code: str) -> Any:
    """The value of translated code that names no variable (a constant expression)."""
    return eval(compile(code, "<mdl fragment constant>", "eval"), helpers_namespace())
