"""Registers <-> values: the one place that knows formats, orders, scaling and "not implemented".

Runtime (`mdl read`/`mdl write`) and simulator (`mdl sim --set`) use this module; the generated
drivers inline the same rules and tests prove they agree.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence

from mdl.model import Function, Scalar
from mdl.model.layout import Layout, layout


class CodecError(ValueError):
    """A value cannot be encoded (out of range, wrong type) or registers cannot be decoded."""


def _units_to_bytes(lay: Layout, regs: Sequence[int]) -> bytes:
    if lay.unit == "word":
        units = [
            bytes(((r >> 8) & 0xFF, r & 0xFF)) if lay.byte_order == "big" else bytes((r & 0xFF, (r >> 8) & 0xFF))
            for r in regs
        ]
    elif lay.unit == "low":
        units = [bytes((r & 0xFF,)) for r in regs]
    else:
        units = [bytes(((r >> 8) & 0xFF,)) for r in regs]
    if lay.word_order == "little":
        units.reverse()
    return b"".join(units)


def _bytes_to_units(lay: Layout, data: bytes) -> list[int]:
    size = 2 if lay.unit == "word" else 1
    units = [data[i : i + size] for i in range(0, len(data), size)]
    if lay.word_order == "little":
        units.reverse()
    if lay.unit == "word":
        if lay.byte_order == "big":
            return [(u[0] << 8) | u[1] for u in units]
        return [(u[1] << 8) | u[0] for u in units]
    if lay.unit == "low":
        return [u[0] for u in units]
    return [u[0] << 8 for u in units]


def decode_raw(lay: Layout, regs: Sequence[int]) -> Scalar:
    """Registers (address order) -> the format's value, before scaling."""
    if lay.kind == "bool":
        return bool(regs[0])
    data = _units_to_bytes(lay, regs)
    if lay.kind == "string":
        return data.rstrip(b"\x00 ").decode("utf-8", errors="replace")
    if lay.kind == "float":
        value: float = struct.unpack(">f" if lay.bits == 32 else ">d", data)[0]
        return value
    raw = int.from_bytes(data, "big") & ((1 << lay.bits) - 1)
    if lay.signed and raw >> (lay.bits - 1):
        raw -= 1 << lay.bits
    return raw


def int_range(lay: Layout) -> tuple[int, int]:
    if lay.signed:
        return -(1 << (lay.bits - 1)), (1 << (lay.bits - 1)) - 1
    return 0, (1 << lay.bits) - 1


def encode_raw(lay: Layout, value: Scalar) -> list[int]:
    """The format's value -> registers (address order)."""
    n = len(lay.addresses)
    if lay.kind == "bool":
        return [1 if value else 0]
    if lay.kind == "string":
        if not isinstance(value, str):
            raise CodecError(f"expects text, got {value!r}")
        data = value.encode("utf-8")
        size = n * (2 if lay.unit == "word" else 1)
        if len(data) > size:
            raise CodecError(f"text of {len(data)} bytes does not fit {size} bytes")
        data = data.ljust(size, b"\x00")
    elif lay.kind == "float":
        try:
            data = struct.pack(">f" if lay.bits == 32 else ">d", float(value))
        except OverflowError:  # 1e39 has no FLOAT32
            raise CodecError(f"{value} does not fit float{lay.bits}") from None
    else:
        if not isinstance(value, int):
            raise CodecError(f"expects a whole number, got {value!r}")
        lo, hi = int_range(lay)
        if not lo <= value <= hi:
            raise CodecError(f"{value} does not fit {'' if lay.signed else 'u'}int{lay.bits}")
        span = n * (16 if lay.unit == "word" else 8)
        data = (value & ((1 << span) - 1)).to_bytes(span // 8, "big")
    return _bytes_to_units(lay, data)


def is_not_implemented(fn: Function, regs: Sequence[int]) -> bool:
    """`not_implemented` values: one of up to 4 hex digits matches when every register holds it;
    a longer one matches the registers composed in address order, first most significant."""
    if not fn.not_implemented:
        return False
    composed = 0
    for r in regs:
        composed = (composed << 16) | r
    for token in fn.not_implemented:
        pattern = int(token, 16)
        if len(token) <= 6:
            if all(r == pattern for r in regs):
                return True
        elif composed == pattern:
            return True
    return False


def scales(fn: Function) -> bool:
    return fn.eff_multiplier != 1.0 or fn.eff_offset != 0.0


def decode(fn: Function, regs: Sequence[int]) -> Scalar | None:
    """Registers -> the engineering value (None where "not implemented")."""
    if is_not_implemented(fn, regs):
        return None
    lay = layout(fn)
    if fn.read_function_code:
        from mdl.diagnostics import error
        from mdl.lang.cfrag import compile_read

        try:
            return compile_read(fn.read_function_code, len(lay.addresses))(list(regs))
        except ArithmeticError as exc:  # the fragment has no value for these registers (docs/fragments.md)
            raise error(f"function '{fn.name}': read_function_code: {exc}") from None
    raw = decode_raw(lay, regs)
    if isinstance(raw, (str, bool)) or not scales(fn):
        return raw
    return tidy(raw * fn.eff_multiplier + fn.eff_offset)


def tidy(x: float) -> float:
    """A scaled value to 15 significant digits, so 3 * 0.1 reads 0.3, not 0.30000000000000004."""
    return float(f"{x:.15g}")


def check_range(fn: Function, value: Scalar) -> None:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if fn.minimum is not None and value < fn.minimum:
            raise CodecError(f"{value} is below the minimum {fn.minimum:g}")
        if fn.maximum is not None and value > fn.maximum:
            raise CodecError(f"{value} is above the maximum {fn.maximum:g}")


def encode(fn: Function, value: Scalar) -> list[int]:
    """The engineering value -> registers, refusing values outside minimum/maximum."""
    check_range(fn, value)
    lay = layout(fn)
    if fn.write_function_code:
        from mdl.lang.cfrag import compile_write

        try:
            return compile_write(fn.write_function_code, len(lay.addresses))(float(value))
        except ArithmeticError as exc:  # no registers for this value, or one out of range (docs/fragments.md)
            raise CodecError(f"write_function_code: {exc}") from None
    if lay.kind in ("string", "bool"):
        return encode_raw(lay, value)
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise CodecError(f"expects a number, got {value!r}")
    raw = (value - fn.eff_offset) / fn.eff_multiplier if scales(fn) else value
    if lay.kind == "float":
        return encode_raw(lay, raw)
    if isinstance(raw, float):
        if not math.isfinite(raw):
            raise CodecError(f"{value} is not a finite number")
        raw = math.floor(raw + 0.5)
    return encode_raw(lay, raw)


def parse_value(fn: Function, text: str) -> Scalar:
    """A value typed by a user (`NAME=VALUE`) -> a Python value for `encode`."""
    lay = layout(fn)
    if fn.values:
        for key, label in fn.values.items():
            if label == text:
                return key
    if lay.kind == "string" and not fn.write_function_code:
        return text
    if lay.kind == "bool" and not fn.write_function_code:
        low = text.strip().lower()
        if low in ("1", "true", "on", "yes"):
            return True
        if low in ("0", "false", "off", "no"):
            return False
        raise CodecError(f"expects true/false or 1/0, got {text!r}")
    try:
        number = int(text, 0)
    except ValueError:
        pass
    else:
        if number.bit_length() > 1023:  # beyond every format, even scaled, and beyond float()
            raise CodecError(f"{text.strip()[:20]}... is too large")
        return number
    try:
        return float(text)
    except ValueError:
        raise CodecError(f"expects a number, got {text!r}") from None
