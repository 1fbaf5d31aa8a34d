# C semantics for translated fragments. This file is also copied verbatim into generated
# Python drivers that use fragments, so it imports only the standard library.
import math as _math
import struct as _struct


def _wrap(x, bits, signed):
    x &= (1 << bits) - 1
    return x - (1 << bits) if signed and x >> (bits - 1) else x


def _f32(x):
    try:
        return _struct.unpack("<f", _struct.pack("<f", x))[0]
    except OverflowError:
        return _math.copysign(_math.inf, x)


def _trunc(x):
    if not _math.isfinite(x):
        raise ValueError("fragment converts a non-finite value to an integer")
    return int(x)


def _idiv(a, b):
    if b == 0:
        raise ZeroDivisionError("fragment divides an integer by zero")
    q = abs(a) // abs(b)
    return q if (a < 0) == (b < 0) else -q


def _imod(a, b):
    return a - b * _idiv(a, b)


def _fdiv(a, b):
    if b == 0:
        if a == 0 or a != a:
            return _math.nan
        return _math.copysign(_math.inf, a) * _math.copysign(1.0, b)
    return a / b
