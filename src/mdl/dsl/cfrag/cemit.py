"""Typed fragment trees -> C99 or C++17 functions with the semantics of docs/fragments.md.

The code is printed from the tree, never from the fragment's text (comments never reach it).
Every conversion C makes implicitly is written out; every operation C leaves undefined or
implementation-defined, every comparison and every floating + or - with a zero operand calls a
helper of chelpers.c (docs/fragments.md says why): the functions compile without a warning under
`-Wall -Wextra -Wpedantic -Wconversion -Wshadow` (gcc and clang, C99 and C++17), pass the C++
driver's clang-tidy checks and run clean under UBSan. A helper that fails records EDOM or ERANGE;
the function then returns -1 with errno set to it. In C++ the casts are static_casts and nothing
is `static` (the driver puts the functions in its anonymous namespace).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from decimal import Decimal
from fractions import Fraction
from functools import cache
from pathlib import Path
from typing import Literal, NamedTuple

from mdl.dsl.cfrag.pyemit import bare, constant_value, register_ready, stored_constant
from mdl.dsl.cfrag.tree import (
    COMPARISONS,
    FLOATS,
    INT_TYPES,
    CNode,
    IntType,
    NumNode,
    Statement,
    c_type_name,
    int_range,
    round_to_float,
)

Dialect = Literal["c", "c++"]
HELPERS_SOURCE = (Path(__file__).parent / "chelpers.c").read_text(encoding="utf-8")
INCLUDES: dict[str, tuple[str, ...]] = {"c": ("errno.h", "stdint.h"), "c++": ("cerrno", "cstdint")}
ERR = "frag_err"  # the error of a fragment's function: 0, EDOM or ERANGE
_SUFFIX = {"int": "i32", "unsigned": "u32", "long": "i64", "ulong": "u64"}
_ZERO = {"int": "0", "unsigned": "0U", "long": "INT64_C(0)", "ulong": "UINT64_C(0)", "float": "0.0F", "double": "0.0"}
_CAST = re.compile(r"\(((?:u?int(?:8|16|32|64)_t)|double|float|void)\)\(")
_HELPER_NAME = re.compile(r"\bmdl_frag_\w+(?=\()")


def dialect_code(code: str, dialect: Dialect) -> str:
    """C code as the dialect writes it: `(T)(x)` casts become static_cast<T>(x) in C++."""
    return _CAST.sub(r"static_cast<\1>(", code) if dialect == "c++" else code


@cache
def helper_sources() -> dict[str, str]:
    """Helper name -> its source (with the comment before it), in chelpers.c's order."""
    out: dict[str, str] = {}
    for block in HELPERS_SOURCE.split("\n\n")[1:]:
        m = re.search(r"^static [\w ]+?\b(mdl_frag_\w+)\(", block, re.M)
        assert m is not None, block
        out[m.group(1)] = block.strip() + "\n"
    return out


def helpers_closure(names: Iterable[str]) -> list[str]:
    """`names` and the helpers they call in turn, in chelpers.c's order (a helper after those it calls)."""
    sources = helper_sources()
    wanted: set[str] = set()
    todo = list(names)
    while todo:
        name = todo.pop()
        if name not in wanted:
            wanted.add(name)
            todo += [n for n in _HELPER_NAME.findall(sources[name]) if n != name]
    return [name for name in sources if name in wanted]


def float_literal(value: float, t: str) -> str:
    """A C literal of a finite double, or of a float's value with the shortest digits that read back as it."""
    if t == "double":
        text = repr(value)
        assert math.isfinite(value), text
        return text if any(c in text for c in ".e") else text + ".0"
    digits = next(t for t in (f"{value:.{p}g}" for p in range(1, 10)) if round_to_float(Fraction(Decimal(t))) == value)
    return float_literal(float(digits), "double") + "F"  # as repr writes those digits


def int_literal(value: int, t: str) -> str:
    """A C literal (or, below zero, a parenthesized constant expression) of an integer type."""
    if value < 0:
        low = int_range(t)[0]
        if value == low:  # the most negative value has no literal
            return f"({int_literal(value + 1, t)} - 1)"
        return f"(-{int_literal(-value, t)})"
    return {"int": str(value), "unsigned": f"{value}U", "long": f"INT64_C({value})", "ulong": f"UINT64_C({value})"}[t]


