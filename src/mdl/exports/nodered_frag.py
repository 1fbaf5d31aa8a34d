"""A read fragment (SPEC 2.4, docs/fragments.md) as JavaScript for the Node-RED flow's decoder
(mdl.exports.nodered_js): the checked, typed statements of mdl.dsl.cfrag translated as mdl.dsl.cfrag.pyemit
translates them to Python, with the same semantics. Integers (C's int, unsigned, long, ulong) are BigInt,
wrapped to their width with BigInt.asIntN / asUintN where Python's `_wrap` wraps; floats are Numbers, a
float's arithmetic rounded with Math.fround where Python's `_f32` rounds. Constant expressions are folded
by pyemit itself (`constant_value`), so a constant is the number Python computes. Where C's result is
undefined or an error (a division by zero, a conversion or register assignment out of range) the helpers
throw, and the decoder drops the poll as mdl read fails it.

Only the parser's checked trees are printed: register names r1..rN, `arg`, operators and numbers, never the
fragment's text.
"""

from __future__ import annotations

from mdl.dsl.cfrag import compile_fragment
from mdl.dsl.cfrag.pyemit import bare, constant_value, register_ready, stored_constant
from mdl.dsl.cfrag.tree import COMPARISONS, FLOATS, INT_TYPES, CNode, IntType, int_type_of
from mdl.ir import steps as ir

# the helpers the translated statements call (pyhelpers.py's, in JavaScript), after nodered_js.HELPERS
FRAGMENT_HELPERS = r"""function wrap(x, bits, signed) {
    return signed ? BigInt.asIntN(bits, x) : BigInt.asUintN(bits, x);
}
function i2f32(n) {
    let m = n < 0n ? -n : n;
    const drop = m.toString(2).length - 24;
    if (drop > 0) {
        const d = BigInt(drop);
        let q = m >> d;
        const rest = m & ((1n << d) - 1n), half = 1n << (d - 1n);
        if (rest > half || (rest === half && (q & 1n) === 1n)) q += 1n;
        m = q << d;
    }
    return n >= 0n ? Number(m) : -Number(m);
}
function f2i(x, bits, signed) {
    const low = signed ? -(1n << BigInt(bits - 1)) : 0n;
    const high = signed ? 1n << BigInt(bits - 1) : 1n << BigInt(bits);
    if (!(low - 1n < x && x < high)) {
        const type = (signed ? "" : "u") + "int" + bits + "_t";
        throw new RangeError("converts " + x + " to " + type + ", outside its range");
    }
    return BigInt(Math.trunc(x));
}
function idiv(a, b) {
    if (b === 0n) throw new RangeError("divides the integer " + a + " by zero");
    return a / b;
}
function imod(a, b) {
    if (b === 0n) throw new RangeError("divides the integer " + a + " by zero");
    return a % b;
}
function shl(a, n, bits, signed) {
    return 0n <= n && n < BigInt(bits) ? wrap(a << n, bits, signed) : 0n;
}
function shr(a, n, bits) {
    return 0n <= n && n < BigInt(bits) ? a >> n : a < 0n ? -1n : 0n;
}
function store(x, name) {
    const big = typeof x === "bigint";
    if (big ? !(x > -32769n && x < 65536n) : !(x > -32769 && x < 65536)) {
        throw new RangeError("assigns " + x + " to " + name + ", outside -32768..65535");
    }
    return BigInt.asUintN(16, big ? x : BigInt(Math.trunc(x)));
}
"""


def _literal(value: int | float) -> str:
    if isinstance(value, int):
        return f"{value}n" if value >= 0 else f"({value}n)"
    return f"({value!r})" if str(value).startswith("-") else repr(value)


def _flag(signed: bool) -> str:
    return "true" if signed else "false"


def _int_target(t: str | IntType) -> IntType:
    return t if isinstance(t, tuple) else INT_TYPES[t]


def convert(code: str, src: str, dst: str | IntType) -> str:
    """Code of expression type `src` converted to `dst` (a type name or (bits, signed)), as pyemit.convert."""
    if dst == src:
        return code
    if dst == "double":
        return code if src == "float" else f"Number({bare(code)})"
    if dst == "float":
        return f"Math.fround({bare(code)})" if src == "double" else f"i2f32({bare(code)})"
    bits, signed = _int_target(dst)
    if src in FLOATS:
        return f"f2i({bare(code)}, {bits}, {_flag(signed)})"
    sbits, ssigned = INT_TYPES[src]
    if (ssigned == signed and sbits <= bits) or (not ssigned and signed and sbits < bits):
        return code
    return f"wrap({bare(code)}, {bits}, {_flag(signed)})"


