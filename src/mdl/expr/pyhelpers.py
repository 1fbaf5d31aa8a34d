# Runtime of translated Modbus Schema Toolkit expressions. This file is also copied verbatim into
# generated Python drivers that use expressions, so it imports only the standard library.
# Division is cfrag/pyhelpers.py's _fdiv (IEEE semantics), which is always emitted beside it.
import decimal as _decimal
import math as _xmath
import struct as _xstruct


def _x_regs(r, index):
    values = [r[i] for i in index]
    return None if any(v is None for v in values) else values


def _x_uint(regs):
    value = 0
    for x in regs:
        value = (value << 16) | x
    return value


def _x_int(regs, bits, signed):
    value = _x_uint(regs)
    if signed and value >> (bits - 1):
        return value - (1 << bits)
    if not signed and bits == 64 and value >> 63:
        return None  # as the Toolkit: no unsigned 64-bit value above 2^63 - 1
    return value


def _x_float(regs, bits):
    data = b"".join(x.to_bytes(2, "big") for x in regs)
    return _xstruct.unpack(">f" if bits == 32 else ">d", data)[0]


def _x_bytes(regs):
    return b"".join(x.to_bytes(2, "big") for x in regs)


def _x_utf8(regs):
    return _x_bytes(regs).split(b"\x00", 1)[0].decode("utf-8", "replace")


def _x_hexstring(regs):
    return " ".join(f"0x{b:02X}" for b in _x_bytes(regs))


def _x_eui48(regs):
    return ":".join(f"{b:02X}" for b in _x_bytes(regs[-3:]))


def _x_ipv4addr(regs):
    return ".".join(str(b) for b in _x_bytes(regs))


def _x_ipv6addr(regs):
    return ":".join(f"{x:04X}" for x in regs)


def _x_enum(regs, mapping):
    value = _x_int(regs, 16 * len(regs), True)
    if value in mapping:
        return mapping[value]
    return "No mapping for value " + _x_hexstring(regs)


def _x_bitset(regs, mapping):
    value = _x_uint(regs)
    return [mapping.get(i, f"Bit {i}") for i in range(16 * len(regs)) if value >> i & 1]


def _x_swapbytes(regs):
    return [((x & 0xFF) << 8) | (x >> 8) for x in regs]


def _x_swapendian(regs):
    return [int(f"{x:016b}"[::-1], 2) for x in regs]


def _x_long(value):
    value &= 0xFFFFFFFFFFFFFFFF
    return value - (1 << 64) if value >> 63 else value


def _x_pow(a, b):
    try:
        return _xmath.pow(a, b)
    except OverflowError:
        return _xmath.inf if a > 0 or float(b).is_integer() and int(b) % 2 == 0 else -_xmath.inf
    except ValueError:
        return _xmath.nan


def _x_double_text(x):
    """Java's Double.toString: shortest digits, plain from 1e-3 to 1e7, else d.dddE±n."""
    if x != x:
        return "NaN"
    if x in (_xmath.inf, -_xmath.inf):
        return "Infinity" if x > 0 else "-Infinity"
    if x == 0:
        return "-0.0" if _xmath.copysign(1.0, x) < 0 else "0.0"
    if 1e-3 <= abs(x) < 1e7:
        return repr(x)
    d = _decimal.Decimal(repr(x))
    digits = "".join(map(str, d.as_tuple().digits)).rstrip("0") or "0"
    return f"{'-' if x < 0 else ''}{digits[0]}.{digits[1:] or '0'}E{d.adjusted()}"


def _x_text(value):
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return _x_double_text(value)
    if isinstance(value, list):
        return "[" + ", ".join(value) + "]"
    return str(value)
