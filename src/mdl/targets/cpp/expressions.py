"""Lowered expression operations -> straight-line C++17 over std::optional, and the runtime those
operations call: `helpers(code)` picks the parts of the runtime the generated code uses, so a
driver holds no unused function.

Register values are `Regs<N>` (a std::array): every size is known when the driver is generated, so
reading and converting registers allocates nothing; only text and list results own heap memory.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from mdl.dsl.expr.lower import Lowered
from mdl.dsl.expr.ops import Op, OpKind, printer
from mdl.targets.templating import RuntimePart, c_int64, ctext, double_literal, pick

CPP_TYPES = {
    "long": "int64_t",
    "double": "double",
    "string": "std::string",
    "bool": "bool",
    "list": "std::vector<std::string>",
}


def cpp_type(t: str) -> str:
    return CPP_TYPES[t]


def _regs_type(op: Op) -> str:
    return f"Regs<{op.data['count']}>"


def _regs_literal(op: Op, words: list[int]) -> str:
    return f"{_regs_type(op)}{{" + ", ".join(f"0x{w:04X}U" for w in words) + "}"


def _literal(op: Op, decls: list[str]) -> str:
    v = op.data["value"]
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f"std::string({_text_of(v, f'{op.tmp}_text', decls)}, {len(v.encode('utf-8'))})"
    return c_int64(int(v)) if op.type == "long" else double_literal(float(v))


def _text_of(text: str, name: str, decls: list[str]) -> str:
    """`text` as the code uses it: a string literal, or (too long for one, templating.ctext) the name
    of a char array whose declaration is added to decls."""
    decl, expr = ctext(text, name, "c++")
    decls += decl
    return expr


def _long(a: str, wide: set[str]) -> str:
    """The value of long `a`: a plain UINT64 parameter is its 64 bits as an int64_t (an expression
    sees every integer as a long, docs/expressions.md), any other as it is."""
    return f"x_wrap<int64_t>(*{a})" if a in wide else f"*{a}"


def _text(a: str, t: str, wide: set[str]) -> str:
    """`a` as concat prints it (a plain UINT64 parameter as the long it is)."""
    if a in wide:
        return f"x_text_long({a} ? std::optional<int64_t>({_long(a, wide)}) : std::nullopt)"
    return f"x_text_{t}({a})"


def _guard(op: Op, types: dict[str, str]) -> str:
    """The argument is there and is none of the function's "not implemented" values."""
    a = op.args[0]
    arg_type = types[a][len("std::optional<") : -1]
    return a + "".join(f" && *{a} != {arg_type}{{" + ", ".join(f"0x{w:04X}U" for w in g) + "}" for g in op.data["ni"])


def _enum(op: Op, decls: list[str]) -> str:
    table = ", ".join(
        f"{{{c_int64(k)}, {_text_of(v, f'{op.tmp}_label{i}', decls)}}}"
        for i, (k, v) in enumerate(sorted(op.data["mapping"].items()))
    )
    return f"x_enum(*{op.args[0]}, {{{table}}})"


def _bitset(op: Op, decls: list[str]) -> str:
    """A bit the registers do not have is never set: its label is left out."""
    bits = 16 * op.data["count"]
    table = ", ".join(
        f"{{{k}, {_text_of(v, f'{op.tmp}_label{k}', decls)}}}"
        for k, v in sorted(op.data["mapping"].items())
        if 0 <= k < bits
    )
    return f"x_bitset(*{op.args[0]}, {{{table}}})"