def literal(value: int | float, t: str) -> str:
    if t in FLOATS:
        text = float_literal(abs(value), t)
        return f"(-{text})" if math.copysign(1.0, value) < 0 else text
    assert isinstance(value, int)
    return int_literal(value, t)


def _stored(target: str, value: CNode) -> int | float | None:
    """What an assignment of a constant value stores; None if the value is not constant, or the
    assignment fails (then at run time, as it does in Python)."""
    try:
        return stored_constant(target, value)
    except ArithmeticError:
        return None


def _substituted(node: CNode, known: dict[str, NumNode]) -> CNode:
    """`node` with the variables whose value is a known constant replaced by it."""
    match node:
        case ("var", _, name):
            return known.get(name, node)
        case ("cast", t, target, inner):
            return ("cast", t, target, _substituted(inner, known))
        case ("unary", t, op, inner):
            return ("unary", t, op, _substituted(inner, known))
        case ("bin", t, op, left, right, optype):
            return ("bin", t, op, _substituted(left, known), _substituted(right, known), optype)
        case ("cond", t, c, a, b):
            return ("cond", t, _substituted(c, known), _substituted(a, known), _substituted(b, known))
    return node


def _fails(code: str) -> bool:
    """Whether C code calls a helper that can fail (they take the error's address)."""
    return f"&{ERR}" in code


