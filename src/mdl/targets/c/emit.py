"""Resolved device -> C99 driver on libmodbus (<stem>.h / <stem>.c), SPEC section 5, docs/c-api.md.

The templates print the files' skeletons and the decoders and encoders whole (steps.j2: one Jinja
macro per step kind of the value IR, mdl.ir.steps, and `codecs`, each one's comment, head and body);
mdl.targets.c.functions prints the other parts of every function (declarations, reads and writes,
read_all's parts) and mdl.targets.c.plan the read plan's tables.
This module gathers what they print: each function's steps, C types and the registers it reads,
the read plan, and the runtime the driver carries (the .c files of runtime/, fragments' helpers
from mdl.dsl.cfrag, the expression runtime from mdl.targets.c.expressions). Nothing here
allocates at run time: every buffer is an array of a size known when the driver is generated.
"""

from __future__ import annotations

import re
from collections.abc import Hashable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jinja2

from mdl import __version__
from mdl.diagnostics import error
from mdl.dsl.cfrag import INCLUDES as FRAGMENT_INCLUDES
from mdl.dsl.cfrag import CFragment, helpers_source
from mdl.dsl.expr.ops import OpKind
from mdl.ir import steps as ir
from mdl.model import Function
from mdl.resolver import ResolvedDevice, ResolvedFunction
from mdl.targets import clike
from mdl.targets.base import Run, Target, runs_at
from mdl.targets.c import expressions, functions
from mdl.targets.c.plan import plan_tables
from mdl.targets.clike import MergeRow, Printing, Shared, int_bounds, merge_rows
from mdl.targets.profile import NOT_PROVIDED_ERRNO, Interface, check_files, int_write
from mdl.targets.templating import SharedRendering, ctext, double_literal, environment, generation_macro

RUNTIME = Path(__file__).resolve().parent / "runtime"
TABLE_CONST = {"coil": "MDL_COIL", "discrete": "MDL_DISCRETE", "holding": "MDL_HOLDING", "input": "MDL_INPUT"}
BASE_INCLUDES = ("errno.h", "math.h", "stdbool.h", "stddef.h", "stdint.h", "string.h")


def c_double(x: float) -> str:
    """A C literal of a finite double, a negative one in parentheses (templating.double_literal)."""
    return double_literal(x, parenthesized=True)


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


@dataclass(frozen=True)
class RangeCheck:
    """A CheckRange as the template prints it: `low`/`high` are C literals (None: no such bound),
    `never`: no value of the type is within the bounds."""

    low: str | None = None
    high: str | None = None
    never: bool = False


@dataclass(eq=False, slots=True)  # compared by identity: one per function
class CFunction:
    """A function as the C driver prints it: each fact the printers (mdl.targets.c.functions) and the
    templates ask of it, worked out once."""

    rf: ResolvedFunction
    fn: Function
    ident: str
    n: int  # registers (or bits)
    t: str  # C type of the value (char for text)
    wt: str  # C type a write takes
    wt_param: str  # how a write's parameter of that type is declared, up to its name
    param_type: str  # the C type of an expression's parameter naming it (a scalar one is converted to it)
    text_size: int  # text: the array's size (bytes + NUL), else 0
    is_text: bool  # text_size > 0 (an expression's text once its capacity is known)
    nullable: bool
    expr: Any  # expressions.CExpression, or None
    decode: tuple[ir.DecodeStep, ...] | None
    encode: tuple[ir.EncodeStep, ...] | None
    runs: list[Run]
    slots: tuple[int, ...]
    at: int | None  # the first of its slots in read_all's buffer, if they follow each other
    mask_write: bool  # bits written with function 22 (Mask Write Register)
    read_fragment: str | None = None  # the names of its fragment functions
    write_fragment: str | None = None
    range_check: RangeCheck | None = None
    round_check: RangeCheck | None = None
    list_cap: int = 0  # a list (bitset): the capacity of its text as concat prints it, [a, b]
    deps: list[CFunction] = field(default_factory=list)
    steps: list[CFunction] = field(default_factory=list)  # what read_<name> decodes, dependencies first
    reads_device: bool = False  # whether read_<ident> reads registers (of its own or of the functions it needs)
    # its decoder decode_<decoder> and encoder encode_<encoder>: a shared one's number, or its own
    # identifier with its body (templates/steps.j2) in decode_text (not for an expression) and encode_text
    decoder: str = ""
    encoder: str = ""
    decode_text: str = ""
    encode_text: str = ""
    reader: int | None = None  # read_<reader> reads its one run and decodes it, if shared
    writer: int | None = None  # write_<writer> encodes a value and writes its one run, if shared
    factor: CFunction | None = None  # the function whose value scales it (scale_exponent, scale_by)
    merge: list[MergeRow] | tuple[()] = ()  # bits: the registers its write merges into

    @property
    def own_expression(self) -> bool:
        """Whether it prints its own expression decoder, decode_<ident> (no other function has its
        expression's statements, registers and types)."""
        return self.expr is not None and self.decoder == self.ident

    @property
    def fails(self) -> bool:
        """Whether decoding can fail (a fragment's EDOM/ERANGE)."""
        return self.read_fragment is not None


