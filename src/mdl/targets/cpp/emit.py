"""MDL model -> C++17 driver on libmodbus (<stem>.h / <stem>.cc), SPEC section 5.

The driver compiles without a warning under `-Wall -Wextra -Wpedantic -Wconversion -Wshadow` (g++
and clang++) and passes the clang-tidy checks docs/cpp-api.md lists: every conversion is spelled
out, every buffer is a std::array of a size known here, and read_all allocates nothing of its own.
Values are packed and unpacked with the generated code's own shifts for every byte and word order
(libmodbus 3.1.6's float helpers do not round-trip). Fragments are printed by mdl.lang.cfrag (as C
drivers get them), expressions by mdl.targets.cpp.expressions; text from the input reaches comments through
`ccomment` and string literals through `cstring` (mdl.targets.render).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from mdl import __version__
from mdl.lang.cfrag import INCLUDES as FRAGMENT_INCLUDES
from mdl.lang.cfrag import CFragment, compile_fragment, helpers_source
from mdl.lang.expr.fields import evaluation_order
from mdl.model import Device, Function
from mdl.model.layout import Layout, int_type_bits, layout
from mdl.model.names import camel, stem, unique_identifiers
from mdl.plan import plan_reads, split_request
from mdl.targets.base import Target
from mdl.targets.cpp.expressions import body as expr_body
from mdl.targets.cpp.expressions import cpp_type, helpers
from mdl.targets.python.emit import runs
from mdl.targets.render import ccomment, environment
from mdl.values.codec import int_range, scales
from mdl.values.straight import span_bits, unit_shift, units_msb_first

TABLE_CONST = {"coil": "kCoil", "discrete": "kDiscrete", "holding": "kHolding", "input": "kInput"}
# headers every driver's .cc includes; the expression runtime adds its own
BASE_INCLUDES = ("algorithm", "array", "cerrno", "cmath", "cstddef", "cstdint", "cstring")


def cpp_number(x: float) -> str:
    text = repr(float(x))
    if "inf" in text or "nan" in text:
        raise ValueError(f"{x} cannot be a C++ literal")
    return text if any(c in text for c in ".e") else text + ".0"


def value_type(fn: Function) -> str:
    """T of read_<name>(T *out) / write_<name>(T value), before std::optional."""
    if fn.compiled is not None:
        return cpp_type(fn.compiled.type)
    lay = layout(fn)
    if fn.read_function_code or fn.write_function_code or scales(fn):
        return "double"
    if lay.kind == "bool":
        return "bool"
    if lay.kind == "string":
        return "std::string"
    if lay.kind == "float":
        return "float" if lay.bits == 32 else "double"
    return f"{'' if lay.signed else 'u'}int{int_type_bits(lay.bits)}_t"


# ---- fragments: mdl.lang.cfrag prints them as C++ (docs/fragments.md says what they compute) ----

def read_fragment(fn: Function) -> CFragment | None:
    """The read_function_code of a readable function, as the body of `int decode_<name>(r, T *out)`."""
    if not (fn.read_function_code and fn.readable):
        return None
    return compile_fragment(fn.read_function_code, len(layout(fn).addresses), True).c("c++")


def write_fragment(fn: Function) -> CFragment | None:
    """The write_function_code of a writable function, as the end of `int encode_<name>(value, r)`."""
    if not (fn.write_function_code and fn.writable):
        return None
    return compile_fragment(fn.write_function_code, len(layout(fn).addresses), False).c("c++")


# ---- decoders and encoders of the formats ----

def _unit_expr(i: int, part: str) -> str:
    return {"word": f"static_cast<uint64_t>(r[{i}])",
            "swap": f"static_cast<uint64_t>(((r[{i}] & 0xFFU) << 8U) | (r[{i}] >> 8U))",
            "low": f"static_cast<uint64_t>(r[{i}] & 0xFFU)",
            "high": f"static_cast<uint64_t>(r[{i}] >> 8U)"}[part]


def _compose_lines(lay: Layout) -> list[str]:
    lines = ["uint64_t v = 0;"]
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        shift = unit_shift(lay, pos)
        lines.append(f"v |= {_unit_expr(i, part)}{f' << {shift}U' if shift else ''};")
    return lines


def _not_implemented_lines(fn: Function, n: int, status: bool) -> list[str]:
    """The tests of the "not implemented" values, in a decoder that returns its value or (status)
    returns 0 and sets *out."""
    lines = []
    for token in fn.not_implemented or []:
        pattern = int(token, 16)
        if len(token) <= 6:
            test = " && ".join(f"r[{i}] == 0x{pattern:04X}U" for i in range(n))
        else:
            test = " && ".join(f"r[{i}] == 0x{(pattern >> (16 * (n - 1 - i))) & 0xFFFF:04X}U" for i in range(n))
        done = ["*out = std::nullopt;", "return 0;"] if status else ["return std::nullopt;"]
        lines += [f"if ({test}) {{  // not implemented: {ccomment(token)}", *("    " + line for line in done), "}"]
    return lines


def _string_decode_lines(lay: Layout) -> list[str]:
    nbytes = span_bits(lay) // 8
    lines = [f"std::array<char, {nbytes}> s{{}};"]
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        if lay.unit == "word":
            hi, lo = (f"r[{i}] >> 8U", f"r[{i}] & 0xFFU") if part == "word" else (f"r[{i}] & 0xFFU", f"r[{i}] >> 8U")
            lines += [f"s[{2 * pos}] = static_cast<char>({hi});", f"s[{2 * pos + 1}] = static_cast<char>({lo});"]
        else:
            src = f"r[{i}] & 0xFFU" if part == "low" else f"r[{i}] >> 8U"
            lines.append(f"s[{pos}] = static_cast<char>({src});")
    return lines + ["std::size_t len = s.size();",
                    "while (len > 0 && (s[len - 1] == '\\0' || s[len - 1] == ' ')) {",
                    "    --len;",
                    "}",
                    "return {s.data(), len};"]


def decode_lines(fn: Function, t: str) -> list[str]:
    """Body of `T decode_<name>(const std::array<uint16_t, N> &r, ...)`, or for a fragment of
    `int decode_<name>(const std::array<uint16_t, N> &r, T *out)`: 0, or -1 with errno set."""
    if fn.compiled is not None:
        return expr_body(fn.compiled.lowered)
    lay = layout(fn)
    fragment = read_fragment(fn)
    lines = _not_implemented_lines(fn, len(lay.addresses), status=fragment is not None)
    if fragment is not None:
        return lines + fragment.body()
    if lay.kind == "bool":
        return lines + ["return r[0] != 0;"]
    if lay.kind == "string":
        return lines + _string_decode_lines(lay)
    lines += _compose_lines(lay)
    if lay.kind == "float":
        ctype, width = ("float", "uint32_t") if lay.bits == 32 else ("double", "uint64_t")
        lines += [f"const auto bits = static_cast<{width}>(v);",
                  f"{ctype} f = {'0.0F' if ctype == 'float' else '0.0'};",
                  "std::memcpy(&f, &bits, sizeof f);"]
        raw, rtype = "f", ctype
    else:
        if lay.bits < 64:
            lines.append(f"v &= 0x{(1 << lay.bits) - 1:X}ULL;")
        raw, rtype = "v", "uint64_t"
        if lay.signed:
            if lay.bits < 64:
                sign = f"0x{1 << (lay.bits - 1):X}ULL"
                lines.append(f"const int64_t s = static_cast<int64_t>(v ^ {sign}) - static_cast<int64_t>({sign});")
            else:
                lines += ["int64_t s = 0;", "std::memcpy(&s, &v, sizeof s);"]
            raw, rtype = "s", "int64_t"
    if scales(fn):
        scaled = f"static_cast<double>({raw}) * {cpp_number(fn.eff_multiplier)} + {cpp_number(fn.eff_offset)}"
        return lines + [f"return {scaled};"]
    return lines + [f"return {raw if rtype == t else f'static_cast<{t}>({raw})'};"]


def _int_type_range(t: str) -> tuple[int, int] | None:
    """The values of an integer (or bool) value type, or None for any other type."""
    if t == "bool":
        return 0, 1
    m = re.fullmatch(r"(u?)int(\d+)_t", t)
    if m is None:
        return None
    bits = int(m.group(2))
    return (0, (1 << bits) - 1) if m.group(1) else (-(1 << (bits - 1)), (1 << (bits - 1)) - 1)


def _range_lines(fn: Function, t: str) -> list[str] | None:
    """The checks of NaN, minimum and maximum; None if no value is within minimum..maximum. An
    integer is compared with the integers nearest inside the bounds, and a check that no value of
    its type can fail is left out."""
    tests = ["std::isnan(value)"] if t in ("double", "float") else []
    values = _int_type_range(t)
    for bound, op in ((fn.minimum, "<"), (fn.maximum, ">")):
        if bound is None or math.isnan(bound) or t == "std::string":
            continue
        if math.isinf(bound):
            if (bound > 0) == (op == "<"):
                return None
            continue
        if values is None:
            tests.append(f"value {op} {cpp_number(bound)}")
            continue
        edge = math.ceil(bound) if op == "<" else math.floor(bound)
        if edge > values[1] if op == "<" else edge < values[0]:
            return None
        if edge > values[0] if op == "<" else edge < values[1]:
            value = "static_cast<int>(value)" if t == "bool" else "value"
            literal = {"int64_t": f"INT64_C({edge})", "uint64_t": f"UINT64_C({edge})", "uint32_t": f"{edge}U"}
            tests.append(f"{value} {op} {literal.get(t, str(edge))}")
    return [line for test in tests for line in _fail_if(test)]


def _fail_if(test: str) -> list[str]:
    return [f"if ({test}) {{", "    errno = EINVAL;", "    return -1;", "}"]


def _int_encode_lines(fn: Function, lay: Layout) -> list[str]:
    lo, hi = int_range(lay)
    if scales(fn):
        x = f"std::floor((value - {cpp_number(fn.eff_offset)}) / {cpp_number(fn.eff_multiplier)} + 0.5)"
        lines = [f"const double x = {x};", *_fail_if(f"!(x >= {cpp_number(lo)} && x <= {cpp_number(hi)})")]
        if lay.bits == 64:  # the double range check is inexact at 2^63/2^64
            lines += _fail_if(f"x >= {'9223372036854775807.0' if lay.signed else '18446744073709551615.0'}")
        ctype = "int64_t" if lay.signed else "uint64_t"
        return lines + [f"auto v = static_cast<uint64_t>(static_cast<{ctype}>(x));"]
    lines = []
    if int_type_bits(lay.bits) != lay.bits:
        lines += _fail_if(f"value < {lo}LL || value > {hi}LL" if lay.signed else f"value > {hi}ULL")
    widened = "static_cast<int64_t>(value)" if lay.signed and int_type_bits(lay.bits) < 64 else "value"
    return lines + [f"auto v = static_cast<uint64_t>({widened});"]


def encode_lines(fn: Function, t: str) -> list[str]:
    """Body of `int encode_<name>(T value, std::array<uint16_t, N> &r)`: 0, or -1 with errno = EINVAL."""
    lay = layout(fn)
    checks = _range_lines(fn, t)
    if checks is None:
        return ["static_cast<void>(value);", "static_cast<void>(r);",
                "errno = EINVAL;  // no value is within minimum..maximum", "return -1;"]
    lines = checks
    fragment = write_fragment(fn)
    if fragment is not None:
        return lines + fragment.body()
    if lay.kind == "bool":
        return lines + ["r[0] = value ? 1U : 0U;", "return 0;"]
    span = span_bits(lay)
    if lay.kind == "string":
        nbytes = span // 8
        lines += _fail_if(f"value.size() > {nbytes}")
        lines += [f"std::array<unsigned char, {nbytes}> s{{}};", "std::memcpy(s.data(), value.data(), value.size());"]
        for pos, (i, part) in enumerate(units_msb_first(lay)):
            if lay.unit == "word":
                hi, lo = (2 * pos, 2 * pos + 1) if part == "word" else (2 * pos + 1, 2 * pos)
                lines.append(f"r[{i}] = static_cast<uint16_t>((s[{hi}] << 8U) | s[{lo}]);")
            else:
                lines.append(f"r[{i}] = static_cast<uint16_t>(s[{pos}]{' << 8U' if part == 'high' else ''});")
        return lines + ["return 0;"]
    if lay.kind == "float":
        if scales(fn):
            lines.append(f"const double x = (value - {cpp_number(fn.eff_offset)}) / {cpp_number(fn.eff_multiplier)};")
        else:
            lines.append("const double x = value;")
        ctype, width = ("float", "uint32_t") if lay.bits == 32 else ("double", "uint64_t")
        lines += [f"const auto f = static_cast<{ctype}>(x);", f"{width} bits = 0;",
                  "std::memcpy(&bits, &f, sizeof bits);",
                  "const uint64_t v = bits;"]
    else:
        lines += _int_encode_lines(fn, lay)
        if span < 64:
            lines.append(f"v &= 0x{(1 << span) - 1:X}ULL;")
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        shift = unit_shift(lay, pos)
        unit = f"(v >> {shift}U)" if shift else "v"
        expr = {"word": f"{unit} & 0xFFFFU", "swap": f"(({unit} & 0xFFU) << 8U) | (({unit} >> 8U) & 0xFFU)",
                "low": f"{unit} & 0xFFU", "high": f"({unit} & 0xFFU) << 8U"}[part]
        lines.append(f"r[{i}] = static_cast<uint16_t>({expr});")
    return lines + ["return 0;"]


# ---- the template's view of the device ----

@dataclass
class CppFunction:
    fn: Function
    ident: str
    t: str  # value type
    rt: str  # read type: t, or std::optional<t>
    n: int  # registers (or bits)
    expr: bool
    deps: list[str]  # idents of the functions an expression refers to, in parameter order
    runs: list[dict[str, Any]]
    slots: list[int]  # positions of the registers in read_all's buffer
    decode: list[str] | None
    encode: list[str] | None
    status: bool  # whether decode_<name> returns a status (0, or -1 with errno) and sets *out
    params: str = ""
    steps: list[CppFunction] = field(default_factory=list)  # what read_<name> decodes, dependencies first

    def decode_into(self, target: str, deps_from: str) -> list[str]:
        """Statements that decode the registers r (with present) into target, an lvalue; the values
        the function depends on are deps_from + their names."""
        regs = ["r", "present"] if self.expr else ["r"]
        args = (regs if self.n else []) + [deps_from + d for d in self.deps]
        if not self.status:
            return [f"{target} = decode_{self.ident}({', '.join(args)});"]
        args.append(target[1:] if target.startswith("*") else f"&{target}")
        return [f"if (decode_{self.ident}({', '.join(args)}) == -1) {{", "    return -1;", "}"]

    @property
    def reads_device(self) -> bool:
        return any(step.n for step in self.steps)


def _plan(device: Device) -> tuple[list[dict[str, Any]], list[dict[str, Any]], dict[tuple[str, int], int], int]:
    groups: list[dict[str, Any]] = []
    splits: list[dict[str, Any]] = []
    slot: dict[tuple[str, int], int] = {}
    offset = 0
    for req in plan_reads(device):
        parts = split_request(device, req)
        smaller = parts if parts != [req] else []
        groups.append({"table": TABLE_CONST[req.table], "start": req.start, "count": req.count, "offset": offset,
                       "split_first": len(splits), "split_count": len(smaller)})
        for a in range(req.start, req.end):
            slot[(req.table, a)] = offset + a - req.start
        splits += [{"table": TABLE_CONST[s.table], "start": s.start, "count": s.count, "delta": s.start - req.start}
                   for s in smaller]
        offset += req.count
    return groups, splits, slot, offset


def _functions(device: Device, slot: dict[tuple[str, int], int]) -> dict[str, CppFunction]:
    idents = unique_identifiers(fn.name for fn in device.functions)
    ident_of = dict(zip((fn.name for fn in device.functions), idents, strict=True))
    out: dict[str, CppFunction] = {}
    for fn, ident in zip(device.functions, idents, strict=True):
        lay = layout(fn)
        t = value_type(fn)
        out[ident] = CppFunction(
            fn=fn, ident=ident, t=t, n=len(lay.addresses), expr=fn.compiled is not None,
            rt=f"std::optional<{t}>" if fn.not_implemented or fn.compiled is not None else t,
            deps=[ident_of[d] for d in (fn.compiled.deps if fn.compiled is not None else [])],
            runs=[{"table": TABLE_CONST[tb], "start": s, "count": c} for tb, s, c in runs(lay)],
            slots=[slot[(lay.table, a)] for a in lay.addresses] if fn.readable else [],
            decode=decode_lines(fn, t) if fn.readable else None,
            encode=encode_lines(fn, t) if fn.writable else None,
            status=read_fragment(fn) is not None)
    for f in out.values():
        f.params = ", ".join(([f"const std::array<uint16_t, {f.n}> &r"] if f.n else [])
                             + ([f"const std::array<bool, {f.n}> &present"] if f.n and f.expr else [])
                             + [f"const std::optional<{out[d].t}> &p{i}" for i, d in enumerate(f.deps)]
                             + ([f"{f.rt} *out"] if f.status else []))
        closure = evaluation_order(device, [f.fn.name]) if f.deps else [f.fn]
        f.steps = [out[ident_of[g.name]] for g in closure]
    return out


def context(device: Device, source_name: str) -> dict[str, Any]:
    file_stem = stem(device.name)
    groups, splits, slot, raw_total = _plan(device)
    by_ident = _functions(device, slot)
    functions = list(by_ident.values())
    order = evaluation_order(device, [fn.name for fn in device.functions if fn.readable])
    readable = [next(f for f in functions if f.fn is fn) for fn in order]
    code = [line for f in functions for line in (f.decode or []) + (f.encode or [])]
    runtime, runtime_includes = helpers("\n".join(code))
    fragments = [c for fn in device.functions for c in (read_fragment(fn), write_fragment(fn)) if c is not None]
    if fragments:
        runtime += "\n" + helpers_source(fragments, "c++")
        runtime_includes += FRAGMENT_INCLUDES["c++"]
    types = [f.t for f in functions] + [f.rt for f in functions]
    values_own_memory = any("std::string" in f.rt or "std::vector" in f.rt for f in readable)
    return {
        "device": device, "version": __version__, "source": source_name, "stem": file_stem,
        "class_name": camel(file_stem), "guard": f"MDL_{file_stem.upper().rstrip('_')}_H", "functions": functions,
        "readable": readable, "groups": groups, "splits": splits, "raw_total": raw_total,
        "fragments": bool(fragments), "runtime": runtime, "values_own_memory": values_own_memory,
        "includes": sorted(set(BASE_INCLUDES) | set(runtime_includes) | ({"utility"} if values_own_memory else set())),
        "header_includes": sorted({"array", "cstddef", "cstdint"}
                                  | ({"optional"} if any("std::optional" in t for t in types) else set())
                                  | ({"string"} if any("std::string" in t for t in types) else set())
                                  | ({"vector"} if any("std::vector" in t for t in types) else set())),
    }


def render_files(device: Device, source_name: str) -> dict[str, str]:
    ctx = context(device, source_name)
    env = environment()
    return {f"{ctx['stem']}.h": env.get_template("cpp/templates/device.h.j2").render(**ctx),
            f"{ctx['stem']}.cc": env.get_template("cpp/templates/device.cc.j2").render(**ctx)}


TARGET = Target("cpp", render_files)
