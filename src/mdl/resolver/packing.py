"""Checks of the MDL 1.0 elements that pack values into registers or scale them by another register
(SPEC 2.2: `bits`, `scale_exponent`, `scale_by`) and of `initial` and `role` (docs/bits-and-scale.md)."""

from __future__ import annotations

import re
from collections.abc import Mapping

from mdl.model import BIT_TABLES, Function
from mdl.model.layout import Layout, LayoutError, layout

# (message, severity, the element it is about)
Problem = tuple[str, str, str]
# a pattern's text, compiled where it is used (re.compile keeps it): no compiling at import (issue 40)
_ROLE = r"[A-Za-z_][A-Za-z0-9_]*"


def mask_write(fn: Function) -> bool:
    return fn.mask_write


def packing_problems(fn: Function, lay: Layout, functions: Mapping[str, Function]) -> list[Problem]:
    """What is wrong with the function's bits, scale factor, initial values and role."""
    out = _bits_problems(fn, lay) + _scale_problems(fn, lay, functions) + _initial_problems(fn, lay)
    if fn.role is not None and not re.compile(_ROLE).fullmatch(fn.role):
        out.append((f"role '{fn.role[:40]}' is not a name (letters, digits and _)", "error", "role"))
    return out


def _bits_problems(fn: Function, lay: Layout) -> list[Problem]:
    out: list[Problem] = []
    if mask_write(fn) and fn.bits is None:
        out.append(
            (
                "write_function_code 22 (Mask Write Register) changes bits: it needs <bits>",
                "error",
                "write_function_code",
            )
        )
    if fn.bits is None:
        return out
    span = fn.bit_range
    if span is None:
        return [*out, (f"bits '{fn.bits[:20]}' is not N or N-M", "error", "bits")]
    if lay.kind != "int":
        what = "a BIT" if lay.kind == "bool" else f"format {fn.eff_format}"
        return [*out, (f"bits pick bits of an integer; {what} has none to pick", "error", "bits")]
    low, high = span
    if high >= lay.bits:
        out.append(
            (f"bits {fn.bits.strip()} are outside the {lay.bits}-bit value (bits 0-{lay.bits - 1})", "error", "bits")
        )
    if fn.read_function_code is not None:
        out.append(
            ("bits cannot be combined with read_function_code (the fragment decides the value)", "error", "bits")
        )
    if fn.write_function_code is not None and not mask_write(fn):
        out.append(
            (
                "bits cannot be combined with a write fragment (write_function_code 22 is Mask Write Register)",
                "error",
                "bits",
            )
        )
    if low == high and fn.scales:
        out.append(("one bit is a boolean: multiplier and offset cannot apply (use a range N-M)", "error", "bits"))
    if fn.factor is not None:
        out.append(("bits cannot be scaled by another function yet", "error", "bits"))
    if mask_write(fn) and fn.write_multiple:
        out.append(
            (
                "write_multiple does nothing: write_function_code 22 writes with Mask Write Register",
                "warning",
                "write_function_code",
            )
        )
    return out


def _scale_problems(fn: Function, lay: Layout, functions: Mapping[str, Function]) -> list[Problem]:
    if fn.factor is None:
        return []
    element = "scale_exponent" if fn.scale_exponent is not None else "scale_by"
    if fn.scale_exponent is not None and fn.scale_by is not None:
        return [("scale_exponent and scale_by cannot both apply", "error", "scale_by")]
    out: list[Problem] = []
    if lay.kind != "int":
        what = "a BIT" if lay.kind == "bool" else f"format {fn.eff_format}"
        out.append((f"{element} scales an integer; {what} cannot be scaled", "error", element))
    if fn.read_function_code is not None or fn.write_function_code is not None:
        out.append((f"{element} cannot be combined with a fragment (the fragment decides the value)", "error", element))
    factor = functions.get(fn.factor)
    if factor is None:
        return [*out, (f"{element} names no function '{fn.factor}'", "error", element)]
    if factor is fn:
        return [*out, (f"{element} names the function itself", "error", element)]
    why = factor_problem(factor)
    if why:
        out.append((f"{element} '{fn.factor}' {why}", "error", element))
    return out


def factor_problem(factor: Function) -> str | None:
    """Why a function cannot scale another: it must be read, and be a plain integer, not scaled itself."""
    if factor.expression is not None:
        return "is computed by an expression; a scale factor is an integer register"
    if not factor.readable:
        return f"cannot be read (access '{factor.eff_access}')"
    if factor.factor is not None:
        return f"is itself scaled by '{factor.factor}'"
    try:
        kind = layout(factor).kind
    except LayoutError:
        return None  # reported as its own error
    span = factor.bit_range
    if kind != "int" or factor.read_function_code is not None or factor.scales or (span and span[0] == span[1]):
        return "is not an integer (an integer format without multiplier, offset or fragment)"
    return None


def _initial_problems(fn: Function, lay: Layout) -> list[Problem]:
    if fn.initial is None:
        return []
    n = len(lay.addresses)
    if len(fn.initial) != n:
        return [(f"initial gives {len(fn.initial)} value(s) for {n} register(s)", "error", "initial")]
    limit = 1 if lay.table in BIT_TABLES else 0xFFFF
    bad = [v for v in fn.initial if not 0 <= v <= limit]
    if bad:
        return [(f"initial value {bad[0]} is outside 0..{limit}", "error", "initial")]
    return []
