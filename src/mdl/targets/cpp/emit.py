"""MDL model -> C++17 driver on libmodbus (<stem>.h / <stem>.cc), SPEC section 5.

The driver compiles without a warning under `-Wall -Wextra -Wpedantic -Wconversion -Wshadow` (g++
and clang++) and passes the clang-tidy checks docs/cpp-api.md lists: every conversion is spelled
out, every buffer is a std::array of a size known here, and read_all allocates nothing of its own.
Values are packed and unpacked with the generated code's own shifts for every byte and word order
(libmodbus 3.1.6's float helpers do not round-trip). Fragments are printed by mdl.dsl.cfrag (as C
drivers get them), expressions by mdl.targets.cpp.expressions; text from the input reaches comments through
`ccomment` and string literals through `cstring` (mdl.targets.templating). The templates print each file's
skeleton and the decoders and encoders whole (templates/ops.j2, some ten for a device of 10,000
functions); the other parts that repeat for every function are printed in Python
(mdl.targets.cpp.declarations for the header, mdl.targets.cpp.definitions for the source), which a
device of 10,000 functions renders in a fraction of the time loops of Jinja took.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

import jinja2

from mdl import __version__
from mdl.dsl.cfrag import INCLUDES as FRAGMENT_INCLUDES
from mdl.dsl.cfrag import CFragment, helpers_source
from mdl.dsl.expr.fields import plain_type
from mdl.dsl.expr.lower import Lowered
from mdl.ir import steps as ir
from mdl.ir.steps import ValueType
from mdl.model import Function
from mdl.resolver import ResolvedDevice, ResolvedFunction
from mdl.targets import clike
from mdl.targets.base import Run, Target, plan_rows, runs_at
from mdl.targets.clike import MergeRow, Printing, Shared, int_bounds, merge_rows
from mdl.targets.cpp import declarations, definitions
from mdl.targets.cpp.expressions import body as expr_body
from mdl.targets.cpp.expressions import cpp_type, helpers
from mdl.targets.profile import NOT_PROVIDED_ERRNO, Interface, check_files, int_write
from mdl.targets.templating import SharedRendering, ccomment, ctext, double_literal, generation_macro
from mdl.targets.templating import environment as render_environment

# functions whose read_<name> and write_<name> one class declares: g++ declares a class's member functions
# in time that grows with the square of their number (20,000 in one class: 19 s), so a device of more has
# them in a chain of classes of this many functions each, which its class derives from (class_parts)
CLASS_PART = 500
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


def range_tests(step: ir.CheckRange | None, t: str) -> list[str] | None:
    """The conditions that refuse a value: NaN, below minimum, above maximum; None if no value is
    within minimum..maximum. An integer is compared with the integers nearest inside the bounds,
    and a check that no value of its type can fail is left out (clike.int_bounds)."""
    if step is None:
        return []  # without bounds NaN is written as the float it is, as every target does
    tests = ["std::isnan(value)"] if t in ("double", "float") else []
    if t == "std::string":
        return tests
    bounds = int_bounds(step.minimum, step.maximum, t)
    if bounds is None:
        return tests + [
            f"value {op} {double_literal(float(bound))}"
            for bound, op in ((step.minimum, "<"), (step.maximum, ">"))
            if bound is not None
        ]
    if bounds.never:
        return None
    value = "static_cast<int>(value)" if t == "bool" else "value"
    literal = {"int64_t": "INT64_C({})", "uint64_t": "UINT64_C({})", "uint32_t": "{}U"}.get(t, "{}")
    return tests + [
        f"{value} {op} {literal.format(edge)}"
        for edge, op in ((bounds.low, "<"), (bounds.high, ">"))
        if edge is not None
    ]


# ---- the template's view of the device ----


@dataclass(eq=False, slots=True)  # compared by identity: one per function
class CppFunction:
    resolved: ResolvedFunction
    fn: Function
    ident: str
    about: str  # its description (and units) in a comment
    codec: ir.Codec  # its value IR, which templates/ops.j2 prints
    t: str  # value type
    rt: str  # read type: t, or std::optional<t>
    n: int  # registers (or bits)
    expr: bool
    deps: list[str]  # idents of the functions an expression refers to, in parameter order
    dep_types: list[str]  # the types of its decoder's parameters naming them (param_type)
    dep_args: list[str]  # the arguments passing them, `%s` standing for where they are (v_, values.)
    runs: list[Run]
    slots: Sequence[int]  # positions of the registers in read_all's buffer
    readable: bool
    writable: bool
    status: bool  # whether decode_<name> returns a status (0, or -1 with errno) and sets *out
    decode_lines: list[str]  # a read fragment's or an expression's statements
    encode_lines: list[str]  # a write fragment's statements
    range_tests: list[str] | None  # conditions refusing a value to write; None: every value is refused
    int_bits: int  # the width of the C type of an integer value
    steps: list[CppFunction] = field(default_factory=list)  # what read_<name> decodes, dependencies first
    # its decoder decode_<decoder> and encoder encode_<encoder>: a shared one's number, or its own
    # identifier (a fragment, an expression) with its body (templates/ops.j2) in decode_text/encode_text
    decoder: str = ""
    encoder: str = ""
    decode_text: str = ""
    encode_text: str = ""
    owner: str = ""  # the class whose member its read_<name> and write_<name> are (the .cc qualifies them so)
    reader: int | None = None  # read_<reader>_ reads its one run and decodes it, if shared
    writer: int | None = None  # write_<writer>_ encodes a value and writes its one run, if shared
    factor: CppFunction | None = None  # the function whose value scales it (scale_exponent, scale_by)
    merge: list[MergeRow] = field(default_factory=list)  # bits: the registers its write merges into
    mask_write: bool = False  # bits written with function 22 (Mask Write Register)
    lowered: Lowered | None = None  # its expression, lowered (None: it has none)

    @property
    def reads_device(self) -> bool:
        return any(step.n for step in self.steps)


class _Builder:
    """The functions of one device as the templates print them, each fact about a function worked out
    once: what functions of the same value IR have alike (no fragment or expression in an IR that has a
    shape, the range tests and whether bits are merged of an encode IR) once per IR shape."""

    def __init__(self, resolved: ResolvedDevice) -> None:
        self.resolved = resolved
        self.ident_of = {f.name: f.ident for f in resolved.functions}
        # (encode shape, type written) -> (range tests, whether the write merges bits)
        self.encodings: dict[tuple[str, str], tuple[list[str] | None, bool]] = {}
        self.fragments: list[CFragment] = []  # every fragment's C++ tree, in the functions' order

    def function(self, f: ResolvedFunction) -> CppFunction:
        """f as the templates print it, but for what depends on other functions (_functions)."""
        fn, codec = f.fn, f.codec
        decode, encode = codec.decode, codec.encode
        read_fragment = expression = write_fragment = None
        if decode is not None and f.decode_shape is None:  # a shape has neither
            read_fragment = ir.find_step(decode, ir.Fragment)
            expression = ir.find_step(decode, ir.Expression)
        mask_write = fn.write_function_code is not None and fn.mask_write  # asked only where a code is given
        # SPEC 5: T is double wherever a fragment applies, for the read and the write alike
        t = "double" if fn.write_function_code and fn.writable and not mask_write else value_type(codec.value_type)
        decode_lines: list[str] = []  # an expression's are printed once its parameters' types are known
        if read_fragment is not None:
            tree = read_fragment.tree.c("c++")
            self.fragments.append(tree)
            decode_lines = tree.body()
        encode_lines: list[str] = []
        tests: list[str] | None = []
        merge: list[MergeRow] = []
        if encode is not None:
            wt = value_type(codec.write_type)
            shape = f.encode_shape
            if shape is None:  # a fragment's
                write_fragment = ir.find_step(encode, ir.Fragment)
                tests = range_tests(ir.find_step(encode, ir.CheckRange), wt)
                merge = merge_rows(codec)
            else:
                known = self.encodings.get((shape, wt))
                if known is None:
                    known = self.encodings[shape, wt] = (
                        range_tests(ir.find_step(encode, ir.CheckRange), wt),
                        ir.find_step(encode, ir.Merge) is not None,
                    )
                tests = known[0]
                if known[1]:
                    merge = merge_rows(codec)
        if write_fragment is not None:
            tree = write_fragment.tree.c("c++")
            self.fragments.append(tree)
            encode_lines = tree.body()
        deps = f.deps
        return CppFunction(
            resolved=f,
            fn=fn,
            ident=f.ident,
            about=ccomment(fn.description) + (f" [{ccomment(fn.units)}]" if fn.units else ""),
            codec=codec,
            t=t,
            n=len(codec.addresses),
            expr=expression is not None,
            rt=f"std::optional<{t}>" if codec.value_type.nullable else t,
            deps=[self.ident_of[d] for d in deps] if deps else [],
            dep_types=[],
            dep_args=[],
            runs=runs_at(TABLE_CONST[f.layout.table], f.runs),
            slots=self.resolved.slots_of(f) if decode is not None else (),
            readable=decode is not None,
            writable=encode is not None,
            status=read_fragment is not None,
            decode_lines=decode_lines,
            encode_lines=encode_lines,
            range_tests=tests,
            int_bits=codec.write_type.bits,
            merge=merge,
            mask_write=mask_write,
            lowered=expression.lowered if expression is not None else None,
        )


def param_type(g: CppFunction) -> str:
    """The type of an expression decoder's parameter naming g: the one the expression language gives
    g (an expression's own type; for a plain function mdl.dsl.expr.fields.plain_type: int64_t for an
    integer, double for a float, a scaled or a fragment's value, bool, std::string). A UINT64 stays
    uint64_t: the expression takes its 64 bits as the long it sees (mdl.targets.cpp.expressions)."""
    if g.expr:
        return g.t
    t = cpp_type(plain_type(g.fn))
    vt = g.codec.value_type
    return "uint64_t" if t == "int64_t" and vt.kind == "int" and vt.bits == 64 and not vt.signed else t


def _functions(resolved: ResolvedDevice) -> tuple[dict[str, CppFunction], list[CFragment]]:
    """Each function by identifier, and the C++ trees of the fragments (mdl.dsl.cfrag.helpers_source)."""
    builder = _Builder(resolved)
    function = builder.function
    out = {f.ident: function(f) for f in resolved.functions}
    ident_of = builder.ident_of
    bodies: dict[Hashable, list[str]] = {}  # an expression's statements by its shape and parameter types
    for f in out.values():
        if not f.deps:  # a scale factor is a dependency too
            f.steps = [f]
        elif f.fn.factor is not None:  # its decoder and encoder take the factor's value as a double
            f.factor = out[ident_of[f.fn.factor]]
            f.steps = [out[g.ident] for g in resolved.closure([f.fn.name])]
            f.dep_types = ["double"]
            f.dep_args = [f"factor_of(%s{f.factor.ident})"]
        else:
            f.steps = [out[g.ident] for g in resolved.closure([f.fn.name])]
            f.dep_types = [param_type(out[d]) for d in f.deps]
            # a value of another type is converted where it is passed, spelled out
            f.dep_args = [
                f"%s{d}" if out[d].t == t else f"std::optional<{t}>(%s{d})"
                for d, t in zip(f.deps, f.dep_types, strict=True)
            ]
        if f.lowered is not None and f.lowered.shape is None:
            f.decode_lines = expr_body(f.lowered, f.dep_types)
        elif f.lowered is not None:  # printed once per shape (equal shapes: equal operations) and parameter types
            key = f.lowered.shape, f.lowered.wide, tuple(f.dep_types)
            lines = bodies.get(key)
            if lines is None:
                lines = bodies[key] = expr_body(f.lowered, f.dep_types)
            f.decode_lines = lines
    return out, builder.fragments


def class_parts(functions: list[CppFunction]) -> list[list[CppFunction]]:
    """The functions of each class of the chain the device's class derives from (CLASS_PART each), or
    none for a device of at most CLASS_PART functions (one class). A write with a scale factor calls the
    factor's read_<name>, which must be a member of its class or of one before: the factors come first."""
    if len(functions) <= CLASS_PART:
        return []
    factors = {id(f.factor) for f in functions if f.factor is not None}
    ordered = [f for f in functions if id(f) in factors] + [f for f in functions if id(f) not in factors]
    head = max(len(factors), CLASS_PART)  # every factor in the first class, however many
    return [ordered[:head]] + [ordered[i : i + CLASS_PART] for i in range(head, len(ordered), CLASS_PART)]


def context(resolved: ResolvedDevice, source_name: str) -> dict[str, Any]:
    device = resolved.device
    file_stem = resolved.stem
    groups, splits = plan_rows(resolved, TABLE_CONST)
    raw_total = resolved.buffer_size
    by_ident, fragments = _functions(resolved)
    functions = list(by_ident.values())
    readable = [by_ident[f.ident] for f in resolved.readable]
    code = {line for f in functions for line in f.decode_lines}  # each distinct line scanned once
    runtime, runtime_includes = helpers("\n".join(code))
    if fragments:
        runtime += "\n" + helpers_source(fragments, "c++")
        runtime_includes += FRAGMENT_INCLUDES["c++"]
    chunks = clike.chunks(readable, lambda f: f.n, lambda f: f.expr)
    class_name = resolved.class_name
    parts_ns = f"{file_stem}_parts"
    parts = class_parts(functions)
    for k, part in enumerate(parts):
        for f in part:
            f.owner = f"{parts_ns}::Part{k}"
    for f in functions if not parts else ():
        f.owner = class_name
    types = {f.t for f in functions} | {f.rt for f in functions}
    needed = clike.ranges(sorted({s for f in readable if not f.expr for s in f.slots}))
    return {
        "device": device,
        "version": __version__,
        "source": source_name,
        "stem": file_stem,
        "generation_macro": generation_macro(file_stem),
        "device_name": ctext(device.name, "kDeviceName", "c++"),
        "class_name": class_name,
        "class_parts": parts,
        "class_part": CLASS_PART,
        "parts_ns": parts_ns,
        "core": f"{parts_ns}::Core" if parts else class_name,  # the class of the requests and shared code
        "guard": f"MDL_{file_stem.upper().rstrip('_')}_H",
        "functions": functions,
        "readable": readable,
        "chunks": chunks,
        "groups": groups,
        "splits": splits,
        "raw_total": raw_total,
        "fragments": bool(fragments),
        "runtime": runtime,
        "needed": needed,
        "fragment_reads": [f for f in readable if f.status],
        "writes_multiple": any(f.writable and f.fn.write_multiple for f in functions),  # FC15/FC16 only
        "mask_writes": any(f.writable and f.mask_write for f in functions),  # FC22
        "factors": any(f.factor is not None for f in functions),
        "exponents": any(f.factor is not None and f.fn.scale_exponent is not None for f in functions),
        "includes": sorted(set(BASE_INCLUDES) | set(runtime_includes)),
        "header_includes": sorted(
            {"array", "cstddef", "cstdint"}
            | ({"optional"} if any("std::optional" in t for t in types) else set())
            | ({"string"} if any("std::string" in t for t in types) else set())
            | ({"vector"} if any("std::vector" in t for t in types) else set())
        ),
    }


def environment() -> jinja2.Environment:
    env = render_environment()
    env.filters["cppfloat"] = lambda x: double_literal(float(x))  # an int bound too in its shortest digits
    env.globals["int_write"] = int_write  # a profile role written to an integer function (roles.j2)
    env.globals["not_provided"] = NOT_PROVIDED_ERRNO
    # the per-function parts of the header and the source, printed in Python
    env.globals["values_members"] = declarations.values_members
    env.globals["function_members"] = declarations.function_members
    env.globals["group_rows"] = definitions.group_rows
    env.globals["split_rows"] = definitions.split_rows
    env.globals["range_rows"] = definitions.range_rows
    env.globals["decode_parts"] = definitions.decode_parts
    env.globals["methods"] = definitions.methods
    return env


def _decode_key(f: CppFunction) -> Hashable | None:
    if not f.readable:
        return None
    if f.resolved.decode_shape is not None:
        return f.resolved.decode_shape, f.n, f.rt
    if f.expr:  # its statements name its registers and parameters by position only
        return "expression", tuple(f.decode_lines), f.n, f.t, f.rt, tuple(f.dep_types)
    return f.ident


def _encode_key(f: CppFunction) -> Hashable | None:
    if not f.writable:
        return None
    if f.resolved.encode_shape is None:
        return f.ident
    return f.resolved.encode_shape, tuple(f.range_tests) if f.range_tests is not None else None, f.int_bits, f.t, f.n


def share(functions: list[CppFunction], env: jinja2.Environment) -> Shared[CppFunction]:
    """Each function's decoder and encoder body, printed by ops.j2 from its IR and shared by the
    functions of the same IR (clike.share); a function whose IR no other has (a fragment, an
    expression) has its own, named after it. ops.j2's codecs prints them whole in device.cc.j2."""
    ops = env.get_template("cpp/templates/ops.j2").module
    decode_body = SharedRendering(ops.decode_body)  # type: ignore[attr-defined]
    encode_body = SharedRendering(ops.encode_body)  # type: ignore[attr-defined]
    return clike.share(
        functions,
        Printing(
            _decode_key,
            _encode_key,
            lambda f: decode_body(f.resolved.decode_shape, f.codec.decode, f.status, f.decode_lines, f.t).rstrip(),
            lambda f: encode_body(
                f.resolved.encode_shape, f.codec.encode, f.range_tests, f.encode_lines, f.int_bits
            ).rstrip(),
            lambda f: f.expr or f.factor is not None,
            lambda f: bool(f.merge) or f.factor is not None,
        ),
    )


def render_files(resolved: ResolvedDevice, source_name: str, interface: Interface | None = None) -> dict[str, str]:
    ctx = context(resolved, source_name)
    env = environment()
    ctx["shared"] = share(ctx["functions"], env)
    ctx["own_codecs"] = [f for f in ctx["functions"] if f.decode_text or f.encode_text]  # ops.j2's codecs
    ctx["profile"] = interface
    ctx["by_name"] = {f.fn.name: f for f in ctx["functions"]} if interface is not None else {}  # roles.j2
    driver = {
        f"{resolved.stem}.h": env.get_template("cpp/templates/device.h.j2").render(**ctx),
        f"{resolved.stem}.cc": env.get_template("cpp/templates/device.cc.j2").render(**ctx),
    }
    if interface is None:
        return driver
    shared = env.get_template("cpp/templates/profile.h.j2").render(iface=interface, version=__version__)
    return check_files(interface, driver, {interface.header: shared})


TARGET = Target("cpp", render_files)
