"""Scaling both ways, computed exactly: XIF's two points (Native Value 1/2 -> Scaled Value 1/2), the
pre-3.2 A', B', C' (value = A' x 10^B' x (native + C')) <-> MDL's `multiplier` and `offset`
(value = raw x multiplier + offset).

Cells are read as exact decimals (fractions), the multiplier and offset computed from them exactly
and rounded to a double once; export chooses the two points so that reading them back gives the same
two doubles bit for bit."""

from __future__ import annotations

import re
from decimal import Context, Decimal
from fractions import Fraction

from mdl.ir.build import divisor_of

# a decimal number as cells hold it: ASCII digits, an optional exponent of at most 3 digits
_NUMBER = re.compile(r"[+-]?(?:[0-9]{1,40}(?:\.[0-9]{0,40})?|\.[0-9]{1,40})(?:[eE][+-]?[0-9]{1,3})?")
_EXACT = Context(prec=2000)  # enough digits for the exact sum of two doubles' shortest forms


class ScalingError(ValueError):
    """A number or a scale that cannot be used; the message says why."""


def number(text: str) -> Fraction:
    """A cell's decimal number, exactly; ScalingError if it is not one."""
    t = text.strip()
    if not _NUMBER.fullmatch(t):
        raise ScalingError(f"'{t[:40]}' is not a number")
    return Fraction(t)


def to_float(value: Fraction, what: str) -> float:
    try:
        return float(value)
    except OverflowError:
        raise ScalingError(f"{what} is too large for a double") from None


def two_point(n1: Fraction, n2: Fraction, s1: Fraction, s2: Fraction) -> tuple[float, float]:
    """(multiplier, offset) of the line through (n1, s1) and (n2, s2)."""
    if n1 == n2:
        raise ScalingError("Native Value 1 and Native Value 2 are equal: they define no scale")
    if s1 == s2:
        raise ScalingError("Scaled Value 1 and Scaled Value 2 are equal: every value would read the same")
    m = (s2 - s1) / (n2 - n1)
    return _checked(m, s1 - n1 * m)


def abc(a: Fraction, b: Fraction, c: Fraction) -> tuple[float, float]:
    """(multiplier, offset) of the pre-3.2 A' x 10^B' x (native + C')."""
    if b.denominator != 1 or abs(b) > 300:
        raise ScalingError("B' is a power of ten: a whole number from -300 to 300")
    if a == 0:
        raise ScalingError("A' is 0: every value would read the same")
    m = a * Fraction(10) ** int(b)
    return _checked(m, m * c)


def linear(multiplier: Fraction, offset: Fraction) -> tuple[float, float]:
    """The pre-3.2 Multiplier and Offset columns."""
    if multiplier == 0:
        raise ScalingError("Multiplier is 0: every value would read the same")
    return _checked(multiplier, offset)


def _checked(m: Fraction, o: Fraction) -> tuple[float, float]:
    multiplier, offset = to_float(m, "the scale"), to_float(o, "the offset")
    if multiplier == 0:
        raise ScalingError("the scale is too small for a double")
    return multiplier, offset


def decimal_text(x: float) -> str:
    """The shortest text that reads back as `x` (no `.0` on whole numbers)."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def points(multiplier: float, offset: float) -> tuple[str, str, str, str]:
    """Native Value 1, Native Value 2, Scaled Value 1, Scaled Value 2 for `raw * multiplier + offset`:
    native 0 -> the offset, and native d -> offset + 1 where the multiplier is 1/d (0.1: 0..10), else
    native 1 -> offset + multiplier, the sum written exactly."""
    s1 = Decimal(decimal_text(offset))
    d = divisor_of(multiplier)
    if d is not None:
        n2, step = str(d), Decimal(1)
    else:
        n2, step = "1", Decimal(decimal_text(multiplier))
    s2 = _EXACT.add(s1, step)
    return "0", n2, decimal_text(offset), _plain(s2)


def _plain(d: Decimal) -> str:
    """A decimal as a cell shows it: positional where that is short, else with an exponent."""
    if d == 0:
        return "0"
    d = d.normalize(_EXACT)
    text = format(d, "f") if -30 < d.adjusted() < 30 else str(d)
    return text