def _param_type(t: str, expr: object, value_kind: str) -> str:
    """The C type of an expression's parameter naming a function of C type t (as the expression sees
    it; a scalar one is converted to it)."""
    if t == "char":
        return "const char *"
    if t.startswith("struct"):
        return f"const {t} *"
    if expr is None and t != "bool":
        return "int64_t " if value_kind == "int" else "double "
    return f"{t} "


def int_literal(value: int, t: str) -> str:
    """A C literal of an integer in a comparison with a value of type t."""
    if t in ("int64_t", "uint64_t") or not -(1 << 31) <= value < (1 << 31):
        if value == -(1 << 63):
            return "(-INT64_C(9223372036854775807) - 1)"
        return f"INT64_C({value})" if value < 0 or t == "int64_t" else f"UINT64_C({value})"
    if t == "uint32_t":
        return f"{value}U" if value >= 0 else str(value)
    return str(value)


def _range_check(minimum: float | None, maximum: float | None, t: str) -> RangeCheck:
    """A CheckRange (or a RoundInt's range) for a value of C type t: an integer is compared with the
    integers nearest inside the bounds, and a test no value of its type can fail is left out
    (-Wtype-limits; clike.int_bounds)."""
    bounds = int_bounds(minimum, maximum, t)
    if bounds is None:
        return RangeCheck(
            None if minimum is None else c_double(minimum),
            None if maximum is None else c_double(maximum),
        )
    return RangeCheck(
        None if bounds.low is None else int_literal(bounds.low, t),
        None if bounds.high is None else int_literal(bounds.high, t),
        bounds.never,
    )


class _RangeChecks:
    """The range checks of a device's functions, each pair of bounds and type worked out once (a
    device repeats a few: _range_check). A check is never changed: functions share one."""

    def __init__(self) -> None:
        self.done: dict[tuple[str, str, str], RangeCheck] = {}

    def __call__(self, minimum: float | None, maximum: float | None, t: str) -> RangeCheck:
        key = (repr(minimum), repr(maximum), t)  # repr: 0.0 and -0.0 (1 and 1.0) print apart
        found = self.done.get(key)
        if found is None:
            found = self.done[key] = _range_check(minimum, maximum, t)
        return found


def _functions(rd: ResolvedDevice) -> list[CFunction]:
    out: dict[str, CFunction] = {}
    stem = rd.stem
    list_type = f"struct {stem}_list"
    checks = _RangeChecks()
    printed: dict[Hashable, list[str]] = {}  # expressions' statements, once per shape (CExpression)
    for rf in rd.functions:
        codec = rf.codec
        vt = codec.value_type
        t = c_type(vt, stem)
        wt = c_type(codec.write_type, stem)
        text_size = vt.nbytes + 1 if vt.kind == "string" else 0
        expr = None
        decode, encode = codec.decode, codec.encode
        slots = rd.slots_of(rf) if decode else ()
        if vt.kind == "expr" and decode is not None:
            step = decode[0]
            assert isinstance(step, ir.Expression)
            expr = expressions.CExpression(rf.ident, step.lowered, list_type, printed)
        fn = rf.fn
        f = CFunction(
            rf=rf,
            fn=fn,
            ident=rf.ident,
            n=len(rf.layout.addresses),
            t=t,
            wt=wt,
            wt_param="const char *" if wt == "char" else wt + " ",
            param_type=_param_type(t, expr, vt.kind),
            text_size=text_size,
            is_text=text_size > 0,
            nullable=vt.nullable,
            expr=expr,
            decode=decode,
            encode=encode,
            runs=runs_at(TABLE_CONST[rf.layout.table], rf.runs),
            slots=slots,
            at=slots[0] if len(slots) == 1 else clike.first_slot(slots),
            mask_write=fn.mask_write,
        )
        if rf.decode_shape is None:  # a fragment or an expression: the shapes of the others have none
            for step in decode or ():
                if isinstance(step, ir.Fragment):
                    f.read_fragment = f"frag_read_{rf.ident}"
        for estep in encode or ():
            if isinstance(estep, ir.Fragment):
                f.write_fragment = f"frag_write_{rf.ident}"
            elif isinstance(estep, ir.CheckRange):
                f.range_check = checks(estep.minimum, estep.maximum, wt)
            elif isinstance(estep, ir.RoundInt):
                f.round_check = checks(estep.low, estep.high, wt)
            elif isinstance(estep, ir.Merge):
                f.merge = merge_rows(codec)
        out[rf.name] = f
    for f in out.values():
        if f.rf.deps:
            f.deps = [out[d] for d in f.rf.deps]
            f.steps = [out[g.name] for g in rd.closure([f.rf.name])]
            f.reads_device = any(step.n for step in f.steps)
        else:
            f.steps = [f]
            f.reads_device = f.n > 0
        if f.fn.factor is not None:
            f.factor = out[f.fn.factor]
    # each expression after the functions it names (whatever their order in the file), so that the
    # text capacity of each text or list parameter is known: its buffers hold its longest value (only
    # where an expression gives a text or a list, or names a text: numbers have no capacity)
    exprs = [f for f in out.values() if f.expr is not None]
    if not any(f.t == "char" or f.expr.type == "list" or any(d.is_text for d in f.deps) for f in exprs):
        exprs = []
    for rf in rd.closure([f.rf.name for f in exprs]) if exprs else ():
        f = out[rf.name]
        if f.expr is None:
            continue
        for i, d in enumerate(f.deps):
            if d.is_text or d.list_cap:
                f.expr.param_caps[f"p{i}"] = d.text_size - 1 if d.is_text else d.list_cap
        if f.t == "char":
            f.text_size = f.expr.result_cap + 1
            f.is_text = True
        elif f.expr.type == "list":
            f.list_cap = f.expr.result_cap
    return list(out.values())


