# Runtime of translated Modbus Schema Toolkit expressions. The functions a generated Python driver
# calls are copied from this file into it (see mdl.targets.python.emit), so it imports only the standard
# library and each function is typed for `mypy --strict`. Division is cfrag/pyhelpers.py's _fdiv
# (IEEE semantics).
import decimal
import math
import struct
from collections.abc import Sequence


def _x_regs(r: Sequence[int | None], index: tuple[int, ...]) -> list[int] | None:
    values = []
    for i in index:
        value = r[i]
        if value is None:
            return None
        values.append(value)
    return values


def _x_uint(regs: list[int]) -> int:
    value = 0
    for x in regs:
        value = (value << 16) | x
    return value


def _x_signed(value: int, bits: int) -> int:
    return value - (1 << bits) if value >> (bits - 1) else value


def _x_int(regs: list[int], bits: int, signed: bool) -> int | None:
    value = _x_uint(regs)
    if signed:
        return _x_signed(value, bits)
    if bits == 64 and value >> 63:
        return None  # as the Toolkit: no unsigned 64-bit value above 2^63 - 1
    return value


def _x_float(regs: list[int], bits: int) -> float:
    return float(struct.unpack(">f" if bits == 32 else ">d", _x_bytes(regs))[0])


def _x_bytes(regs: list[int]) -> bytes:
    return b"".join(x.to_bytes(2, "big") for x in regs)


def _x_utf8(regs: list[int]) -> str:
    return _x_bytes(regs).split(b"\x00", 1)[0].decode("utf-8", "replace")


def _x_hexstring(regs: list[int]) -> str:
    return " ".join(f"0x{b:02X}" for b in _x_bytes(regs))


def _x_eui48(regs: list[int]) -> str:
    return ":".join(f"{b:02X}" for b in _x_bytes(regs[-3:]))


def _x_ipv4addr(regs: list[int]) -> str:
    return ".".join(str(b) for b in _x_bytes(regs))


def _x_ipv6addr(regs: list[int]) -> str:
    return ":".join(f"{x:04X}" for x in regs)


def _x_enum(regs: list[int], mapping: dict[int, str]) -> str:
    value = _x_signed(_x_uint(regs), 16 * len(regs))
    if value in mapping:
        return mapping[value]
    return "No mapping for value " + _x_hexstring(regs)


def _x_bitset(regs: list[int], mapping: dict[int, str]) -> list[str]:
    value = _x_uint(regs)
    return [mapping.get(i, f"Bit {i}") for i in range(16 * len(regs)) if value >> i & 1]


def _x_swapbytes(regs: list[int]) -> list[int]:
    return [((x & 0xFF) << 8) | (x >> 8) for x in regs]


def _x_swapendian(regs: list[int]) -> list[int]:
    return [int(f"{x:016b}"[::-1], 2) for x in regs]


def _x_long(value: int) -> int:
    value &= 0xFFFFFFFFFFFFFFFF
    return value - (1 << 64) if value >> 63 else value


def _x_pow(a: float, b: float) -> float:
    try:
        return math.pow(a, b)
    except OverflowError:
        return math.inf if a > 0 or float(b).is_integer() and int(b) % 2 == 0 else -math.inf
    except ValueError:
        return math.nan


def _x_double_text(x: float) -> str:
    """Java's Double.toString: shortest digits, plain from 1e-3 to 1e7, else d.dddEn."""
    if math.isnan(x):
        return "NaN"
    if x in (math.inf, -math.inf):
        return "Infinity" if x > 0 else "-Infinity"
    if x == 0:
        return "-0.0" if math.copysign(1.0, x) < 0 else "0.0"
    if 1e-3 <= abs(x) < 1e7:
        return repr(x)
    d = decimal.Decimal(repr(x))
    digits = "".join(map(str, d.as_tuple().digits)).rstrip("0") or "0"
    return f"{'-' if x < 0 else ''}{digits[0]}.{digits[1:] or '0'}E{d.adjusted()}"


def _x_text(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return _x_double_text(value)
    if isinstance(value, list):
        return "[" + ", ".join(value) + "]"
    return str(value)
