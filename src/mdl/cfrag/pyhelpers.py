# C semantics for translated fragments. The functions a generated Python driver calls are copied
# from this file into it (see mdl.gen.python), so it imports only the standard library and each
# function is typed for `mypy --strict`.
import math
import struct


def _wrap(x: int, bits: int, signed: bool) -> int:
    x &= (1 << bits) - 1
    return x - (1 << bits) if signed and x >> (bits - 1) else x


def _f32(x: float) -> float:
    try:
        return float(struct.unpack("<f", struct.pack("<f", x))[0])
    except OverflowError:
        return math.copysign(math.inf, x)


def _trunc(x: float) -> int:
    if not math.isfinite(x):
        raise ValueError("fragment converts a non-finite value to an integer")
    return int(x)


def _idiv(a: int, b: int) -> int:
    if b == 0:
        raise ZeroDivisionError("fragment divides an integer by zero")
    q = abs(a) // abs(b)
    return q if (a < 0) == (b < 0) else -q


def _imod(a: int, b: int) -> int:
    return a - b * _idiv(a, b)


def _fdiv(a: float, b: float) -> float:
    if b == 0:
        if a == 0 or math.isnan(a):
            return math.nan
        return math.copysign(math.inf, a) * math.copysign(1.0, b)
    return a / b