@dataclass
class _Printer:
    """The statements of one expression's operations: `types` each temporary's C++ type so far."""

    result: str  # the temporary returned (moved out, not copied: not const)
    wide: set[str]  # the parameters naming a plain UINT64 (_long)
    types: dict[str, str] = field(default_factory=dict)

    def statements(self, op: Op) -> list[str]:
        t = f"std::optional<{_regs_type(op) if op.type == 'regs' else cpp_type(op.type)}>"
        self.types[op.tmp] = t
        return PRINTER[op.kind](self, op, t)

    def set(self, op: Op, t: str, value: str, decls: list[str] | None = None) -> list[str]:
        """`tmp` initialised to `value` (after the declarations of the texts it names)."""
        const = "" if op.tmp == self.result else "const "
        return [*(decls or []), f"{const}{t} {op.tmp} = {value};"]

    @staticmethod
    def when(op: Op, t: str, condition: str, value: str, decls: list[str] | None = None) -> list[str]:
        """`tmp` set to `value` where `condition` holds, else std::nullopt."""
        return [*(decls or []), f"{t} {op.tmp};", f"if ({condition}) {{ {op.tmp} = {value}; }}"]


Print = Callable[[_Printer, Op, str], list[str]]


def _lit(p: _Printer, op: Op, t: str) -> list[str]:
    decls: list[str] = []
    value = _literal(op, decls)
    return p.set(op, t, value, decls)


def _regs(p: _Printer, op: Op, t: str) -> list[str]:
    index = ", ".join(str(i) for i in op.data["index"])
    regs = ", ".join(f"r[{i}]" for i in op.data["index"])
    return p.set(op, t, f"x_all(present, {{{index}}}) ? {t}({_regs_type(op)}{{{regs}}}) : std::nullopt")


def _concat(p: _Printer, op: Op, t: str) -> list[str]:
    parts = [_text(x, pt, p.wide) for x, pt in zip(op.args, op.data["types"], strict=True)]
    return p.set(op, t, " + ".join(["std::string()", *parts]))


def _label(p: _Printer, op: Op, t: str) -> list[str]:
    false_text, true_text = op.data["labels"]
    decls: list[str] = []
    f, tr = _text_of(false_text, f"{op.tmp}_f", decls), _text_of(true_text, f"{op.tmp}_t", decls)
    a = op.args[0]
    return p.when(op, t, a, f"std::string(*{a} ? {tr} : {f})", decls)


def _unary(value: Callable[[_Printer, Op, str], str]) -> Print:
    """An operation of one argument `a`: `value(printer, op, a)` where `a` is there."""
    return lambda p, op, t: p.when(op, t, op.args[0], value(p, op, op.args[0]))


def _binary(value: Callable[[_Printer, Op, str, str], str]) -> Print:
    """An operation of two arguments: `value(printer, op, a, b)` where both are there."""
    return lambda p, op, t: p.when(op, t, f"{op.args[0]} && {op.args[1]}", value(p, op, *op.args))


def _arith(p: _Printer, op: Op, a: str, b: str) -> str:
    if op.type == "long":
        name = {"+": "add", "-": "sub", "*": "mul"}[op.data["op"]]
        return f"x_{name}({_long(a, p.wide)}, {_long(b, p.wide)})"
    return f"*{a} {op.data['op']} *{b}"


def _register(call: Callable[[Op, list[str]], str]) -> Print:
    """A register function: `call(op, decls)` where its registers are there and none of its "not
    implemented" values."""

    def statements(p: _Printer, op: Op, t: str) -> list[str]:
        decls: list[str] = []
        value = call(op, decls)
        return p.when(op, t, _guard(op, p.types), value, decls)

    return statements


def _convert(pattern: str) -> Print:
    return _register(lambda op, decls: pattern.format(a=op.args[0]))


