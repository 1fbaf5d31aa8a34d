"""Lowered expression operations -> straight-line C++17 over std::optional, and the runtime those
operations call: `helpers(code)` picks the parts of the runtime the generated code uses, so a
driver holds no unused function.

Register values are `Regs<N>` (a std::array): every size is known when the driver is generated, so
reading and converting registers allocates nothing; only text and list results own heap memory.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

from mdl.lang.expr.lower import Lowered, Op
from mdl.targets.templating import c_int64, ctext

CPP_TYPES = {"long": "int64_t", "double": "double", "string": "std::string", "bool": "bool",
             "list": "std::vector<std::string>"}
_CONVERT = {"int16": "x_int(*{a}, true)", "uint16": "x_int(*{a}, false)", "int32": "x_int(*{a}, true)",
            "uint32": "x_int(*{a}, false)", "int64": "x_int(*{a}, true)", "uint64": "x_int(*{a}, false)",
            "ieee754_32": "x_float(*{a})", "ieee754_64": "x_float(*{a})", "utf8": "x_utf8(*{a})",
            "hexstring": "x_hexstring(*{a})", "eui48": "x_eui48(*{a})", "ipv4addr": "x_ipv4addr(*{a})",
            "ipv6addr": "x_ipv6addr(*{a})"}


def cpp_type(t: str) -> str:
    return CPP_TYPES[t]


def _double(value: float) -> str:
    text = repr(float(value))
    return text if any(c in text for c in ".e") else text + ".0"


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
    return c_int64(int(v)) if op.type == "long" else _double(v)


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


def _lines(op: Op, types: dict[str, str], result: str, wide: set[str]) -> list[str]:
    t = f"std::optional<{_regs_type(op) if op.type == 'regs' else cpp_type(op.type)}>"
    types[op.tmp] = t
    const = "" if op.tmp == result else "const "  # the result is moved out, not copied
    a = op.args[0] if op.args else ""  # an operation without arguments names none
    d = op.data
    decls: list[str] = []  # the char arrays of texts too long for a literal
    if op.kind == "lit":
        value = _literal(op, decls)
        return [*decls, f"{const}{t} {op.tmp} = {value};"]
    if op.kind == "regs":
        index = ", ".join(str(i) for i in d["index"])
        regs = ", ".join(f"r[{i}]" for i in d["index"])
        return [f"{const}{t} {op.tmp} = x_all(present, {{{index}}}) ? {t}({_regs_type(op)}{{{regs}}}) : std::nullopt;"]
    if op.kind == "const":
        return [f"{const}{t} {op.tmp} = {_regs_literal(op, d['words'])};"]
    if op.kind == "concat":
        parts = [_text(x, pt, wide) for x, pt in zip(op.args, d["types"], strict=True)]
        return [f"{const}{t} {op.tmp} = {' + '.join(['std::string()', *parts])};"]
    out = [f"{t} {op.tmp};"]
    if op.kind in ("swapbytes", "swapendian"):
        return out + [f"if ({a}) {{ {op.tmp} = x_{op.kind}(*{a}); }}"]
    if op.kind == "bit":
        return out + [f"if ({a}) {{ {op.tmp} = (*{a})[0] != 0; }}"]
    if op.kind == "label":
        false_text, true_text = d["labels"]
        f, tr = _text_of(false_text, f"{op.tmp}_f", decls), _text_of(true_text, f"{op.tmp}_t", decls)
        return decls + out + [f"if ({a}) {{ {op.tmp} = std::string(*{a} ? {tr} : {f}); }}"]
    if op.kind == "todouble":
        return out + [f"if ({a}) {{ {op.tmp} = static_cast<double>({_long(a, wide)}); }}"]
    if op.kind == "neg":
        expr = f"x_sub<int64_t>(0, {_long(a, wide)})" if op.type == "long" else f"-*{a}"
        return out + [f"if ({a}) {{ {op.tmp} = {expr}; }}"]
    if op.kind in ("arith", "div", "pow"):
        b = op.args[1]
        if op.kind == "div":
            expr = f"*{a} / *{b}"
        elif op.kind == "pow":
            expr = f"std::pow(*{a}, *{b})"
        elif op.type == "long":
            name = {"+": "add", "-": "sub", "*": "mul"}[d["op"]]
            expr = f"x_{name}({_long(a, wide)}, {_long(b, wide)})"
        else:
            expr = f"*{a} {d['op']} *{b}"
        return out + [f"if ({a} && {b}) {{ {op.tmp} = {expr}; }}"]
    call = _register_function(op, decls)
    return decls + out + [f"if ({_guard(op, types)}) {{ {op.tmp} = {call}; }}"]


def _guard(op: Op, types: dict[str, str]) -> str:
    """The argument is there and is none of the function's "not implemented" values."""
    a = op.args[0]
    arg_type = types[a][len("std::optional<"):-1]
    return a + "".join(f" && *{a} != {arg_type}{{" + ", ".join(f"0x{w:04X}U" for w in g) + "}"
                       for g in op.data["ni"])


