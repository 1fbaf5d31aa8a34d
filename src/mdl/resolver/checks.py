"""Checks an XSD cannot make: numbers that are not finite, duplicate names, where values live,
fragments, expressions, ranges.

Positions come from where the source recorded each text (mdl.diagnostics.span_of): an error inside
an expression or a fragment points at its column in the file; a model built in code has none.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

from mdl.diagnostics import Diagnostic, span_of
from mdl.ir.build import int_range
from mdl.model import READ_ONLY_TABLES, Device, Function
from mdl.model.layout import Layout, LayoutError, layout
from mdl.resolver.packing import mask_write, packing_problems

if TYPE_CHECKING:
    from mdl.dsl.expr.fields import Compiled

FLOAT_FIELDS = ("multiplier", "offset", "minimum", "maximum")  # every float element of MDL 1.0


class Report(Protocol):
    """Records a diagnostic about a function (at its element `key`, `offset` characters into its text)."""

    def __call__(self, fn: Function, message: str, severity: str = "error", key: str = "", offset: int = 0) -> None: ...


def position(owner: object, key: str = "", offset: int = 0, line: int | None = None) -> tuple[int | None, int | None]:
    """(line, column) in the file of `owner`'s text `key` ("": the owner's own element), `offset`
    characters in; the owner's line without a column where the source recorded no position."""
    span = span_of(owner, key) if key else None
    if span is not None:
        return span.at(offset)
    span = span_of(owner, "")
    if span is not None:
        return span.line, span.col
    return line, None


def check_device(
    device: Device,
    path: str | None = None,
    layouts: dict[str, Layout] | None = None,
    compiled: dict[str, Compiled] | None = None,
) -> list[Diagnostic]:
    """Every problem of the device, in file order; the device is left as it is. `layouts`, when given,
    receives the layout of each function without an expression that has one, and `compiled` each
    expression that compiles (the resolve step keeps them)."""
    out: list[Diagnostic] = []
    compiled = {} if compiled is None else compiled

    def err(fn: Function, message: str, severity: str = "error", key: str = "", offset: int = 0) -> None:
        line, col = position(fn, key, offset, fn.line)
        out.append(Diagnostic(path, line, col, f"function '{fn.name}': {message}", severity))

    infinite = [fn for fn in device.functions if not_finite(fn, err)]
    if infinite:  # nothing below is meant for such numbers
        return out
    seen: dict[str, int | None] = {}
    for fn in device.functions:
        if fn.name in seen:
            err(fn, f"duplicate function name (first defined on line {seen[fn.name]})")
        else:
            seen[fn.name] = fn.line
    by_name = {fn.name: fn for fn in device.functions}
    if any(fn.expression is not None for fn in device.functions):  # the expression compiler, when needed
        from mdl.dsl.expr.fields import compile_device

        for problem in compile_device(device, compiled):
            out.append(_expression_problem(problem.function, problem.message, problem.col, path))
    for fn in device.functions:
        if fn.expression is not None:
            _check_expression_function(fn, compiled.get(fn.name), err)
            continue
        try:
            lay = layout(fn)
        except LayoutError as exc:
            err(fn, str(exc))
            continue
        if layouts is not None:
            layouts[fn.name] = lay
        if fn.access in ("write", "read_write") and fn.table in READ_ONLY_TABLES:
            err(fn, f"access '{fn.access}' is impossible: the {fn.table} table is read-only")
        if fn.read_function_code is not None or fn.write_function_code is not None:
            _check_fragments(fn, lay, err)
        if fn.read_function_code is not None and lay.kind in ("string", "bool"):
            err(fn, f"a fragment computes a number; format {fn.eff_format} cannot use one")
        if fn.write_function_code is not None and lay.kind == "string":
            err(fn, "a write fragment takes a number; format STRING cannot use one")
        if fn.multiplier == 0 and not fn.read_function_code:
            err(fn, "multiplier 0 reads every value as the offset and can write none")
        for message in bound_problems(fn, lay):
            err(fn, message)
        for message, severity, key in packing_problems(fn, lay, by_name):
            err(fn, message, severity, key)
        for message, severity in marker_problems(fn, lay):
            err(fn, message, severity)
        for token in fn.not_implemented or ():
            digits = len(token) - 2
            if digits > 4 and digits > 4 * len(lay.addresses):
                err(fn, f"not_implemented value {token} is wider than the function's {len(lay.addresses)} register(s)")
    out += check_tests(device, path)
    return sorted(out, key=_in_file_order)


def _check_fragments(fn: Function, lay: Layout, err: Report) -> None:
    """Report the fragments (read_function_code, write_function_code) that do not check."""
    for attr, code in (
        ("read_function_code", fn.read_function_code),
        ("write_function_code", fn.write_function_code),
    ):
        if code is None or (attr == "write_function_code" and mask_write(fn)):
            continue
        from mdl.dsl.cfrag import FragmentError, check  # the fragment checker, when needed

        try:
            check(code, len(lay.addresses))
        except FragmentError as exc:
            err(
                fn,
                f"{attr}: {exc}" + (f" (column {exc.col})" if exc.col else ""),
                key=attr,
                offset=(exc.col or 1) - 1,
            )


