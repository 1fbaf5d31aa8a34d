"""Lowered expression operations (mdl.dsl.expr.lower) -> straight-line C99, and the runtime they call
(runtime/expr.c: `runtime(exprs)` copies the parts the driver uses).

Every value is a pair: the value `tN` (or parameter `pN`) and its presence `tN_has` (`pN_has`); an
operation is done only where its operands are there, as std::optional does in the C++ target.
Nothing is allocated: register values are `uint16_t[count]`, text a `char[cap + 1]` whose capacity is
computed here from the operations (utf8 of n registers: 6n bytes, each byte becoming U+FFFD at
worst; hexstring 10n - 1; concat: the sum of its parts), and a list (bitset) a `struct mdl_list`:
`count` pointers to string literals, one per set bit (the label of every bit, named or `Bit N`, is
known when the driver is generated).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Hashable, Mapping
from functools import cache
from pathlib import Path

from mdl.dsl.expr.lower import Lowered
from mdl.dsl.expr.ops import Op, OpKind, printer
from mdl.model.layout import MAX_REGISTERS
from mdl.targets.templating import RuntimePart, c_int64, ctext, double_literal, pick

RUNTIME_SOURCE = Path(__file__).resolve().parent / "runtime" / "expr.c"
_NAME = re.compile(r"\bx_\w+\b")
C_TYPES = {"long": "int64_t", "double": "double", "string": "char", "bool": "bool", "list": "struct {stem}_list"}
LONG_TEXT = 20  # -9223372036854775808
DOUBLE_TEXT = 26  # Java's Double.toString, at most -1.2345678901234567E-308
MAX_LIST_BITS = 16 * MAX_REGISTERS
_REGISTER_TEXT: dict[OpKind, Callable[[int], int]] = {
    OpKind.HEXSTRING: lambda n: 10 * n - 1,
    OpKind.UTF8: lambda n: 6 * n,
    OpKind.EUI48: lambda n: 17,
    OpKind.IPV4ADDR: lambda n: 15,
    OpKind.IPV6ADDR: lambda n: 5 * n - 1,
}


def _texts(labels: list[str], tmp: str) -> tuple[list[str], str]:
    """The declarations the labels need (those too long for a C99 string literal, templating.ctext)
    and the labels as an initialiser list ("0" for none)."""
    decls: list[str] = []
    items = []
    for i, label in enumerate(labels):
        decl, text = ctext(label, f"{tmp}_label{i}", "c")
        decls += decl
        items.append(text)
    return decls, ", ".join(items) or "0"


def _labels(mapping: dict[int, str], nbits: int) -> list[str]:
    return [mapping.get(bit, f"Bit {bit}") for bit in range(nbits)]


class CExpression:
    """A function's expression as the body of its C decoder. `param_caps`: the text capacity of each
    text or list parameter (pN; a list's as concat prints it), given by the functions it names: set
    for every one of them before the first call of caps(), result_cap or body(). `printed`, shared by
    a device's expressions, keeps the statements of each shape (Lowered.shape: equal shapes have
    equal operations) for the same `wide`, parameter capacities and list type: printed once."""

    def __init__(self, ident: str, lowered: Lowered, list_type: str, printed: dict[Hashable, list[str]] | None = None):
        self.ident = ident
        self.list_type = list_type
        self.lowered = lowered
        self.param_caps: dict[str, int] = {}
        self._body: list[str] | None = None
        self._printed = printed

    @property
    def type(self) -> str:
        return self.lowered.type

    @property
    def result_cap(self) -> int:
        """The capacity of the result's text (without its NUL), for a text or list result (a list's as
        concat prints it)."""
        return self.caps()[self.lowered.result]

    def caps(self) -> dict[str, int]:
        """The capacity of each text or list value: parameters and temporaries (the statements
        ask no other's)."""
        caps = dict(self.param_caps)
        for op in self.lowered.ops:
            if op.type == "string" or op.type == "list":
                caps[op.tmp] = self._cap(op, caps)
        return caps

    def _cap(self, op: Op, caps: dict[str, int]) -> int:
        """The capacity of the value of a text or list operation."""
        d = op.data
        if op.type == "list":
            return 2 + sum(len(label.encode()) + 2 for label in _labels(d.get("mapping", {}), 16 * d["count"]))
        if op.kind is OpKind.LIT:
            return len(str(d["value"]).encode("utf-8"))
        if op.kind is OpKind.LABEL:
            return max(len(x.encode("utf-8")) for x in d["labels"])
        if op.kind is OpKind.ENUM:
            return max([len(v.encode("utf-8")) for v in d["mapping"].values()] + [21 + 10 * d["count"] - 1])
        if op.kind is OpKind.CONCAT:
            sizes = {"long": LONG_TEXT, "double": DOUBLE_TEXT, "bool": 5}
            return sum(
                caps[a] if t in ("string", "list") else sizes[t] for a, t in zip(op.args, d["types"], strict=True)
            )
        return _REGISTER_TEXT[op.kind](d["count"])

    def body(self) -> list[str]:
        """The statements of `decode_<ident>(r, present, params..., out, has)`; *has false for null.
        Worked out once, on the first call: the parameters' capacities are known by then."""
        if self._body is None:
            shape = self.lowered.shape
            if shape is None or self._printed is None:
                self._body = self._statements()
            else:
                key = (shape, self.lowered.wide, tuple(sorted(self.param_caps.items())), self.list_type)
                found = self._printed.get(key)
                if found is None:
                    found = self._printed[key] = self._statements()
                self._body = found
        return self._body

    def _statements(self) -> list[str]:
        caps = self.caps()
        lines: list[str] = []
        for op in self.lowered.ops:
            lines += _PRINT_BY_KIND[id(op.kind)](self, op, caps)
        res = self.lowered.result
        t = self.lowered.type
        if t == "string":
            store = f"memcpy(out, {res}, strlen({res}) + 1U);"
        elif t == "list":
            store = f"*out = {'*' if res.startswith('p') else ''}{res};"
        else:
            store = f"*out = {res};"
        lines += [f"if (!{res}_has) {{", "    *has = false;", "    return 0;", "}", store, "*has = true;", "return 0;"]
        return lines

    def declare(self, op: Op, caps: dict[str, int]) -> list[str]:
        """`tN` and `tN_has` (false) declared, for an operation that sets them where its operands are there."""
        t = op.tmp
        if op.type == "string":
            return [f"char {t}[{caps[t] + 1}] = {{0}};", f"bool {t}_has = false;"]
        if op.type == "list":
            return [f"{self.list_type} {t};", f"bool {t}_has = false;", f"{t}.count = 0U;"]
        return [f"{C_TYPES[op.type]} {t} = {_INIT[op.type]};", f"bool {t}_has = false;"]


_INIT = {"long": "0", "double": "0.0", "bool": "false"}  # a scalar temporary's value until it has one


Print = Callable[[CExpression, Op, dict[str, int]], list[str]]


def _lit(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
    t, v = op.tmp, op.data["value"]
    if op.type == "string":
        decl, text = ctext(str(v), f"{t}_text", "c")
        return [
            *decl,
            f"char {t}[{caps[t] + 1}];",
            f"const bool {t}_has = true;",
            f"memcpy({t}, {text}, {caps[t] + 1}U);",
        ]
    text = (
        ("true" if v else "false")
        if op.type == "bool"
        else c_int64(int(v))
        if op.type == "long"
        else double_literal(float(v), parenthesized=True)
    )
    return [f"const {C_TYPES[op.type]} {t} = {text};", f"const bool {t}_has = true;"]


def _regs(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
    t, d = op.tmp, op.data
    present = " && ".join([f"present[{i}]" for i in d["index"]])
    return [
        f"const uint16_t {t}[{d['count']}] = {{" + ", ".join([f"r[{i}]" for i in d["index"]]) + "};",
        f"const bool {t}_has = {present};",
    ]


def _const(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
    t, d = op.tmp, op.data
    return [
        f"const uint16_t {t}[{d['count']}] = {{" + ", ".join(f"0x{w:04X}U" for w in d["words"]) + "};",
        f"const bool {t}_has = true;",
    ]


def _swap(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
    t, a, n = op.tmp, op.args[0], op.data["count"]
    return [f"uint16_t {t}[{n}];", f"const bool {t}_has = {a}_has;", f"x_{op.kind.value}({a}, {t}, {n}U);"]


def _concat(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
    t = op.tmp
    lines = [*e.declare(op, caps), f"{t}_has = true;", "{", "    size_t len = 0;"]
    for x, pt in zip(op.args, op.data["types"], strict=True):
        if pt == "string":
            lines.append(f"    if ({x}_has) {{ x_cat({t}, &len, {x}); }}")
        elif pt == "list":
            sel = "->" if x.startswith("p") else "."
            lines.append(f"    if ({x}_has) {{ x_cat_list({t}, &len, {x}{sel}items, {x}{sel}count); }}")
        else:
            lines.append(f"    if ({x}_has) {{ x_cat_{pt}({t}, &len, {x}); }}")
    return lines + ["}"]


def _label(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
    t, a = op.tmp, op.args[0]
    false_text, true_text = op.data["labels"]
    (f_decl, f), (tr_decl, tr) = ctext(false_text, f"{t}_f", "c"), ctext(true_text, f"{t}_t", "c")
    return [
        *e.declare(op, caps),
        *f_decl,
        *tr_decl,
        f"if ({a}_has) {{ x_copy({t}, {a} ? {tr} : {f}); {t}_has = true; }}",
    ]


def _unary(value: Callable[[Op, str], str]) -> Print:
    """An operation of one argument `a`: `value(op, a)` where `a` is there."""

    def lines(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
        t, a = op.tmp, op.args[0]
        return [*e.declare(op, caps), f"if ({a}_has) {{ {t} = {value(op, a)}; {t}_has = true; }}"]

    return lines


def _binary(value: Callable[[Op, str, str], str]) -> Print:
    """An operation of two arguments: `value(op, a, b)` where both are there."""

    def lines(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
        t, (a, b) = op.tmp, op.args
        return [*e.declare(op, caps), f"if ({a}_has && {b}_has) {{ {t} = {value(op, a, b)}; {t}_has = true; }}"]

    return lines


def _arith(op: Op, a: str, b: str) -> str:
    if op.type == "long":
        return f"x_{ {'+': 'add', '-': 'sub', '*': 'mul'}[op.data['op']] }({a}, {b})"
    return f"{a} {op.data['op']} {b}"


def _register(body: Callable[[Op, str, str, int], list[str]]) -> Print:
    """A register function: `body(op, t, a, count)` where its registers are there and none of its "not
    implemented" values; it sets `t` (and `t_has`)."""

    def lines(e: CExpression, op: Op, caps: dict[str, int]) -> list[str]:
        t, a, d = op.tmp, op.args[0], op.data
        guard = f"{a}_has" + "".join(
            [" && !(" + " && ".join([f"{a}[{i}] == 0x{w:04X}U" for i, w in enumerate(g)]) + ")" for g in d["ni"]]
        )
        return [*e.declare(op, caps), f"if ({guard}) {{", *["    " + line for line in body(op, t, a, d["count"])], "}"]

    return lines


def _int(signed: bool) -> Print:
    return _register(lambda op, t, a, n: [f"{t}_has = x_int({a}, {n}U, {'true' if signed else 'false'}, &{t});"])


def _call(op: Op, t: str, a: str, n: int) -> list[str]:
    """x_<kind>(registers, count, out): a text."""
    return [f"x_{op.kind.value}({a}, {n}U, {t});", f"{t}_has = true;"]


def _enum(op: Op, t: str, a: str, n: int) -> list[str]:
    items = sorted(op.data["mapping"].items())
    keys = ", ".join(c_int64(k) for k, _ in items) or "0"
    decls, labels = _texts([v for _, v in items], t)
    return [
        *decls,
        f"static const int64_t keys[{max(len(items), 1)}] = {{{keys}}};",
        f"static const char *const labels[{max(len(items), 1)}] = {{{labels}}};",
        f"x_enum({a}, {n}U, keys, labels, {len(items)}U, {t});",
        f"{t}_has = true;",
    ]


def _bitset(op: Op, t: str, a: str, n: int) -> list[str]:
    decls, labels = _texts(_labels(op.data["mapping"], 16 * n), t)
    return [
        *decls,
        f"static const char *const labels[{16 * n}] = {{{labels}}};",
        f"x_bitset({a}, {n}U, labels, {t}.items, &{t}.count);",
        f"{t}_has = true;",
    ]


# the statements of each operation kind (mdl.dsl.expr.ops says what each computes)
PRINTER: Mapping[OpKind, Print] = printer(
    {
        OpKind.LIT: _lit,
        OpKind.REGS: _regs,
        OpKind.CONST: _const,
        OpKind.SWAPBYTES: _swap,
        OpKind.SWAPENDIAN: _swap,
        OpKind.CONCAT: _concat,
        OpKind.BIT: _unary(lambda op, a: f"{a}[0] != 0U"),
        OpKind.LABEL: _label,
        OpKind.TODOUBLE: _unary(lambda op, a: f"(double){a}"),
        OpKind.NEG: _unary(lambda op, a: f"x_sub(0, {a})" if op.type == "long" else f"-{a}"),
        OpKind.ARITH: _binary(_arith),
        OpKind.DIV: _binary(lambda op, a, b: f"{a} / {b}"),
        OpKind.POW: _binary(lambda op, a, b: f"pow({a}, {b})"),
        OpKind.INT16: _int(True),
        OpKind.UINT16: _int(False),
        OpKind.INT32: _int(True),
        OpKind.UINT32: _int(False),
        OpKind.INT64: _int(True),
        OpKind.UINT64: _int(False),
        OpKind.IEEE754_32: _register(lambda op, t, a, n: [f"{t} = x_float({a}, {n}U);", f"{t}_has = true;"]),
        OpKind.IEEE754_64: _register(lambda op, t, a, n: [f"{t} = x_float({a}, {n}U);", f"{t}_has = true;"]),
        OpKind.UTF8: _register(_call),
        OpKind.HEXSTRING: _register(_call),
        OpKind.EUI48: _register(_call),
        OpKind.IPV4ADDR: _register(_call),
        OpKind.IPV6ADDR: _register(_call),
        OpKind.ENUM: _register(_enum),
        OpKind.BITSET: _register(_bitset),
        OpKind.BITSETBIT: _register(
            lambda op, t, a, n: [f"{t} = x_bit({a}, {n}U, {op.data['bit']}U);", f"{t}_has = true;"]
        ),
    }
)


# PRINTER by the identity of each kind (one per kind: an enum's members are singletons), looked up
# for every operation of every expression without the enum's hash, a Python method
_PRINT_BY_KIND = {id(kind): print_ for kind, print_ in PRINTER.items()}


@cache
def _parts() -> list[RuntimePart]:
    """The runtime's functions (and types), in expr.c's order: each block between blank lines."""
    text = RUNTIME_SOURCE.read_text(encoding="utf-8")
    out = []
    for block in text.split("\n\n")[1:]:
        m = re.search(r"^static [\w ]+?\b(x_\w+)\(", block, re.M)
        assert m is not None, block
        out.append(RuntimePart((m.group(1),), block.strip() + "\n", frozenset(_NAME.findall(block))))
    return out


def runtime(exprs: list[CExpression]) -> str:
    """The runtime parts the expressions call, and those they call in turn, in expr.c's order
    (templating.pick)."""
    # each distinct line that calls the runtime (names x_<name>) scanned once, and each body once
    # (expressions of one shape share theirs)
    bodies = {id(body): body for body in (e.body() for e in exprs)}
    code = "\n".join({line for body in bodies.values() for line in body if "x_" in line})
    return "\n".join(part.source for part in pick(_parts(), _NAME.findall(code)))