def _register_function(op: Op, decls: list[str]) -> str:
    a, d = op.args[0], op.data
    if op.kind == "enum":
        table = ", ".join(f"{{{c_int64(k)}, {_text_of(v, f'{op.tmp}_label{i}', decls)}}}"
                          for i, (k, v) in enumerate(sorted(d["mapping"].items())))
        return f"x_enum(*{a}, {{{table}}})"
    if op.kind == "bitset":  # a bit the registers do not have is never set: its label is left out
        bits = 16 * d["count"]
        table = ", ".join(f"{{{k}, {_text_of(v, f'{op.tmp}_label{k}', decls)}}}"
                          for k, v in sorted(d["mapping"].items()) if 0 <= k < bits)
        return f"x_bitset(*{a}, {{{table}}})"
    if op.kind == "bitsetbit":
        return f"x_bit(*{a}, {d['bit']})"
    return _CONVERT[op.kind].format(a=a)


def body(lowered: Lowered, params: list[str]) -> list[str]:
    """Statements of `decode_<name>(r, present, p0, p1, ...)`, whose p<i> is a std::optional of
    params[i] (mdl.targets.cpp.emit.param_type); the last returns the value."""
    wide = {f"p{i}" for i, t in enumerate(params) if t == "uint64_t"}
    types: dict[str, str] = {}
    lines: list[str] = []
    for op in lowered.ops:
        lines += _lines(op, types, lowered.result, wide)
    result = lowered.result
    if result in wide:  # the value as it is: its bits as the long the expression returns
        return lines + [f"return {result} ? std::optional<int64_t>({_long(result, wide)}) : std::nullopt;"]
    return lines + [f"return {result};"]


class _Part(NamedTuple):
    names: tuple[str, ...]  # what it defines
    includes: tuple[str, ...]  # the headers it needs
    source: str


RUNTIME = Path(__file__).resolve().parent / "runtime" / "expressions.hh"


def _parts(text: str) -> list[_Part]:
    """The parts of the runtime file, in its order: each starts at a `// part: NAMES | HEADERS` line."""
    parts = []
    for chunk in re.split(r"^// part: ", text, flags=re.M)[1:]:
        head, source = chunk.split("\n", 1)
        names, includes = head.split("|")
        parts.append(_Part(tuple(names.split()), tuple(includes.split()), "\n" + source.rstrip("\n") + "\n"))
    return parts


# the runtime, in the order a driver holds its parts
_PARTS = _parts(RUNTIME.read_text(encoding="utf-8"))


def helpers(code: str) -> tuple[str, list[str]]:
    """The runtime parts `code` uses, directly or through other parts, and the headers they need."""
    wanted: set[int] = set()
    todo = [code]
    while todo:
        used = set(re.findall(r"\b(?:x_\w+|Regs|XLead)\b", todo.pop()))
        for i, part in enumerate(_PARTS):
            if i not in wanted and used.intersection(part.names):
                wanted.add(i)
                todo.append(part.source)
    parts = [_PARTS[i] for i in sorted(wanted)]
    return "".join(part.source for part in parts), sorted({inc for part in parts for inc in part.includes})