class _Emitter:
    """C code (casts as `(T)(x)`) for typed trees: each expression has the C type of its tree type.
    What it calls and whether it can fail are read from the code it returns."""

    @staticmethod
    def call(name: str, *args: str, fallible: bool = False) -> str:
        if fallible:
            args = (*args, f"&{ERR}")
        return f"{name}({', '.join(bare(a) for a in args)})"

    def convert(self, code: str, src: str, dst: str | IntType) -> str:
        """code of expression type `src` as `dst` (an expression type or an integer cast target)."""
        if dst == src:
            return code
        if dst in FLOATS:
            return f"({dst})({bare(code)})"
        bits, signed = dst if isinstance(dst, tuple) else INT_TYPES[str(dst)]
        if src in FLOATS:
            low, high = int_range((bits, signed))
            bounds = (
                repr(math.nextafter(float(low), -math.inf) if bits == 64 and signed else float(low - 1)),
                repr(float(high + 1)),
            )
            checked = self.call("mdl_frag_f2i", self.convert(code, src, "double"), *bounds, fallible=True)
            return f"({c_type_name('int' if bits < 32 else (bits, signed))})({checked})"
        sbits, ssigned = INT_TYPES[src]
        if bits < 32:
            wide = code if src == "ulong" else f"(uint64_t)({bare(code)})"
            return self.call(f"mdl_frag_to_{'i' if signed else 'u'}{bits}", wide)
        if signed and not ((ssigned and sbits <= bits) or (not ssigned and sbits < bits)):
            wide = code if src == "ulong" else f"(uint64_t)({bare(code)})"
            return self.call(f"mdl_frag_to_i{bits}", wide)
        return f"({c_type_name((bits, signed))})({bare(code)})"

    def truth(self, node: CNode) -> str:
        """A C condition true where C takes the value of `node` as true. No comparison is written
        as an operator (compilers call `r1 > r1` or `(r1 | 3) != 0` always true or false): integers
        compare through mdl_frag_cmp_*, floats through mdl_frag_fcmp; a constant operand of && and
        || is folded away."""
        value = constant_value(node)
        if value is not None:
            return "(1 != 0)" if value else "(1 == 0)"
        match node:
            case ("unary", _, "!", inner):
                return f"!{self.truth(inner)}"
            case ("bin", _, op, left, right, _) if op in ("&&", "||"):
                return self.logical(op, left, right)
            case ("bin", _, op, left, right, optype) if op in COMPARISONS:
                assert optype is not None
                return self.compare(op, self.operand(left, optype), self.operand(right, optype), optype)
            case ("bin", t, op, _, _, _) if op in ("&", "|", "^"):  # `(r1 | 3) != 0` is "always true"
                return self.compare("!=", self.expr(node), _ZERO[t], t)
        return f"({self.expr(node)} != {_ZERO[node[1]]})"

    def compare(self, op: str, a: str, b: str, t: str) -> str:
        if t in FLOATS:
            a, b = self.convert(a, t, "double"), self.convert(b, t, "double")
            return f"(({self.call('mdl_frag_fcmp', a, b)} & {_FCMP[op]}) != 0)"
        return f"({self.call('mdl_frag_cmp_' + _SUFFIX[t], a, b)} {op} 0)"

    def logical(self, op: str, left: CNode, right: CNode) -> str:
        """`left op right` for && and ||, where at most one operand is a constant."""
        decisive = op == "||"  # the truth value that decides without the other operand
        first, second = constant_value(left), constant_value(right)
        if first is not None:
            return self.truth(left) if bool(first) == decisive else self.truth(right)
        if second is not None and bool(second) != decisive:
            return self.truth(left)
        code = self.truth(left)
        if second is not None:  # decided by the constant once the left operand is evaluated
            return f"({code} {op} {self.truth(right)})" if _fails(code) else self.truth(right)
        other = self.truth(right)
        return code if other == code else f"({code} {op} {other})"  # `a && a` is a (and a linter's finding)

    def operand(self, node: CNode, t: str) -> str:
        """`node` as a value of type t: a literal of t where it is a constant."""
        value = constant_value(node, t)
        if value is not None:
            return literal(value, t)
        return self.convert(self.expr(node), node[1], t)

    def expr(self, node: CNode) -> str:
        """C code computing `node`, of the C type of its expression type."""
        value = constant_value(node)
        if value is not None:
            return literal(value, node[1])
        match node:
            case ("var", _, name):
                return name
            case ("cast", _, target, inner):
                return self.convert(self.expr(inner), inner[1], target)
            case ("cond", t, c, a, b):
                return self.conditional(t, c, a, b)
            case ("unary", t, op, inner):
                return self.unary(t, op, inner)
            case ("bin", t, op, left, right, optype):
                return self.binary(node, t, op, left, right, optype)
        raise AssertionError(f"unknown fragment node {node[0]}")

    def conditional(self, t: str, c: CNode, a: CNode, b: CNode) -> str:
        chosen = constant_value(c)
        if chosen is not None:  # C evaluates the chosen operand only
            return self.operand(a if chosen else b, t)
        condition, yes, no = self.truth(c), self.operand(a, t), self.operand(b, t)
        if yes != no:
            return f"({condition} ? {yes} : {no})"
        return f"((void)({bare(condition)}), {yes})" if _fails(condition) else yes  # (linters flag `c ? a : a`)

    def unary(self, t: str, op: str, inner: CNode) -> str:
        if op == "!" or op == "+":
            return f"({self.truth(inner)} ? 0 : 1)" if op == "!" else self.expr(inner)
        code = self.expr(inner)
        if t in FLOATS:
            return f"(-{code})"
        return self.call(f"mdl_frag_{'not' if op == '~' else 'neg'}_{_SUFFIX[t]}", code)

    def binary(self, node: CNode, t: str, op: str, left: CNode, right: CNode, optype: str | None) -> str:
        if op in COMPARISONS or op in ("&&", "||"):
            return f"({self.truth(node)} ? 1 : 0)"
        if op in ("<<", ">>"):
            return self.shift(t, op, left, right)
        assert optype is not None
        a, b = self.operand(left, optype), self.operand(right, optype)
        if a == b and op in ("&", "|") or a == b and op == "^" and not _fails(a):  # (a linter's finding)
            return a if op != "^" else literal(0, optype)
        if optype in FLOATS and op in ("+", "-") and 0 in (constant_value(left, optype), constant_value(right, optype)):
            # gcc folds `0.0 - (double)i` to `-(double)i`, which is -0.0 where i is 0
            return self.call(f"mdl_frag_{'add' if op == '+' else 'sub'}_{'f32' if optype == 'float' else 'f64'}", a, b)
        if optype in FLOATS or op in ("&", "|", "^"):
            return f"({a} {op} {b})"
        name = {"+": "add", "-": "sub", "*": "mul", "/": "div", "%": "mod"}[op]
        return self.call(f"mdl_frag_{name}_{_SUFFIX[optype]}", a, b, fallible=op in ("/", "%"))

    def shift(self, t: str, op: str, left: CNode, right: CNode) -> str:
        a, count = self.expr(left), constant_value(right)
        if op == ">>" and t in ("unsigned", "ulong") and isinstance(count, int) and 0 <= count < INT_TYPES[t][0]:
            return f"({a} >> {count})"
        n = self.convert(self.expr(right), right[1], "ulong") if count is None else f"{count}U"
        return self.call(f"mdl_frag_{'shl' if op == '<<' else 'shr'}_{_SUFFIX[t]}", a, n)

    def store(self, target: str, value: CNode) -> str:
        """The value an assignment to `target` stores (a double for arg, an int32_t 0..65535 for rN)."""
        const = _stored(target, value)
        if const is not None:
            return literal(const, "double" if target == "arg" else "int")
        if target == "arg":
            return self.operand(value, "double")
        code = self.expr(value)
        if register_ready(value):
            return code
        t = value[1]
        if t in FLOATS:
            return self.call("mdl_frag_store_f", self.convert(code, t, "double"), fallible=True)
        return self.call(f"mdl_frag_store_{'i' if t in ('int', 'long') else 'u'}", code, fallible=True)


