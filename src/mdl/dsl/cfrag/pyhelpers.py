# C semantics for translated fragments, as docs/fragments.md defines them. The functions a
# generated Python driver calls are copied from this file into it (see mdl.targets.python.emit), so it
# imports only the standard library and each function is typed for `mypy --strict`.
# Errors: ZeroDivisionError and FloatingPointError where C returns -1 with errno EDOM,
# OverflowError where it returns -1 with errno ERANGE.
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


def _i2f32(n: int) -> float:
    """An integer converted to float as C converts it: rounded once, to nearest, ties to even."""
    m = abs(n)
    drop = m.bit_length() - 24
    if drop > 0:
        q, rest, half = m >> drop, m & ((1 << drop) - 1), 1 << (drop - 1)
        if rest > half or (rest == half and q & 1):
            q += 1
        m = q << drop
    return float(m) if n >= 0 else -float(m)


def _f2i(x: float, bits: int, signed: bool) -> int:
    """A float converted to an integer type, truncated toward zero; an error where C's result is undefined."""
    low, high = (-(1 << (bits - 1)), 1 << (bits - 1)) if signed else (0, 1 << bits)
    if not low - 1 < x < high:
        name = f"{'' if signed else 'u'}int{bits}_t"
        raise FloatingPointError(f"converts {x!r} to {name}, outside its range")
    return int(x)


def _idiv(a: int, b: int) -> int:
    if b == 0:
        raise ZeroDivisionError(f"divides the integer {a} by zero")
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


def _shl(a: int, n: int, bits: int, signed: bool) -> int:
    """a << n; a count outside 0..bits-1 (a negative one included) shifts every bit out."""
    return _wrap(a << n, bits, signed) if 0 <= n < bits else 0


def _shr(a: int, n: int, bits: int) -> int:
    """a >> n, arithmetic for a negative a; a count outside 0..bits-1 shifts every bit out."""
    return a >> n if 0 <= n < bits else (-1 if a < 0 else 0)


def _store(x: float, name: str) -> int:
    """What an assignment to a register stores: a value in -32768..65535, a negative one as its
    two's complement, truncated toward zero; any other value (NaN included) is an error."""
    if not -32769 < x < 65536:
        raise OverflowError(f"assigns {x!r} to {name}, outside -32768..65535")
    return int(x) & 0xFFFF