def _arith(op: str, a: str, b: str, t: str) -> str:
    if t in FLOATS:
        expr = f"({a} {op} {b})"  # IEEE 754 division is pyhelpers' _fdiv
        return f"Math.fround({bare(expr)})" if t == "float" else expr
    bits, signed = INT_TYPES[t]
    if op == "/":
        expr = f"idiv({bare(a)}, {bare(b)})"
    elif op == "%":
        expr = f"imod({bare(a)}, {bare(b)})"
    else:
        expr = f"{a} {op} {b}"
    if op in ("&", "|", "^") or (op in ("/", "%") and not signed):
        return f"({expr})"  # cannot leave the type
    return f"wrap({expr}, {bits}, {_flag(signed)})"


def operand(node: CNode, t: str) -> str:
    """`node` converted to type t: a literal where it is a constant."""
    value = constant_value(node, t)
    return _literal(value) if value is not None else convert(emit(node), node[1], t)


def truth(node: CNode) -> str:
    """A JavaScript condition true where C takes the value of `node` as true (NaN is true, as in C)."""
    match node:
        case ("unary", _, "!", inner):
            return f"!{truth(inner)}"
        case ("bin", _, op, left, right, optype) if op in ("&&", "||"):
            return f"({truth(left)} {op} {truth(right)})"
        case ("bin", _, op, left, right, optype) if optype is not None and op in COMPARISONS:
            return f"({operand(left, optype)} {op} {operand(right, optype)})"
    return f"({emit(node)} != 0)"


def _unary(t: str, op: str, inner: CNode) -> str:
    if op == "!":
        return f"({truth(inner)} ? 0n : 1n)"
    code = emit(inner)
    if op == "+":
        return code
    if t in FLOATS:
        return f"(-{code})"
    bits, signed = INT_TYPES[t]
    return f"wrap({op}{code}, {bits}, {_flag(signed)})"


def _binary(t: str, op: str, left: CNode, right: CNode, optype: str | None) -> str:
    if op in ("&&", "||") or op in COMPARISONS:
        return f"({bare(truth(('bin', t, op, left, right, optype)))} ? 1n : 0n)"
    if op in ("<<", ">>"):
        a, b = emit(left), emit(right)
        bits, signed = INT_TYPES[t]
        if op == "<<":
            return f"shl({bare(a)}, {bare(b)}, {bits}, {_flag(signed)})"
        return f"shr({bare(a)}, {bare(b)}, {bits})"
    assert optype is not None  # only && and || have none
    return _arith(op, operand(left, optype), operand(right, optype), optype)


def emit(node: CNode) -> str:
    """JavaScript computing the value of `node`, of its expression type; a constant expression as its value."""
    if node[0] != "num":
        value = constant_value(node)
        if value is not None:
            return _literal(value)
    match node:
        case ("num", t, value):
            return _literal(float(value) if t in FLOATS else int(value))
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
            return f"({truth(c)} ? {operand(a, t)} : {operand(b, t)})"
        case ("bin", t, op, left, right, optype):
            return _binary(t, op, left, right, optype)
    raise AssertionError(f"unknown fragment node {node[0]}")


def _store(target: str, value: CNode) -> str:
    """The value an assignment to `target` (arg or rN) stores, converted as pyemit.store converts it."""
    const = stored_constant(target, value)
    if const is not None:
        return _literal(float(const) if target == "arg" else int(const))
    if target == "arg":
        return bare(operand(value, "double"))
    if register_ready(value):
        return bare(emit(value))
    return f'store({bare(emit(value))}, "{target}")'


def fragment_lines(step: ir.Fragment) -> list[str]:
    """A read fragment's decoder body: r1..rN bound from `r`, `arg` 0.0, the statements, `return arg;`."""
    if not step.reading:
        raise AssertionError("a write fragment reached the flow's decoder")
    fragment = compile_fragment(step.code, step.nregs, True)
    regs = ", ".join(f"r{i + 1} = BigInt(r[{i}])" for i in range(step.nregs))
    lines = [f"let {regs};", "let arg = 0.0;"]
    for target, op, value in fragment.statements:
        if op != "=" or not (target == "arg" or (target[0] == "r" and target[1:].isdigit())):
            raise AssertionError(f"statement {target} {op} reached the translation")
        lines.append(f"{target} = {_store(target, value)};")
    return [*lines, "return arg;"]
