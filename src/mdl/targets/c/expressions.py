"""Lowered expression operations (mdl.lang.expr.lower) -> straight-line C99, and the runtime they call
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
from collections.abc import Callable
from functools import cache
from pathlib import Path

from mdl.lang.cfrag.cemit import float_literal
from mdl.lang.expr.lower import Lowered, Op
from mdl.model.layout import MAX_REGISTERS
from mdl.targets.templating import c_int64, ctext

RUNTIME_SOURCE = Path(__file__).resolve().parent / "runtime" / "expr.c"
C_TYPES = {"long": "int64_t", "double": "double", "string": "char", "bool": "bool", "list": "struct {stem}_list"}
LONG_TEXT = 20  # -9223372036854775808
DOUBLE_TEXT = 26  # Java's Double.toString, at most -1.2345678901234567E-308
MAX_LIST_BITS = 16 * MAX_REGISTERS
_REGISTER_TEXT: dict[str, Callable[[int], int]] = {
    "hexstring": lambda n: 10 * n - 1, "utf8": lambda n: 6 * n, "eui48": lambda n: 17, "ipv4addr": lambda n: 15,
    "ipv6addr": lambda n: 5 * n - 1}
_INTS = {"int16": True, "uint16": False, "int32": True, "uint32": False, "int64": True, "uint64": False}


def _double(value: float) -> str:
    return float_literal(float(value), "double") if value >= 0 else f"(-{float_literal(-float(value), 'double')})"


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
    for every one of them before the first call of caps(), result_cap or body()."""

    def __init__(self, ident: str, lowered: Lowered, list_type: str):
        self.ident = ident
        self.list_type = list_type
        self.lowered = lowered
        self.param_caps: dict[str, int] = {}
        self._body: list[str] | None = None

    @property
    def type(self) -> str:
        return self.lowered.type

    @property
    def result_cap(self) -> int:
        """The capacity of the result's text (without its NUL), for a text or list result (a list's as
        concat prints it)."""
        return self.caps()[self.lowered.result]

    def caps(self) -> dict[str, int]:
        caps = dict(self.param_caps)
        for op in self.lowered.ops:
            caps[op.tmp] = self._cap(op, caps)
        return caps

    def _cap(self, op: Op, caps: dict[str, int]) -> int:
        d = op.data
        if op.type == "list":
            return 2 + sum(len(label.encode()) + 2 for label in _labels(d.get("mapping", {}), 16 * d["count"]))
        if op.type != "string":
            return 0
        if op.kind == "lit":
            return len(str(d["value"]).encode("utf-8"))
        if op.kind == "label":
            return max(len(x.encode("utf-8")) for x in d["labels"])
        if op.kind == "enum":
            return max([len(v.encode("utf-8")) for v in d["mapping"].values()] + [21 + 10 * d["count"] - 1])
        if op.kind == "concat":
            sizes = {"long": LONG_TEXT, "double": DOUBLE_TEXT, "bool": 5}
            return sum(caps[a] if t in ("string", "list") else sizes[t]
                       for a, t in zip(op.args, d["types"], strict=True))
        return _REGISTER_TEXT[op.kind](d["count"])

    def body(self) -> list[str]:
        """The statements of `decode_<ident>(r, present, params..., out, has)`; *has false for null.
        Worked out once, on the first call: the parameters' capacities are known by then."""
        if self._body is None:
            self._body = self._statements()
        return self._body

    def _statements(self) -> list[str]:
        caps = self.caps()
        lines: list[str] = []
        for op in self.lowered.ops:
            lines += self._lines(op, caps)
        res = self.lowered.result
        t = self.lowered.type
        value = res if not res.startswith("p") or t in ("string", "list") else res
        store = {"string": f"memcpy(out, {value}, strlen({value}) + 1U);",
                 "list": f"*out = {'*' if res.startswith('p') else ''}{value};"}.get(t, f"*out = {value};")
        return lines + [f"if (!{res}_has) {{", "    *has = false;", "    return 0;", "}", store,
                        "*has = true;", "return 0;"]

    def _lines(self, op: Op, caps: dict[str, int]) -> list[str]:
        t, d = op.tmp, op.data
        a = op.args[0] if op.args else ""
        b = op.args[1] if len(op.args) > 1 else ""
        if op.kind == "lit":
            v = d["value"]
            if op.type == "string":
                decl, text = ctext(str(v), f"{t}_text", "c")
                return [*decl, f"char {t}[{caps[t] + 1}];", f"const bool {t}_has = true;",
                        f"memcpy({t}, {text}, {caps[t] + 1}U);"]
            text = ("true" if v else "false") if op.type == "bool" else c_int64(int(v)) if op.type == "long" \
                else _double(float(v))
            return [f"const {C_TYPES[op.type]} {t} = {text};", f"const bool {t}_has = true;"]
        if op.kind == "regs":
            present = " && ".join(f"present[{i}]" for i in d["index"])
            return [f"const uint16_t {t}[{d['count']}] = {{" + ", ".join(f"r[{i}]" for i in d["index"]) + "};",
                    f"const bool {t}_has = {present};"]
        if op.kind == "const":
            return [f"const uint16_t {t}[{d['count']}] = {{" + ", ".join(f"0x{w:04X}U" for w in d["words"]) + "};",
                    f"const bool {t}_has = true;"]
        if op.kind in ("swapbytes", "swapendian"):
            return [f"uint16_t {t}[{d['count']}];", f"const bool {t}_has = {a}_has;",
                    f"x_{op.kind}({a}, {t}, {d['count']}U);"]
        decl = self._declare(op, caps)
        if op.kind == "concat":
            lines = [*decl, f"{t}_has = true;", "{", "    size_t len = 0;"]
            for x, pt in zip(op.args, d["types"], strict=True):
                if pt == "string":
                    lines.append(f"    if ({x}_has) {{ x_cat({t}, &len, {x}); }}")
                elif pt == "list":
                    sel = "->" if x.startswith("p") else "."
                    lines.append(f"    if ({x}_has) {{ x_cat_list({t}, &len, {x}{sel}items, {x}{sel}count); }}")
                else:
                    lines.append(f"    if ({x}_has) {{ x_cat_{pt}({t}, &len, {x}); }}")
            return lines + ["}"]
        if op.kind == "bit":
            return [*decl, f"if ({a}_has) {{ {t} = {a}[0] != 0U; {t}_has = true; }}"]
        if op.kind == "label":
            false_text, true_text = d["labels"]
            (f_decl, f), (tr_decl, tr) = ctext(false_text, f"{t}_f", "c"), ctext(true_text, f"{t}_t", "c")
            return [*decl, *f_decl, *tr_decl, f"if ({a}_has) {{ x_copy({t}, {a} ? {tr} : {f}); {t}_has = true; }}"]
        if op.kind == "todouble":
            return [*decl, f"if ({a}_has) {{ {t} = (double){a}; {t}_has = true; }}"]
        if op.kind == "neg":
            expr = f"x_sub(0, {a})" if op.type == "long" else f"-{a}"
            return [*decl, f"if ({a}_has) {{ {t} = {expr}; {t}_has = true; }}"]
        if op.kind in ("arith", "div", "pow"):
            if op.kind == "div":
                expr = f"{a} / {b}"
            elif op.kind == "pow":
                expr = f"pow({a}, {b})"
            elif op.type == "long":
                expr = f"x_{ {'+': 'add', '-': 'sub', '*': 'mul'}[d['op']]}({a}, {b})"
            else:
                expr = f"{a} {d['op']} {b}"
            return [*decl, f"if ({a}_has && {b}_has) {{ {t} = {expr}; {t}_has = true; }}"]
        guard = f"{a}_has" + "".join(
            " && !(" + " && ".join(f"{a}[{i}] == 0x{w:04X}U" for i, w in enumerate(g)) + ")" for g in d["ni"])
        return [*decl, f"if ({guard}) {{", *("    " + line for line in self._register_function(op)), "}"]

    def _declare(self, op: Op, caps: dict[str, int]) -> list[str]:
        t = op.tmp
        if op.type == "string":
            return [f"char {t}[{caps[t] + 1}] = {{0}};", f"bool {t}_has = false;"]
        if op.type == "list":
            return [f"{self.list_type} {t};", f"bool {t}_has = false;", f"{t}.count = 0U;"]
        init = {"long": "0", "double": "0.0", "bool": "false"}[op.type]
        return [f"{C_TYPES[op.type]} {t} = {init};", f"bool {t}_has = false;"]

    @staticmethod
    def _register_function(op: Op) -> list[str]:
        t, a, d = op.tmp, op.args[0], op.data
        n = d["count"]
        if op.kind in _INTS:
            return [f"{t}_has = x_int({a}, {n}U, {'true' if _INTS[op.kind] else 'false'}, &{t});"]
        if op.kind in ("ieee754_32", "ieee754_64"):
            return [f"{t} = x_float({a}, {n}U);", f"{t}_has = true;"]
        if op.kind == "bitsetbit":
            return [f"{t} = x_bit({a}, {n}U, {d['bit']}U);", f"{t}_has = true;"]
        if op.kind == "enum":
            items = sorted(d["mapping"].items())
            keys = ", ".join(c_int64(k) for k, _ in items) or "0"
            decls, labels = _texts([v for _, v in items], t)
            return [*decls, f"static const int64_t keys[{max(len(items), 1)}] = {{{keys}}};",
                    f"static const char *const labels[{max(len(items), 1)}] = {{{labels}}};",
                    f"x_enum({a}, {n}U, keys, labels, {len(items)}U, {t});", f"{t}_has = true;"]
        if op.kind == "bitset":
            decls, labels = _texts(_labels(d["mapping"], 16 * n), t)
            return [*decls, f"static const char *const labels[{16 * n}] = {{{labels}}};",
                    f"x_bitset({a}, {n}U, labels, {t}.items, &{t}.count);", f"{t}_has = true;"]
        return [f"x_{op.kind}({a}, {n}U, {t});", f"{t}_has = true;"]


@cache
def _parts() -> dict[str, str]:
    """Runtime function (or type) name -> its source, in expr.c's order."""
    text = RUNTIME_SOURCE.read_text(encoding="utf-8")
    out: dict[str, str] = {}
    for block in text.split("\n\n")[1:]:
        m = re.search(r"^static [\w ]+?\b(x_\w+)\(", block, re.M)
        assert m is not None, block
        out[m.group(1)] = block.strip() + "\n"
    return out


def runtime(exprs: list[CExpression]) -> str:
    """The runtime parts the expressions call, and those they call in turn, in expr.c's order."""
    parts = _parts()
    code = "\n".join({line for e in exprs for line in e.body()})  # each distinct line scanned once
    wanted: set[str] = set()
    todo = [code]
    while todo:
        for name in re.findall(r"\bx_\w+\b", todo.pop()):
            if name in parts and name not in wanted:
                wanted.add(name)
                todo.append(parts[name])
    return "\n".join(src for name, src in parts.items() if name in wanted)