# the statements of each operation kind (mdl.dsl.expr.ops says what each computes)
PRINTER: Mapping[OpKind, Print] = printer(
    {
        OpKind.LIT: _lit,
        OpKind.REGS: _regs,
        OpKind.CONST: lambda p, op, t: p.set(op, t, _regs_literal(op, op.data["words"])),
        OpKind.SWAPBYTES: _unary(lambda p, op, a: f"x_swapbytes(*{a})"),
        OpKind.SWAPENDIAN: _unary(lambda p, op, a: f"x_swapendian(*{a})"),
        OpKind.CONCAT: _concat,
        OpKind.BIT: _unary(lambda p, op, a: f"(*{a})[0] != 0"),
        OpKind.LABEL: _label,
        OpKind.TODOUBLE: _unary(lambda p, op, a: f"static_cast<double>({_long(a, p.wide)})"),
        OpKind.NEG: _unary(
            lambda p, op, a: f"x_sub<int64_t>(0, {_long(a, p.wide)})" if op.type == "long" else f"-*{a}"
        ),
        OpKind.ARITH: _binary(_arith),
        OpKind.DIV: _binary(lambda p, op, a, b: f"*{a} / *{b}"),
        OpKind.POW: _binary(lambda p, op, a, b: f"std::pow(*{a}, *{b})"),
        OpKind.INT16: _convert("x_int(*{a}, true)"),
        OpKind.UINT16: _convert("x_int(*{a}, false)"),
        OpKind.INT32: _convert("x_int(*{a}, true)"),
        OpKind.UINT32: _convert("x_int(*{a}, false)"),
        OpKind.INT64: _convert("x_int(*{a}, true)"),
        OpKind.UINT64: _convert("x_int(*{a}, false)"),
        OpKind.IEEE754_32: _convert("x_float(*{a})"),
        OpKind.IEEE754_64: _convert("x_float(*{a})"),
        OpKind.UTF8: _convert("x_utf8(*{a})"),
        OpKind.HEXSTRING: _convert("x_hexstring(*{a})"),
        OpKind.EUI48: _convert("x_eui48(*{a})"),
        OpKind.IPV4ADDR: _convert("x_ipv4addr(*{a})"),
        OpKind.IPV6ADDR: _convert("x_ipv6addr(*{a})"),
        OpKind.ENUM: _register(_enum),
        OpKind.BITSET: _register(_bitset),
        OpKind.BITSETBIT: _register(lambda op, decls: f"x_bit(*{op.args[0]}, {op.data['bit']})"),
    }
)


def body(lowered: Lowered, params: list[str]) -> list[str]:
    """Statements of `decode_<name>(r, present, p0, p1, ...)`, whose p<i> is a std::optional of
    params[i] (mdl.targets.cpp.emit.param_type); the last returns the value."""
    wide = {f"p{i}" for i, t in enumerate(params) if t == "uint64_t"}
    printing = _Printer(lowered.result, wide)
    lines: list[str] = []
    for op in lowered.ops:
        lines += printing.statements(op)
    result = lowered.result
    if result in wide:  # the value as it is: its bits as the long the expression returns
        return lines + [f"return {result} ? std::optional<int64_t>({_long(result, wide)}) : std::nullopt;"]
    return lines + [f"return {result};"]


RUNTIME = Path(__file__).resolve().parent / "runtime" / "expressions.hh"
_NAME = re.compile(r"\b(?:x_\w+|Regs|XLead)\b")


def _parts(text: str) -> list[RuntimePart]:
    """The parts of the runtime file, in its order: each starts at a `// part: NAMES | HEADERS` line."""
    parts = []
    for chunk in re.split(r"^// part: ", text, flags=re.M)[1:]:
        head, source = chunk.split("\n", 1)
        names, includes = head.split("|")
        source = "\n" + source.rstrip("\n") + "\n"
        parts.append(
            RuntimePart(tuple(names.split()), source, frozenset(_NAME.findall(source)), tuple(includes.split()))
        )
    return parts


# the runtime, in the order a driver holds its parts
_PARTS = _parts(RUNTIME.read_text(encoding="utf-8"))


def helpers(code: str) -> tuple[str, list[str]]:
    """The runtime parts `code` uses, directly or through other parts (templating.pick), and the
    headers they need."""
    parts = pick(_PARTS, _NAME.findall(code))
    return "".join(part.source for part in parts), sorted({inc for part in parts for inc in part.includes})
