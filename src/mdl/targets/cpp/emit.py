"""MDL model -> C++17 driver on libmodbus (<stem>.h / <stem>.cc), SPEC section 5.

The driver compiles without a warning under `-Wall -Wextra -Wpedantic -Wconversion -Wshadow` (g++
and clang++) and passes the clang-tidy checks docs/cpp-api.md lists: every conversion is spelled
out, every buffer is a std::array of a size known here, and read_all allocates nothing of its own.
Values are packed and unpacked with the generated code's own shifts for every byte and word order
(libmodbus 3.1.6's float helpers do not round-trip). Fragments are printed by mdl.lang.cfrag (as C
drivers get them), expressions by mdl.targets.cpp.expressions; text from the input reaches comments through
`ccomment` and string literals through `cstring` (mdl.targets.templating).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import jinja2

from mdl import __version__
from mdl.lang.cfrag import INCLUDES as FRAGMENT_INCLUDES
from mdl.lang.cfrag import CFragment, helpers_source
from mdl.model import Function
from mdl.resolve import ResolvedDevice, ResolvedFunction
from mdl.targets.base import Target, plan_rows
from mdl.targets.cpp.expressions import body as expr_body
from mdl.targets.cpp.expressions import cpp_type, helpers
from mdl.targets.templating import environment as render_environment
from mdl.values import ir
from mdl.values.ir import ValueType

# functions decoded by each part of read_all: one function of 80,000 lines for 10,000 functions made
# g++ -O2 quadratic (26 minutes); parts of this size keep it linear
READ_ALL_PART = 64
TABLE_CONST = {"coil": "kCoil", "discrete": "kDiscrete", "holding": "kHolding", "input": "kInput"}
# headers every driver's .cc includes; the expression runtime adds its own
BASE_INCLUDES = ("algorithm", "array", "cerrno", "cmath", "cstddef", "cstdint", "cstring")



def value_type(vt: ValueType) -> str:
    """T of read_<name>(T *out) / write_<name>(T value), before std::optional."""
    if vt.kind == "expr":
        return cpp_type(vt.expr_type)
    if vt.kind == "int":
        return f"{'' if vt.signed else 'u'}int{vt.bits}_t"
    if vt.kind == "float":
        return "float" if vt.bits == 32 else "double"
    return {"string": "std::string", "bool": "bool"}[vt.kind]


def cpp_number(x: float) -> str:
    text = repr(float(x))
    if "inf" in text or "nan" in text:
        raise ValueError(f"{x} cannot be a C++ literal")  # resolve refuses non-finite numbers before this
    return text if any(c in text for c in ".e") else text + ".0"


def _int_type_range(t: str) -> tuple[int, int] | None:
    """The values of an integer (or bool) value type, or None for any other type."""
    if t == "bool":
        return 0, 1
    m = re.fullmatch(r"(u?)int(\d+)_t", t)
    if m is None:
        return None
    bits = int(m.group(2))
    return (0, (1 << bits) - 1) if m.group(1) else (-(1 << (bits - 1)), (1 << (bits - 1)) - 1)


def range_tests(step: ir.CheckRange | None, t: str) -> list[str] | None:
    """The conditions that refuse a value: NaN, below minimum, above maximum; None if no value is
    within minimum..maximum. An integer is compared with the integers nearest inside the bounds,
    and a check that no value of its type can fail is left out."""
    if step is None:
        return []  # without bounds NaN is written as the float it is, as every target does
    tests = ["std::isnan(value)"] if t in ("double", "float") else []
    values = _int_type_range(t)
    for bound, op in ((step.minimum, "<"), (step.maximum, ">")):
        if bound is None or t == "std::string":
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
    return tests


# ---- the template's view of the device ----

@dataclass
class CppFunction:
    fn: Function
    ident: str
    codec: ir.Codec  # its value IR, which templates/ops.j2 prints
    t: str  # value type
    rt: str  # read type: t, or std::optional<t>
    n: int  # registers (or bits)
    expr: bool
    deps: list[str]  # idents of the functions an expression refers to, in parameter order
    runs: list[dict[str, Any]]
    slots: list[int]  # positions of the registers in read_all's buffer
    readable: bool
    writable: bool
    status: bool  # whether decode_<name> returns a status (0, or -1 with errno) and sets *out
    decode_lines: list[str]  # a read fragment's or an expression's statements
    encode_lines: list[str]  # a write fragment's statements
    range_tests: list[str] | None  # conditions refusing a value to write; None: every value is refused
    int_bits: int  # the width of the C type of an integer value
    params: str = ""
    steps: list[CppFunction] = field(default_factory=list)  # what read_<name> decodes, dependencies first

    @property
    def reads_device(self) -> bool:
        return any(step.n for step in self.steps)


def _function(resolved: ResolvedDevice, f: ResolvedFunction, ident_of: dict[str, str]) -> CppFunction:
    fn, codec, lay = f.fn, f.codec, f.layout
    read_fragment = ir.find_step(codec.decode, ir.Fragment)
    write_fragment = ir.find_step(codec.encode, ir.Fragment)
    # SPEC 5: T is double wherever a fragment applies, for the read and the write alike
    t = "double" if fn.write_function_code and fn.writable else value_type(codec.value_type)
    expression = ir.find_step(codec.decode, ir.Expression)
    if expression is not None:
        decode_lines = expr_body(expression.lowered)
    elif read_fragment is not None:
        decode_lines = read_fragment.tree.c("c++").body()
    else:
        decode_lines = []
    wt = value_type(codec.write_type)
    return CppFunction(
        fn=fn, ident=f.ident, codec=codec, t=t, n=len(lay.addresses), expr=expression is not None,
        rt=f"std::optional<{t}>" if codec.value_type.nullable else t,
        deps=[ident_of[d] for d in f.deps],
        runs=[{"table": TABLE_CONST[lay.table], "start": s, "count": c} for s, c in lay.runs],
        slots=list(resolved.slots_of(f)) if fn.readable else [],
        readable=codec.decode is not None, writable=codec.encode is not None,
        status=read_fragment is not None, decode_lines=decode_lines,
        encode_lines=write_fragment.tree.c("c++").body() if write_fragment is not None else [],
        range_tests=range_tests(ir.find_step(codec.encode, ir.CheckRange), wt) if codec.encode is not None else [],
        int_bits=codec.write_type.bits)


def _functions(resolved: ResolvedDevice) -> dict[str, CppFunction]:
    ident_of = {f.name: f.ident for f in resolved.functions}
    out = {f.ident: _function(resolved, f, ident_of) for f in resolved.functions}
    for f in out.values():
        f.params = ", ".join(([f"const std::array<uint16_t, {f.n}> &r"] if f.n else [])
                             + ([f"const std::array<bool, {f.n}> &present"] if f.n and f.expr else [])
                             + [f"const std::optional<{out[d].t}> &p{i}" for i, d in enumerate(f.deps)]
                             + ([f"{f.rt} *out"] if f.status else []))
        closure = resolved.closure([f.fn.name]) if f.deps else [resolved.by_name[f.fn.name]]
        f.steps = [out[g.ident] for g in closure]
    return out


def _fragments(resolved: ResolvedDevice) -> list[CFragment]:
    return [step.tree.c("c++") for f in resolved.functions for steps in (f.codec.decode, f.codec.encode)
            for step in steps or () if isinstance(step, ir.Fragment)]


def context(resolved: ResolvedDevice, source_name: str) -> dict[str, Any]:
    device = resolved.device
    file_stem = resolved.stem
    groups, splits = plan_rows(resolved, TABLE_CONST)
    raw_total = resolved.buffer_size
    by_ident = _functions(resolved)
    functions = list(by_ident.values())
    readable = [by_ident[f.ident] for f in resolved.readable]
    code = [line for f in functions for line in f.decode_lines]
    runtime, runtime_includes = helpers("\n".join(code))
    fragments = _fragments(resolved)
    if fragments:
        runtime += "\n" + helpers_source(fragments, "c++")
        runtime_includes += FRAGMENT_INCLUDES["c++"]
    chunks = [{"functions": part, "uses_raw": any(f.n for f in part)}
              for part in (readable[i:i + READ_ALL_PART] for i in range(0, len(readable), READ_ALL_PART))]
    types = [f.t for f in functions] + [f.rt for f in functions]
    values_own_memory = any("std::string" in f.rt or "std::vector" in f.rt for f in readable)
    return {
        "device": device, "version": __version__, "source": source_name, "stem": file_stem,
        "class_name": resolved.class_name, "guard": f"MDL_{file_stem.upper().rstrip('_')}_H", "functions": functions,
        "readable": readable, "chunks": chunks, "groups": groups, "splits": splits, "raw_total": raw_total,
        "fragments": bool(fragments), "runtime": runtime, "values_own_memory": values_own_memory,
        "writes_multiple": any(f.writable and f.fn.write_multiple for f in functions),  # FC15/FC16 only
        "includes": sorted(set(BASE_INCLUDES) | set(runtime_includes) | ({"utility"} if values_own_memory else set())),
        "header_includes": sorted({"array", "cstddef", "cstdint"}
                                  | ({"optional"} if any("std::optional" in t for t in types) else set())
                                  | ({"string"} if any("std::string" in t for t in types) else set())
                                  | ({"vector"} if any("std::vector" in t for t in types) else set())),
    }


def environment() -> jinja2.Environment:
    env = render_environment()
    env.filters["cppfloat"] = cpp_number
    return env


def render_files(resolved: ResolvedDevice, source_name: str) -> dict[str, str]:
    ctx = context(resolved, source_name)
    env = environment()
    return {f"{resolved.stem}.h": env.get_template("cpp/templates/device.h.j2").render(**ctx),
            f"{resolved.stem}.cc": env.get_template("cpp/templates/device.cc.j2").render(**ctx)}


TARGET = Target("cpp", render_files)