# the bits of mdl_frag_fcmp's result (1 less, 2 equal, 4 greater, 8 unordered) where a comparison holds
_FCMP = {"<": "1", "==": "2", ">": "4", "<=": "3", ">=": "6", "!=": "13"}


_NAME = re.compile(r"\b(arg|r[0-9]+)\b")


class _Line(NamedTuple):
    target: str
    code: str  # the value stored
    reads: frozenset[str]  # the variables the code reads
    fails: bool  # whether the code can fail


class CFragment:
    """A checked fragment's C function, in one dialect.

    Reading: `int NAME(const uint16_t *r, double *out)`: r[0..n-1] are r1..rn; 0 and *out = arg,
    or -1 with errno EDOM or ERANGE (and *out untouched). Writing: `int NAME(double value,
    uint16_t *r)`: arg is value; 0 and r[0..n-1] = r1..rn, or -1 with errno EDOM or ERANGE (and r
    untouched). Variables are declared where they get their first value, and an assignment whose
    value nothing reads is left out, or kept as `(void)(value)` where the value can fail: the
    compilers' and clang-tidy's dead-store and unused-variable checks find nothing."""

    def __init__(self, statements: Iterable[Statement], nregs: int, reading: bool, dialect: Dialect):
        self.nregs, self.reading, self.dialect = nregs, reading, dialect
        emitter = _Emitter()
        self._lines: list[_Line] = []
        # registers holding a known constant (0 before a write fragment, then constants assigned) are
        # that constant: a compiler's or clang's analysis finds no test whose outcome it knows
        known: dict[str, NumNode] = {} if reading else {f"r{i}": ("num", "int", 0) for i in range(1, nregs + 1)}
        for target, op, value in statements:
            if op != "=":
                raise AssertionError(f"compound assignment {op} reached the C emitter")
            value = _substituted(value, known)
            code = bare(emitter.store(target, value))
            self._lines.append(_Line(target, code, frozenset(_NAME.findall(code)), _fails(code)))
            const = _stored(target, value)
            if const is None or target == "arg":
                known.pop(target, None)
            else:
                known[target] = ("num", "int", int(const))
        self.helpers = frozenset(name for line in self._statements() for name in _HELPER_NAME.findall(line))

    def _liveness(self) -> tuple[set[str], list[str]]:
        """(the variables whose first value is read, what each statement becomes): "assign" where
        something reads the value it assigns, "void" where nothing does but it can fail (its value is
        computed for its errors), "drop" otherwise."""
        names = ["arg"] + [f"r{i}" for i in range(1, self.nregs + 1)]
        live = {name for name in names if (name == "arg") == self.reading}
        kinds: list[str] = []
        for line in reversed(self._lines):
            if line.code == line.target:  # `r1 = r1;`: nothing to do (and clang warns of a self-assignment)
                kinds.append("drop")
                continue
            kind = "assign" if line.target in live else "void" if line.fails else "drop"
            if kind == "assign":
                live.discard(line.target)
            if kind != "drop":
                live |= line.reads
            kinds.append(kind)
        return live, kinds[::-1]

    def _initial(self, name: str) -> str:
        if name == "arg":
            return "0.0" if self.reading else "value"
        return f"r[{int(name[1:]) - 1}]" if self.reading else "0"

    def _statements(self) -> list[str]:
        """Declarations, assignments and error checks: each variable declared where it gets the first
        value something reads (const where nothing assigns it again)."""
        names = ["arg"] + [f"r{i}" for i in range(1, self.nregs + 1)]
        initial, kinds = self._liveness()
        last = {line.target: i for i, line in enumerate(self._lines) if kinds[i] == "assign"}  # its last assignment
        assigned = set(last)
        out = [f"int {ERR} = 0;"] if any(line.fails for line in self._lines) else []
        out += [self._declaration(name, self._initial(name), name in assigned) for name in names if name in initial]
        if not self.reading and "arg" not in initial:
            out.append("(void)(value);")
        if self.reading and initial <= {"arg"}:
            out.append("(void)(r);")
        declared = set(initial)
        for i, (line, kind) in enumerate(zip(self._lines, kinds, strict=True)):
            if kind == "void":
                out.append(f"(void)({line.code});")
            elif kind == "assign" and line.target in declared:
                out.append(f"{line.target} = {line.code};")
            elif kind == "assign":
                out.append(self._declaration(line.target, line.code, last[line.target] > i))
                declared.add(line.target)
            if line.fails:
                out += [f"if ({ERR} != 0) {{", f"    errno = {ERR};", "    return -1;", "}"]
        return out + self._results(declared)

    def _declaration(self, name: str, code: str, assigned_again: bool) -> str:
        """`name` declared with the value `code`: auto where C++ would spell its type twice (a cast)."""
        ctype = _CTYPE[name[0]]
        cast = f"({ctype})("
        if self.dialect == "c++" and code.startswith(cast) and bare(code[len(cast) - 1 :]) != code[len(cast) - 1 :]:
            ctype = "auto"
        return f"{'' if assigned_again else 'const '}{ctype} {name} = {code};"

    def _results(self, declared: set[str]) -> list[str]:
        if self.reading:
            return [f"*out = {'arg' if 'arg' in declared else '0.0'};", "return 0;"]
        return [
            f"r[{i - 1}] = {f'(uint16_t)(r{i})' if f'r{i}' in declared else '0U'};" for i in range(1, self.nregs + 1)
        ] + ["return 0;"]

    def body(self) -> list[str]:
        """The statements of the function, in the dialect."""
        return [dialect_code(line, self.dialect) for line in self._statements()]

    def function(self, name: str) -> str:
        """The whole function definition, named `name`."""
        params = "const uint16_t *r, double *out" if self.reading else "double value, uint16_t *r"
        head = f"{'static ' if self.dialect == 'c' else ''}int {name}({params}) {{"
        return "\n".join([head, *("    " + line for line in self.body()), "}"]) + "\n"


_CTYPE = {"a": "double", "r": "int32_t"}  # of arg, of rN


def helpers_source(fragments: Iterable[CFragment], dialect: Dialect) -> str:
    """The helpers the fragments' functions call, in the dialect, to put before them."""
    names = helpers_closure(name for f in fragments for name in f.helpers)
    sources = helper_sources()
    text = "\n".join(sources[name] for name in names)
    if dialect == "c++":
        text = re.sub(r"^static ", "", text, flags=re.M)
    return dialect_code(text, dialect)