def _in_file_order(diag: Diagnostic) -> tuple[bool, int, int]:
    return diag.line is None, diag.line or 0, diag.col or 0


def not_finite(fn: Function, err: Report) -> bool:
    """Report each float of `fn` that is infinite or NaN (no target can compute with one)."""
    if fn.multiplier is None and fn.offset is None and fn.minimum is None and fn.maximum is None:
        return False  # most functions have none of the four FLOAT_FIELDS
    bad = False
    for attr in FLOAT_FIELDS:
        value = getattr(fn, attr)
        if value is not None and not math.isfinite(value):
            text = "NaN" if math.isnan(value) else ("INF" if value > 0 else "-INF")
            err(fn, f"<{attr}> {text} is not a finite number", key=attr)
            bad = True
    return bad


def _expression_problem(fn: Function, message: str, col: int | None, path: str | None) -> Diagnostic:
    """An expression's problem at its column in the file; the source may name the function its own way
    (the Toolkit's "field 'x' of block 'y'")."""
    span = span_of(fn, "expression")
    if span is None:  # no position for the text: the column inside the expression goes into the message
        where = f" (column {col})" if col else ""
        return Diagnostic(
            path, fn.expression_line or fn.line, None, f"function '{fn.name}': expression: {message}{where}"
        )
    line, file_col = span.at((col or 1) - 1)
    subject = span.label or f"function '{fn.name}': expression"
    return Diagnostic(path, line, file_col, f"{subject}: {message}")


def bound_problems(fn: Function, lay: Layout) -> list[str]:
    """minimum/maximum that mean nothing: any on text, or crossed ones.

    A bound that excludes one of a bit's values is allowed: a coil that only accepts 1 is a trigger."""
    if fn.minimum is None and fn.maximum is None:  # most functions
        return []
    bounds = [(attr, value) for attr, value in (("minimum", fn.minimum), ("maximum", fn.maximum)) if value is not None]
    if lay.kind == "string":
        return [
            f"{attr} {value:g} cannot apply to a STRING value: text has no order to bound" for attr, value in bounds
        ]
    if fn.minimum is not None and fn.maximum is not None and fn.minimum > fn.maximum:
        return [f"minimum {fn.minimum:g} is above maximum {fn.maximum:g}"]
    return []


def marker_problems(fn: Function, lay: Layout) -> list[tuple[str, str]]:
    """Markers no device can read (SPEC 10 compares them with the raw value: the registers composed
    by format and order, before multiplier, offset and fragment) and write_multiple where nothing
    is written."""
    out: list[tuple[str, str]] = []
    if fn.marker is not None:
        if lay.kind == "string":
            out.append(("a marker is a number; format STRING cannot carry one", "error"))
        elif lay.kind in ("int", "bool"):
            low, high = (0, 1) if lay.kind == "bool" else int_range(lay)
            out += [
                (f"marker {m} can never be read: the raw value is {low}..{high}", "error")
                for m in fn.marker
                if not low <= m <= high
            ]
    if fn.write_multiple and not fn.writable:
        out.append(("write_multiple on a function that cannot be written does nothing", "warning"))
    return out


def _check_expression_function(fn: Function, compiled: Compiled | None, err: Report) -> None:
    if compiled is None:
        return
    lay = compiled.lowered
    if fn.register_type and lay.table and fn.register_type != lay.table:
        err(fn, f"register_type {fn.register_type} but the expression reads the {lay.table} table")
    if fn.access in ("write", "read_write"):
        err(fn, "a function computed by an expression can only be read")
    for attr in (
        "read_function_code",
        "write_function_code",
        "not_implemented",
        "marker",
        "bits",
        "scale_exponent",
        "scale_by",
        "initial",
    ):
        if getattr(fn, attr) is not None:
            err(fn, f"{attr} cannot be combined with an expression")
    if fn.addresses and sorted(fn.addresses) != lay.addresses:
        err(
            fn,
            f"addresses {' '.join(map(str, fn.addresses))} differ from the registers the expression reads "
            f"({' '.join(map(str, lay.addresses)) or 'none'})",
            "warning",
        )


def check_tests(device: Device, path: str | None) -> list[Diagnostic]:
    """Scenario references: every expected function exists and is readable."""
    out: list[Diagnostic] = []
    names = {fn.name: fn for fn in device.functions}
    for sc in device.tests:
        for name in sc.expected:
            if name not in names:
                out.append(Diagnostic(path, *position(sc, line=sc.line), f"test '{sc.id}': no function '{name}'"))
    return out
