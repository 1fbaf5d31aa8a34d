"""Resolved device -> C99 driver on libmodbus (<stem>.h / <stem>.c), SPEC section 5, docs/c-api.md.

The templates print each function's value IR (mdl.values.ir) with one Jinja macro per step kind;
this module only gathers what they print: each function's steps, C types and the registers it
reads, the read plan, and the runtime the driver carries (the .c files of runtime/, fragments'
helpers from mdl.lang.cfrag, the expression runtime from mdl.targets.c.expressions). Nothing here
allocates at run time: every buffer is an array of a size known when the driver is generated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mdl import __version__
from mdl.lang.cfrag import INCLUDES as FRAGMENT_INCLUDES
from mdl.lang.cfrag import CFragment, helpers_source
from mdl.lang.cfrag.cemit import float_literal
from mdl.resolve import ResolvedDevice, ResolvedFunction
from mdl.targets.base import Target, plan_rows
from mdl.targets.c import expressions
from mdl.targets.templating import environment
from mdl.values import ir

RUNTIME = Path(__file__).resolve().parent / "runtime"
TABLE_CONST = {"coil": "MDL_COIL", "discrete": "MDL_DISCRETE", "holding": "MDL_HOLDING", "input": "MDL_INPUT"}
BASE_INCLUDES = ("errno.h", "math.h", "stdbool.h", "stddef.h", "stdint.h", "string.h")


def c_double(x: float) -> str:
    """A C literal of a finite double (the generator refuses non-finite numbers before this)."""
    if not math.isfinite(x):
        raise ValueError(f"{x} cannot be a C literal")
    text = float_literal(abs(x), "double")
    return f"(-{text})" if math.copysign(1.0, x) < 0 else text


def c_type(vt: ir.ValueType, stem: str) -> str:
    """The C type of a value (for text: its char, the member is an array of nbytes + 1)."""
    if vt.kind == "expr":
        return expressions.C_TYPES[vt.expr_type].format(stem=stem)
    if vt.kind == "int":
        return f"{'' if vt.signed else 'u'}int{vt.bits}_t"
    if vt.kind == "float":
        return "float" if vt.bits == 32 else "double"
    if vt.kind == "string":
        return "char"
    return "bool"


@dataclass
class RangeCheck:
    """A CheckRange as the template prints it: `low`/`high` are C literals (None: no such bound),
    `never`: no value of the type is within the bounds."""

    low: str | None = None
    high: str | None = None
    never: bool = False


@dataclass
class CFunction:
    rf: ResolvedFunction
    ident: str
    n: int  # registers (or bits)
    t: str  # C type of the value (char for text)
    wt: str  # C type a write takes
    text_size: int  # text: the array's size (bytes + NUL), else 0
    nullable: bool
    expr: Any  # expressions.CExpression, or None
    decode: tuple[ir.DecodeStep, ...] | None
    encode: tuple[ir.EncodeStep, ...] | None
    runs: list[tuple[str, int, int]]
    slots: list[int]
    read_fragment: str | None = None  # the names of its fragment functions
    write_fragment: str | None = None
    range_check: RangeCheck | None = None
    round_check: RangeCheck | None = None
    list_type: str = ""
    deps: list[CFunction] = field(default_factory=list)
    steps: list[CFunction] = field(default_factory=list)  # what read_<name> decodes, dependencies first

    @property
    def fn(self) -> Any:
        return self.rf.fn

    @property
    def is_text(self) -> bool:
        return self.text_size > 0

    @property
    def params(self) -> str:
        """The parameters of decode_<ident>."""
        out = ["const uint16_t *r"] + (["const bool *present"] if self.expr is not None else [])
        for i, d in enumerate(self.deps):
            out += [f"{_param_type(d, self.list_type)}p{i}", f"bool p{i}_has"]
        out.append(f"{self.t} *out")
        return ", ".join(out + ["bool *has"])

    def call_args(self, mode: str, target: str, has_target: str) -> str:
        """The arguments of a call of decode_<ident> in read_<ident> (mode single: the values it needs
        are v_<name>) or in read_all (mode all: values.<name>)."""
        out = ["r"] + (["present"] if self.expr is not None else [])
        for d in self.deps:
            value = f"v_{d.ident}" if mode == "single" else f"values.{d.ident}"
            if d.expr is None and d.t not in ("char", "bool"):
                value = f"(int64_t){value}" if d.rf.codec.value_type.kind == "int" else f"(double){value}"
            elif d.t.startswith("struct"):
                value = "&" + value
            has = f"v_{d.ident}_has" if mode == "single" else f"values.has_{d.ident}" if d.nullable else "true"
            out += [value, has]
        out.append(target if self.is_text else "&" + target)
        return ", ".join(out + [has_target])

    @property
    def fails(self) -> bool:
        """Whether decoding can fail (a fragment's EDOM/ERANGE)."""
        return self.read_fragment is not None


def _param_type(d: CFunction, list_type: str) -> str:
    """The C type of an expression's parameter naming function d (as the expression sees it)."""
    if d.t == "char":
        return "const char *"
    if d.t.startswith("struct"):
        return f"const {d.t} *"
    if d.expr is None and d.t != "bool":
        return "int64_t " if d.rf.codec.value_type.kind == "int" else "double "
    return f"{d.t} "


def _int_limits(t: str) -> tuple[int, int] | None:
    if t == "bool":
        return 0, 1
    if not t.endswith("_t"):
        return None
    bits = int(t.rstrip("_t").lstrip("uint"))
    return (0, (1 << bits) - 1) if t.startswith("u") else (-(1 << (bits - 1)), (1 << (bits - 1)) - 1)


def int_literal(value: int, t: str) -> str:
    """A C literal of an integer in a comparison with a value of type t."""
    if t in ("int64_t", "uint64_t") or not -(1 << 31) <= value < (1 << 31):
        if value == -(1 << 63):
            return "(-INT64_C(9223372036854775807) - 1)"
        return f"INT64_C({value})" if value < 0 or t == "int64_t" else f"UINT64_C({value})"
    if t == "uint32_t":
        return f"{value}U" if value >= 0 else str(value)
    return str(value)


def _range_check(step: ir.CheckRange, t: str) -> RangeCheck:
    """A CheckRange for a value of C type t: an integer is compared with the integers nearest inside the
    bounds, and a test no value of its type can fail is left out (-Wtype-limits)."""
    limits = _int_limits(t)
    out = RangeCheck()
    for bound, side in ((step.minimum, "low"), (step.maximum, "high")):
        if bound is None:
            continue
        if limits is None:
            setattr(out, side, c_double(bound))
            continue
        edge = math.ceil(bound) if side == "low" else math.floor(bound)
        if (edge > limits[1]) if side == "low" else (edge < limits[0]):
            out.never = True
        elif (edge > limits[0]) if side == "low" else (edge < limits[1]):
            setattr(out, side, int_literal(edge, t))
    return out


def _functions(rd: ResolvedDevice) -> list[CFunction]:
    out: dict[str, CFunction] = {}
    list_type = f"struct {rd.stem}_list"
    for rf in rd.functions:
        codec = rf.codec
        vt = codec.value_type
        text_size = vt.nbytes + 1 if vt.kind == "string" else 0
        expr = None
        if vt.kind == "expr" and codec.decode is not None:
            step = codec.decode[0]
            assert isinstance(step, ir.Expression)
            expr = expressions.CExpression(rf.ident, step.lowered, list_type)
        f = CFunction(
            rf=rf, ident=rf.ident, n=len(rf.layout.addresses), t=c_type(vt, rd.stem),
            wt=c_type(codec.write_type, rd.stem),
            text_size=text_size, nullable=vt.nullable, expr=expr, decode=codec.decode, encode=codec.encode,
            runs=[(TABLE_CONST[rf.layout.table], s, c) for s, c in rf.layout.runs],
            slots=list(rd.slots_of(rf)) if codec.decode else [])
        for step in codec.decode or ():
            if isinstance(step, ir.Fragment):
                f.read_fragment = f"frag_read_{rf.ident}"
        for estep in codec.encode or ():
            if isinstance(estep, ir.Fragment):
                f.write_fragment = f"frag_write_{rf.ident}"
            if isinstance(estep, ir.CheckRange):
                f.range_check = _range_check(estep, f.wt)
            if isinstance(estep, ir.RoundInt):
                f.round_check = _range_check(ir.CheckRange(estep.low, estep.high), f.wt)
        f.list_type = list_type
        out[rf.name] = f
    for f in out.values():
        f.deps = [out[d] for d in f.rf.deps]
        f.steps = [out[g.name] for g in rd.closure([f.rf.name])] if f.deps else [f]
    for f in out.values():  # in declaration order, so a text parameter's capacity is known
        if f.expr is not None:
            for i, d in enumerate(f.deps):
                if d.is_text:
                    f.expr.param_caps[f"p{i}"] = d.text_size - 1
            f.text_size = f.expr.result_size if f.t == "char" else 0
    return list(out.values())


def _fragments(functions: list[CFunction]) -> list[tuple[str, CFragment]]:
    out = []
    for f in functions:
        for steps, name in ((f.decode, f.read_fragment), (f.encode, f.write_fragment)):
            for step in steps or ():
                if isinstance(step, ir.Fragment) and name is not None:
                    out.append((name, step.tree.c("c")))
    return out


def context(rd: ResolvedDevice, source_name: str) -> dict[str, Any]:
    file_stem = rd.stem
    groups, splits = plan_rows(rd, TABLE_CONST)
    raw_total = rd.buffer_size
    functions = _functions(rd)
    by_name = {f.rf.name: f for f in functions}
    readable = [by_name[rf.name] for rf in rd.readable]
    fragments = _fragments(functions)
    runtime = [(RUNTIME / "modbus_io.c").read_text(encoding="utf-8")]
    if raw_total or any(f.n for f in readable):
        runtime.append((RUNTIME / "read_table.c").read_text(encoding="utf-8"))
    writers = {bool(f.fn.write_multiple) for f in functions if f.encode is not None}  # FC15/FC16 only, or not
    if False in writers:
        runtime.append((RUNTIME / "write_table.c").read_text(encoding="utf-8"))
    if True in writers:
        runtime.append((RUNTIME / "write_multiple.c").read_text(encoding="utf-8"))
    includes = set(BASE_INCLUDES)
    if fragments:
        runtime.append(helpers_source([c for _, c in fragments], "c"))
        includes |= set(FRAGMENT_INCLUDES["c"])
    exprs = [f.expr for f in functions if f.expr is not None]
    if exprs:
        runtime.append(expressions.runtime(exprs))
        includes |= {"stdio.h", "stdlib.h"}
    list_bits = max([16 * op.data["count"] for e in exprs for op in e.lowered.ops if op.kind == "bitset"], default=0)
    return {
        "device": rd.device, "version": __version__, "source": source_name, "stem": file_stem,
        "guard": f"MDL_{file_stem.upper().rstrip('_')}_C_H", "functions": functions, "readable": readable,
        "groups": groups, "splits": splits, "raw_total": raw_total, "runtime": runtime,
        "fragments": [(name, c.function(name)) for name, c in fragments], "includes": sorted(includes),
        "c_double": c_double, "list_bits": list_bits,
    }


def render_resolved(rd: ResolvedDevice, source_name: str) -> dict[str, str]:
    ctx = context(rd, source_name)
    env = environment()
    env.tests["instance_of"] = lambda obj, name: type(obj).__name__ == name
    env.globals.update(ctx)
    return {f"{ctx['stem']}.h": env.get_template("c/templates/device.h.j2").render(),
            f"{ctx['stem']}.c": env.get_template("c/templates/device.c.j2").render()}


TARGET = Target("c", render_resolved)
