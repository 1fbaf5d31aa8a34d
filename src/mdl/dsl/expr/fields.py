"""Compile the expressions of a device: resolve field references within each block, order the
fields so that every field comes after those it names, type-check and lower each expression."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

from mdl.model import CompiledExpression, Device, Function, Value
from mdl.model.layout import MAX_REGISTERS

if TYPE_CHECKING:
    from mdl.dsl.expr.lower import Lowered
    from mdl.dsl.expr.nodes import Node
    from mdl.dsl.expr.parser import FieldIndex

# The parser, the lowering and the Python printer are imported by the functions that use them: the
# runtime imports this module for python_function, and a device without expressions (every raw read)
# never needs them.

# a translated expression: (the function's registers, ascending, None where missing; p0, p1, ...) -> value
FieldFunction = Callable[..., Value]


@dataclass
class Compiled:
    lowered: Lowered
    deps: list[str]  # function names, in parameter order (p0, p1, ...)

    @property
    def type(self) -> str:
        return self.lowered.type


@dataclass
class FieldError:
    function: Function
    message: str
    col: int | None


def plain_type(fn: Function) -> str:
    """The expression type of a function without an expression."""
    from mdl.model.layout import layout

    kind = layout(fn).kind
    if fn.read_function_code or kind == "float" or (kind == "int" and (fn.scales or fn.factor is not None)):
        return "double"
    span = fn.bit_range if kind == "int" else None
    if span is not None and span[0] == span[1]:
        return "bool"  # one bit of a register (SPEC 2.2 bits)
    return {"int": "long", "string": "string", "bool": "bool"}[kind]


def _unusable(fn: Function) -> str | None:
    """Why an expression cannot name fn, or None: it must be read, and give every target its exact
    value (a 64-bit integer with a write fragment is a double in the C++ driver, SPEC 5)."""
    if not fn.readable:
        return f"cannot be read (access '{fn.eff_access}')"
    if fn.expression is None and fn.write_function_code and fn.writable:
        from mdl.model.layout import LayoutError, layout

        try:
            lay = layout(fn)
        except LayoutError:
            return None  # reported as its own error
        if lay.kind == "int" and lay.bits > 53 and not fn.scales and not fn.read_function_code:
            return (
                "has a write fragment: its value is a double in the C++ driver (SPEC 5), which "
                f"cannot hold every {lay.bits}-bit integer an expression computes with"
            )
    return None


def _plain_uint64(fn: Function) -> bool:
    """Whether an expression sees fn as an unsigned 64-bit integer (a UINT64 without scaling): its
    value may not fit the long it becomes there."""
    from mdl.model.layout import layout

    if fn.expression is not None or plain_type(fn) != "long":
        return False
    lay = layout(fn)
    return lay.bits == 64 and not lay.signed


def compile_device(device: Device, into: dict[str, Compiled]) -> list[FieldError]:
    """Compile every expression function into `into` (its name -> Compiled; the model is left as it
    is); return the problems found."""
    from mdl.dsl.expr.lower import lower, scan
    from mdl.dsl.expr.nodes import ExprError
    from mdl.dsl.expr.parser import MAX_DEPTH, FieldIndex, parse

    errors: list[FieldError] = []
    blocks: dict[str, dict[str, Function]] = {}
    for fn in device.functions:
        blocks.setdefault(fn.block, {})[fn.field_id] = fn
    parsed: dict[str, Node] = {}
    indexes: dict[str, FieldIndex] = {}  # block -> the index of its field ids
    alike: dict[frozenset[str], FieldIndex] = {}  # blocks of the same field ids share one index
    trees: dict[tuple[str, int], Node] = {}  # (text, id of its index) -> its tree (never changed after parsing)
    for fn in device.functions:
        if fn.expression is None:
            continue
        index = indexes.get(fn.block)
        if index is None:
            ids = frozenset(blocks[fn.block])
            index = alike.get(ids)
            if index is None:
                index = alike[ids] = FieldIndex(ids)
            indexes[fn.block] = index
        key = (fn.expression, id(index))
        tree = trees.get(key)
        if tree is None:
            try:
                tree = trees[key] = parse(fn.expression, index)
            except ExprError as exc:
                errors.append(FieldError(fn, str(exc), exc.col))
                continue
        parsed[fn.name] = tree
    done: dict[str, str] = {}  # name -> type, for compiled or plain functions
    chain: dict[str, int] = {}  # name -> how many fields deep its references go
    too_deep: set[str] = set()
    visiting: set[str] = set()
    erred: set[str] = set()  # names with an error, of errors[:seen]
    seen = 0
    lowered_before: dict[Hashable, Lowered] = {}  # shape -> an expression of that shape (lower)

    def refuse_depth(fn: Function) -> None:
        too_deep.add(fn.name)
        errors.append(FieldError(fn, f"fields refer to each other more than {MAX_DEPTH} deep", 1))

    def visit(fn: Function, depth: int = 0) -> str | None:
        nonlocal seen
        if fn.name in done:
            return done[fn.name]
        if fn.name in too_deep:
            return None
        if depth > MAX_DEPTH:  # checked going down, so this recursion stays shallow
            refuse_depth(fn)
            return None
        if fn.expression is None:
            try:
                done[fn.name] = plain_type(fn)
            except (ValueError, KeyError):
                return None
            return done[fn.name]
        if fn.name not in parsed or fn.name in visiting:
            if fn.name in visiting:
                errors.append(FieldError(fn, "the expression refers to itself through other fields", 1))
            return None
        visiting.add(fn.name)
        scanned = scan(parsed[fn.name])
        refs = scanned.refs
        types: dict[str, str] = {}
        block = blocks[fn.block]
        for ref in refs:
            unusable = _unusable(block[ref])
            if unusable:
                visiting.discard(fn.name)
                errors.append(FieldError(fn, f"field '{ref}' it refers to {unusable}", None))
                return None
            t = visit(block[ref], depth + 1)
            if t is None:
                visiting.discard(fn.name)
                erred.update(e.function.name for e in errors[seen:])  # only those added since: linear
                seen = len(errors)
                if fn.name not in erred:
                    errors.append(FieldError(fn, f"field '{ref}' it refers to has an error", None))
                return None
            types[ref] = t
        visiting.discard(fn.name)
        chain[fn.name] = 1 + max((chain.get(block[r].name, 0) for r in refs), default=0)
        if chain[fn.name] > MAX_DEPTH:  # and coming up, whatever order the fields were visited in
            refuse_depth(fn)
            return None
        try:
            limit = device.max_registers or MAX_REGISTERS
            lowered = lower(parsed[fn.name], types, limit, lowered_before, scanned)
        except ExprError as exc:
            errors.append(FieldError(fn, str(exc), exc.col))
            return None
        lowered.wide = tuple(i for i, r in enumerate(lowered.refs) if _plain_uint64(block[r]))
        into[fn.name] = Compiled(lowered, [block[r].name for r in lowered.refs])
        done[fn.name] = lowered.type
        return lowered.type

    for fn in device.functions:
        if fn.expression is not None:
            visit(fn)
    return errors


def python_source(lowered: Lowered, func_name: str = "_field") -> str:
    from mdl.dsl.expr.pyemit import body, signature

    lines = [f"def {func_name}({signature(lowered)}):"] + ["    " + line for line in body(lowered)]
    return "\n".join(lines) + "\n"


@cache
def _helpers() -> dict[str, Any]:
    """The globals a translated expression runs in: the fragment helpers and the expression ones (the two
    files pyemit.HELPERS_SOURCE joins), imported once as their modules, where their text was compiled again
    for every expression."""
    from mdl.dsl.cfrag.pyemit import helpers_namespace
    from mdl.dsl.expr import pyhelpers

    return {**helpers_namespace(), **vars(pyhelpers)}


@cache
def _namespace_for(source: str) -> FieldFunction:
    ns = dict(_helpers())
    exec(compile(source, "<mdl expression>", "exec"), ns)
    field: FieldFunction = ns["_field"]
    return field


def python_function(compiled: CompiledExpression) -> FieldFunction:
    return _namespace_for(python_source(compiled.lowered))