def _fragments(functions: list[CFunction]) -> list[tuple[str, CFragment]]:
    out = []
    for f in functions:
        if f.read_fragment is None and f.write_fragment is None:
            continue
        for steps, name in ((f.decode, f.read_fragment), (f.encode, f.write_fragment)):
            for step in steps or ():
                if isinstance(step, ir.Fragment) and name is not None:
                    out.append((name, step.tree.c("c")))
    return out


def context(rd: ResolvedDevice, source_name: str) -> dict[str, Any]:
    file_stem = rd.stem
    raw_total = rd.buffer_size
    functions = _functions(rd)
    by_name = {f.rf.name: f for f in functions}
    readable = [by_name[rf.name] for rf in rd.readable]
    fragments = _fragments(functions)
    runtime = []
    if raw_total or any(f.n for f in readable):
        runtime.append((RUNTIME / "read_table.c").read_text(encoding="utf-8"))
    if not runtime and any(f.merge and not f.mask_write for f in functions):  # bits read before they are written
        runtime.append((RUNTIME / "read_table.c").read_text(encoding="utf-8"))
    # FC15/FC16 only, or not (function 22 is neither)
    writers = {bool(f.fn.write_multiple) for f in functions if f.encode is not None and not f.mask_write}
    if False in writers:
        runtime.append((RUNTIME / "write_table.c").read_text(encoding="utf-8"))
    if True in writers:
        runtime.append((RUNTIME / "write_multiple.c").read_text(encoding="utf-8"))
    if any(f.mask_write and f.encode is not None for f in functions):
        runtime.append((RUNTIME / "mask_write.c").read_text(encoding="utf-8"))
    if runtime:  # what requests share (a driver of register-less expressions sends none)
        runtime.insert(0, (RUNTIME / "modbus_io.c").read_text(encoding="utf-8"))
    if any(f.factor is not None and f.fn.scale_exponent is not None for f in functions):
        runtime.append((RUNTIME / "power_of_ten.c").read_text(encoding="utf-8"))
    includes = set(BASE_INCLUDES)
    if fragments:
        runtime.append(helpers_source([c for _, c in fragments], "c"))
        includes |= set(FRAGMENT_INCLUDES["c"])
    exprs = [f.expr for f in functions if f.expr is not None]
    if exprs:
        runtime.append(expressions.runtime(exprs))
        includes |= {"stdio.h", "stdlib.h"}
    list_bits = max(
        [16 * op.data["count"] for e in exprs for op in e.lowered.ops if op.kind is OpKind.BITSET], default=0
    )
    return {
        "device": rd.device,
        "version": __version__,
        "source": source_name,
        "stem": file_stem,
        "generation_macro": generation_macro(file_stem),
        "guard": f"MDL_{file_stem.upper().rstrip('_')}_C_H",
        "functions": functions,
        "readable": readable,
        "by_name": by_name,  # a profile role's function (roles.j2)
        "plan": plan_tables(rd, TABLE_CONST),
        "raw_total": raw_total,
        "chunks": clike.chunks(readable, lambda f: f.n, lambda f: f.expr is not None),
        "needed": clike.ranges(sorted({s for f in readable if f.expr is None for s in f.slots})),
        "fragment_reads": [f for f in readable if f.fails],
        "runtime": runtime,
        "fragments": [(name, c.function(name)) for name, c in fragments],
        "includes": sorted(includes),
        "c_double": c_double,
        "list_bits": list_bits,
        # a name too long for a C99 string literal is a char array defined in the .c (templating.ctext)
        "device_name": ctext(rd.device.name, f"{file_stem}_device_name", "c"),
    }


