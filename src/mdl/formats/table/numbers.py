"""Number cells of vendor tables: scales (`0.1`, `0,1V`, `scale(0.1)`, `x10`, `1/10`), limits, offsets.

A cell is read whole or refused: `mod10k(True)` is not a scale, and never becomes the 10 inside it.
Accepted, after optional spaces:

- a number with an optional unit and an optional remark in parentheses: `0.1`, `0.1V`, `0,01 Hz`,
  `-1W`, `0.1(?)` (ORNL's example), `1e-3`, `1.234,5`;
- `scale(N)` (VOLTTRON's transform), `xN` / `×N` / `*N`, `A/B` (`1/10`), `10^N`;
- `-`, `n/a`, `none`: no value (the same as an empty cell);
- any of these in square brackets, as a unit column prints them: `[0.1°C]`, `[Wh]`.

Decimal commas: `decimal` is "comma" (`,` is the decimal mark; dots group thousands), "point" (`,`
groups thousands) or "auto" (the default): a comma followed by digits is a decimal comma, and the
caller is told (`Number.comma`) so that it can say so once.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from mdl.diagnostics import shown
from mdl.formats.table.cells import CellError, cell_cache
from mdl.formats.table.lazy import lazy

_DIGITS = r"(?:\d+(?:[.,]\d+)*\.?|[.,]\d+)"
_NUMBER = rf"[-+]?{_DIGITS}(?:[eE][-+]?\d+)?"
# a unit starts with a letter or a sign of one (°C, %, µs, Ω); digits may follow (m3/h, m²)
_UNIT = r"(?:[^\W\d_]|[°%‰µΩ℃℉'\"])[^()]*?"
_PLAIN = lazy(rf"^({_NUMBER})\s*({_UNIT})?\s*(\([^()]*\))?$")
_SCALE_CALL = lazy(rf"(?i)^scale\s*\(\s*({_NUMBER})\s*\)$")
_TIMES = lazy(rf"^[xX×*]\s*({_NUMBER})$")
_FRACTION = lazy(rf"^({_NUMBER})\s*/\s*({_NUMBER})\s*({_UNIT})?$")
_POWER = lazy(rf"^10\s*\^\s*([-+]?\d{{1,3}})\s*({_UNIT})?$")
NO_VALUE = frozenset({"-", "\u2013", "\u2014", "n/a", "na", "n.a.", "n.a", "n. a.", "none", "--", "/"})
_PREFIX_ONLY = frozenset({"k", "K", "M", "G"})  # `10k`: ten thousand or ten of a unit? refused


@dataclass(frozen=True)
class Number:
    value: float
    unit: str | None = None  # the unit written after the number (`0.1V` -> "V")
    comma: bool = False  # read with a decimal comma the caller did not ask for
    alone: bool = False  # a unit with no number (`W`), read as scale 1 (rows.py, a scale and units column)
    times: bool = False  # `x10`, `*10`, `×10`: multiply by ten, or stored ten times larger? (read as 10, warned)


_UNIT_ALONE = lazy(rf"^{_UNIT}$")
_BRACKETED = lazy(r"^\[([^\[\]]*)\]$")


def _unbracketed(cell: str) -> str:
    """`[0.1°C]` -> `0.1°C`: a unit column that prints its cells in square brackets (Lambda's heat pump
    table: `[0.01°C]`, `[Wh]`, `[Nr]`) says the same as without them. Left whole, the cell is no scale
    and becomes the unit `[0.01°C]` with scale 1: every value a hundred times too large, silently."""
    m = _BRACKETED().match(cell)
    return " ".join(m.group(1).split()) if m else cell


@cell_cache
def unit_alone(text: str) -> str | None:
    """The unit of a cell that is a unit and nothing else (`W`, `V DC`, `°C`, `[Wh]`), else None."""
    cell = _unbracketed(" ".join(text.split()))
    if not cell or cell.lower() in NO_VALUE or not _UNIT_ALONE().match(cell):
        return None
    try:
        return _unit(cell)
    except CellError:
        return None


def _digits_to_float(text: str, decimal: str) -> tuple[float, bool]:
    """`1.234,5` / `0,1` / `1,000` -> (float, whether a decimal comma was guessed)."""
    sign = ""
    if text[:1] in "+-":
        sign, text = text[0], text[1:]
    mantissa, _, exponent = text.partition("e") if "e" in text else text.partition("E")
    has_dot, has_comma = "." in mantissa, "," in mantissa
    guessed = False
    if has_dot and has_comma:  # the last mark is the decimal one, the other groups thousands
        point = "." if mantissa.rfind(".") > mantissa.rfind(",") else ","
        group = "," if point == "." else "."
        if decimal == "point" and point == ",":
            raise CellError("a decimal comma, but decimal_separator = point")
        whole, _, frac = mantissa.rpartition(point)
        if not re.fullmatch(rf"\d{{1,3}}(?:\{group}\d{{3}})*", whole):
            raise CellError("its digits are grouped in an unknown way")
        mantissa = whole.replace(group, "") + "." + frac
        guessed = point == "," and decimal == "auto"
    elif has_comma:
        if decimal == "point" or mantissa.count(",") > 1:
            if not re.fullmatch(r"\d{1,3}(?:,\d{3})+", mantissa):
                raise CellError("',' groups thousands here, in threes")
            mantissa = mantissa.replace(",", "")
        else:
            mantissa = mantissa.replace(",", ".")
            guessed = decimal == "auto"
    elif has_dot and decimal == "comma" and mantissa.count(".") > 1:
        mantissa = mantissa.replace(".", "")  # 1.234.567 with decimal commas
    if mantissa.count(".") > 1:
        raise CellError("more than one decimal mark")
    if len(mantissa) > 40 or len(exponent) > 5:
        raise CellError("too many digits")
    value = float(sign + mantissa + (("e" + exponent) if exponent else ""))
    return value, guessed


def _unit(text: str | None) -> str | None:
    unit = (text or "").strip() or None
    if unit in _PREFIX_ONLY:
        raise CellError(f"{shown(unit)} after the number: a thousands suffix or a unit?")
    return unit


def _finite(value: float, cell: str, what: str) -> float:
    if not math.isfinite(value):  # 1e999: no target computes with it
        raise _NotFinite(f"{what} {shown(cell)} is not a finite number".lstrip())
    return value


class _NotFinite(CellError):
    """Said as is (the existing message names the cell)."""


@cell_cache
def parse_number(text: str, decimal: str = "auto", what: str = "", scale: bool = False) -> Number | None:
    """A number cell -> Number, None for a cell that says "no value", CellError for anything else.

    With `scale`, the multiplier forms (`scale(0.1)`, `x10`, `1/10`, `10^-1`) are accepted too."""
    cell = _unbracketed(" ".join(text.replace("\u2212", "-").split()))
    if not cell or cell.lower() in NO_VALUE:
        return None
    kinds = "a scale (0.1, 0.1V, scale(0.1), x10, 1/10)" if scale else "a number"
    try:
        found = _read(cell, decimal, what, scale)
    except _NotFinite:
        raise
    except CellError as exc:
        raise CellError(f"{what} {shown(cell)} is not {kinds}: {exc}".lstrip()) from None
    if found is None:
        raise CellError(f"{what} {shown(cell)} is not {kinds}".lstrip())
    return found


def _read(cell: str, decimal: str, what: str, scale: bool) -> Number | None:
    forms = (_PLAIN, _SCALE_CALL, _TIMES, _FRACTION, _POWER) if scale else (_PLAIN,)
    for form in forms:
        m = form().match(cell)
        if not m:
            continue
        if form is _POWER:
            exponent = int(m.group(1))
            if abs(exponent) > 300:
                raise _NotFinite(f"{what} {shown(cell)} is not a finite number".lstrip())
            return Number(10.0**exponent, _unit(m.group(2)))
        if form is _FRACTION:
            top, comma1 = _digits_to_float(m.group(1), decimal)
            bottom, comma2 = _digits_to_float(m.group(2), decimal)
            if bottom == 0:
                raise CellError("it divides by 0")
            return Number(_finite(top / bottom, cell, what), _unit(m.group(3)), comma1 or comma2)
        value, comma = _digits_to_float(m.group(1), decimal)
        if form is _TIMES:
            return Number(_finite(value, cell, what), None, comma, times=True)
        unit = _unit(m.group(2)) if form is _PLAIN else None
        return Number(_finite(value, cell, what), unit, comma)
    return None


@cell_cache
def parse_int(text: str) -> int:
    """A whole number cell (`2`, `0x10`, `2.0`, `4 bytes`) -> int."""
    t = text.strip()
    try:
        return int(t, 0)
    except ValueError:
        pass
    number = parse_number(t, "point")
    if number is None or not number.value.is_integer() or abs(number.value) > 1e12:
        raise CellError(f"{shown(t)} is not a whole number")
    return int(number.value)