def _check_key(check: RangeCheck | None) -> tuple[str | None, str | None, bool] | None:
    return None if check is None else (check.low, check.high, check.never)


def _decode_key(f: CFunction) -> Hashable | None:
    if f.decode is None:
        return None
    if f.expr is not None:  # its statements name its registers and parameters by position only
        return "expression", tuple(f.expr.body()), f.n, f.t, tuple(d.param_type for d in f.deps)
    return (f.rf.decode_shape, f.t, f.n, f.text_size, f.nullable) if f.rf.decode_shape is not None else f.ident


def _encode_key(f: CFunction) -> Hashable | None:
    if f.encode is None:
        return None
    if f.rf.encode_shape is None:
        return f.ident
    return f.rf.encode_shape, f.wt, _check_key(f.range_check), _check_key(f.round_check), f.n


def share(functions: list[CFunction], env: jinja2.Environment) -> Shared[CFunction]:
    """Each function's decoder and encoder body, printed by steps.j2 from its IR and shared by the
    functions of the same IR (clike.share); a function whose IR no other has (a fragment) has its
    own, named after it. steps.j2's codecs prints them whole in device.c.j2, an expression's decoder
    with its statements from mdl.targets.c.expressions."""
    steps = env.get_template("c/templates/steps.j2").module
    decoder = SharedRendering(steps.decoder)  # type: ignore[attr-defined]
    encoder = SharedRendering(steps.encoder)  # type: ignore[attr-defined]
    return clike.share(
        functions,
        Printing(
            _decode_key,
            _encode_key,
            lambda f: decoder(f.rf.decode_shape, f.decode, f.t, f.read_fragment) if f.expr is None else "",
            lambda f: encoder(f.rf.encode_shape, f.encode, f.wt, f.range_check, f.round_check, f.write_fragment),
            lambda f: f.expr is not None,
            lambda f: bool(f.merge) or f.factor is not None,
        ),
    )


def render_resolved(rd: ResolvedDevice, source_name: str, interface: Interface | None = None) -> dict[str, str]:
    ctx = context(rd, source_name)
    env = environment()
    env.tests["instance_of"] = lambda obj, name: type(obj).__name__ == name
    env.globals.update(ctx)
    all_functions: list[CFunction] = ctx["functions"]
    shared = share(all_functions, env)
    ccomment = env.filters["ccomment"]
    stem = ctx["stem"]
    sizes, members, declarations = functions.header(all_functions, ctx["readable"], stem, ccomment)
    env.globals.update(
        sizes=sizes,
        members=members,
        declarations=declarations,
        shared=shared,  # the decoders and encoders, printed whole by steps.j2's codecs with each function's own
        own_codecs=[f for f in all_functions if f.own_expression or f.decode_text or f.encode_text],
        accessors=functions.Accessors(stem, ccomment).print(all_functions, shared),
        read_all_parts=functions.read_all_parts(ctx["chunks"], stem),
    )
    env.globals["profile"] = interface
    env.globals["int_write"] = int_write  # a profile role written to an integer function (roles.j2)
    env.globals["not_provided"] = NOT_PROVIDED_ERRNO
    driver = {
        f"{stem}.h": env.get_template("c/templates/device.h.j2").render(),
        f"{stem}.c": env.get_template("c/templates/device.c.j2").render(),
    }
    if interface is None:
        return driver
    _check_profile_names(interface, rd, driver)
    shared_header = env.get_template("c/templates/profile.h.j2").render(iface=interface, version=__version__)
    return check_files(interface, driver, {interface.header: shared_header})


def _check_profile_names(interface: Interface, rd: ResolvedDevice, driver: dict[str, str]) -> None:
    """`struct mdl_<profile>` must not be a struct or enum the driver defines (`mdl_table`), nor
    `<stem>_<profile>` one of its functions (`<stem>_init`, `<stem>_read_<name>`)."""
    tag = f"mdl_{interface.name}"
    if any(re.search(rf"\b(?:struct|enum|union)\s+{tag}\s*\{{", text) for text in driver.values()):
        raise error(f"profile {interface.name}: the C driver's own code has a struct or enum {tag}: rename the profile")
    fill = f"{rd.stem}_{interface.name}"
    own = {f"{rd.stem}_{name}" for name in ("init", "read_all", "driver_read_all", "device_name")}
    own |= {f"{rd.stem}_{verb}_{f.ident}" for f in rd.functions for verb in ("read", "write")}
    if fill in own:
        raise error(f"profile {interface.name}: the C driver has a {fill} of its own: rename the profile")


TARGET = Target("c", render_resolved)
