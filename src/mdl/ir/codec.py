"""The value IR run in Python: registers <-> values for `mdl read`, `mdl write`, `mdl sim --set`
and `mdl test`.

Each `Codec` (mdl.ir.steps) is compiled once into a pair of Python closures (`compile_codec`),
one small function per step, so a poll decodes without looking at the model again. The generated
drivers print the same steps; the tests compare them with this module bit for bit.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence

from mdl.diagnostics import error
from mdl.ir import steps as ir
from mdl.ir.build import build, decode_steps, encode_steps
from mdl.model import Function, Scalar, Value
from mdl.model.layout import layout
from mdl.records import record


class CodecError(ValueError):
    """A value cannot be encoded (out of range, wrong type) or registers cannot be decoded."""


Decoder = Callable[..., Value]  # registers (address order)[, the scale factor's value] -> value
Encoder = Callable[..., list[int]]  # value[, the scale factor's value] -> registers (address order)


def _part(unit: ir.Unit) -> Callable[[Sequence[int]], int]:
    i = unit.index
    if unit.part == "word":
        return lambda r: r[i]
    if unit.part == "swap":
        return lambda r: ((r[i] & 0xFF) << 8) | (r[i] >> 8)
    if unit.part == "low":
        return lambda r: r[i] & 0xFF
    return lambda r: r[i] >> 8


def _compose(units: tuple[ir.Unit, ...]) -> Callable[[Sequence[int]], int]:
    parts = [(_part(u), u.shift) for u in units]
    if len(parts) == 1 and parts[0][1] == 0:
        return parts[0][0]

    def compose(r: Sequence[int]) -> int:
        v = 0
        for part, shift in parts:
            v |= part(r) << shift
        return v

    return compose


def _split(units: tuple[ir.Unit, ...], n: int) -> Callable[[int], list[int]]:
    def split(v: int) -> list[int]:
        regs = [0] * n
        for u in units:
            x = (v >> u.shift) & (0xFFFF if u.part in ("word", "swap") else 0xFF)
            regs[u.index] = {"word": x, "swap": ((x & 0xFF) << 8) | (x >> 8), "low": x, "high": x << 8}[u.part]
        return regs

    return split


def _scale(step: ir.Scale) -> Callable[[int | float], float]:
    d, m, o = step.divisor, step.multiplier, step.offset

    def scale(v: int | float) -> float:
        x = float(v)
        x = x / d if d is not None else x * m
        return x + o if o != 0.0 else x

    return scale


def _value_step(step: ir.DecodeStep) -> Callable[[int | float], int | float]:
    """A step after Compose: v -> v."""
    if isinstance(step, ir.Mask):
        mask = (1 << step.bits) - 1
        return lambda v: int(v) & mask
    if isinstance(step, ir.SignExtend):
        top, full = 1 << (step.bits - 1), 1 << step.bits
        return lambda v: int(v) - full if int(v) & top else v
    if isinstance(step, ir.ToFloat):
        fmt, size = (">f", 4) if step.bits == 32 else (">d", 8)
        return lambda v: float(struct.unpack(fmt, int(v).to_bytes(size, "big"))[0])
    if isinstance(step, ir.Scale):
        return _scale(step)
    if isinstance(step, ir.Bits):
        shift, mask = step.shift, (1 << step.width) - 1
        if step.boolean:
            return lambda v: bool((int(v) >> shift) & mask)
        return lambda v: (int(v) >> shift) & mask
    raise AssertionError(f"not a value step: {step}")


def power_of_ten(e: int) -> float:
    """10^|e| as every target computes it: 1.0 multiplied by 10.0 |e| times (exact up to 22)."""
    p = 1.0
    for _ in range(abs(e)):
        p *= 10.0
    return p


def _factor(step: ir.ScaleFactor | ir.UnscaleFactor, f: Value) -> float | None:
    """The factor's power of ten (or its value as a double); None where it has none (null, or an exponent
    outside -22..22)."""
    if f is None or isinstance(f, (str, list)):
        return None
    if step.exponent:
        return power_of_ten(int(f)) if -ir.MAX_EXPONENT <= int(f) <= ir.MAX_EXPONENT else None
    return float(f)


def _scale_factor(step: ir.ScaleFactor) -> Callable[[int | float, Value], float | None]:
    d, m, o = step.divisor, step.multiplier, step.offset

    def scale(v: int | float, f: Value) -> float | None:
        p = _factor(step, f)
        if p is None:
            return None
        x = float(v)
        if d is not None:
            x = x / d
        elif m != 1.0:
            x = x * m
        x = x / p if step.exponent and int(f) < 0 else x * p  # type: ignore[arg-type]  # f is a number here
        return x + o if o != 0.0 else x

    return scale


def compile_decoder(name: str, steps: tuple[ir.DecodeStep, ...]) -> Decoder:
    """The steps as one function: registers -> value (ArithmeticError becomes MdlError naming the function)."""
    head: list[ir.DecodeStep] = list(steps)
    missing: frozenset[tuple[int, ...]] = frozenset()
    if head and isinstance(head[0], ir.NotImplemented):
        missing = frozenset(head.pop(0).patterns)  # type: ignore[union-attr]
    first = head[0]
    body: Decoder
    if isinstance(first, ir.Fragment):
        from mdl.dsl.cfrag import compile_read  # here: the fragment compiler only for a fragment

        fragment = compile_read(first.code, first.nregs)

        def body(r: Sequence[int]) -> Value:
            try:
                return fragment(list(r))
            except ArithmeticError as exc:  # the fragment has no value for these registers (docs/fragments.md)
                raise error(f"function '{name}': read_function_code: {exc}") from None

    elif isinstance(first, ir.ToBool):

        def body(r: Sequence[int]) -> Value:
            return bool(r[0])

    elif isinstance(first, ir.ToText):
        compose, nbytes = _compose(first.units), first.nbytes

        def body(r: Sequence[int]) -> Value:
            return compose(r).to_bytes(nbytes, "big").rstrip(b"\x00 ").decode("utf-8", errors="replace")

    elif isinstance(first, ir.Compose) and isinstance(head[-1], ir.ScaleFactor):
        compose, scaled = _compose(first.units), _scale_factor(head[-1])
        rest = [_value_step(step) for step in head[1:-1]]

        def body(r: Sequence[int], f: Value = None) -> Value:
            v: int | float = compose(r)
            for step in rest:
                v = step(v)
            return scaled(v, f)

    elif isinstance(first, ir.Compose):
        compose = _compose(first.units)
        rest = [_value_step(step) for step in head[1:]]

        def body(r: Sequence[int]) -> Value:
            v: int | float = compose(r)
            for step in rest:
                v = step(v)
            return v

    else:
        raise AssertionError(f"a decode cannot start with {first}")
    if not missing:
        return body
    return lambda r, *f: None if tuple(r) in missing else body(r, *f)


def _number(value: Scalar) -> int | float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CodecError(f"expects a number, got {value!r}")
    return value


def compile_encoder(codec: ir.Codec, steps: tuple[ir.EncodeStep, ...]) -> Encoder:
    n = len(codec.addresses)
    checks: list[Callable[[Scalar], None]] = []
    todo = list(steps)
    if todo and isinstance(todo[0], ir.CheckRange):
        checks.append(_range_check(todo.pop(0)))  # type: ignore[arg-type]
    last = todo[0]
    body: Encoder
    if isinstance(last, ir.Fragment):
        from mdl.dsl.cfrag import compile_write

        fragment = compile_write(last.code, last.nregs)

        def body(value: Scalar) -> list[int]:
            try:
                return fragment(float(_number(value)))
            except ArithmeticError as exc:  # no registers for this value, or one out of range (docs/fragments.md)
                raise CodecError(f"write_function_code: {exc}") from None

    elif isinstance(last, ir.FromBool):

        def body(value: Scalar) -> list[int]:
            return [1 if value else 0]

    elif isinstance(last, ir.FromText):
        split, nbytes = _split(last.units, n), last.nbytes

        def body(value: Scalar) -> list[int]:
            if not isinstance(value, str):
                raise CodecError(f"expects text, got {value!r}")
            data = value.encode("utf-8")
            if len(data) > nbytes:
                raise CodecError(f"text of {len(data)} bytes does not fit {nbytes} bytes")
            return split(int.from_bytes(data.ljust(nbytes, b"\x00"), "big"))

    else:
        body = _numeric_encoder(todo, n)
    if not checks:
        return body
    check = checks[0]

    def checked(value: Scalar, *factor: Value) -> list[int]:
        check(value)
        return body(value, *factor)

    return checked


def _range_check(step: ir.CheckRange) -> Callable[[Scalar], None]:
    low, high = step.minimum, step.maximum

    def check(value: Scalar) -> None:
        x = int(value) if isinstance(value, bool) else _number(value)  # a bit's bounds: 0 and 1
        if isinstance(x, float) and math.isnan(x):
            raise CodecError("NaN is outside every range")
        if low is not None and x < low:
            raise CodecError(f"{value} is below the minimum {low:g}")
        if high is not None and x > high:
            raise CodecError(f"{value} is above the maximum {high:g}")

    return check


def _unscale_factor(step: ir.UnscaleFactor, x: int | float, f: Value) -> float:
    """`UnscaleFactor`: CodecError where the factor has no value (or is 0)."""
    p = _factor(step, f)
    if p is None:
        raise CodecError("the scale factor has no value: nothing is written")
    if p == 0.0:
        raise CodecError("the scale factor is 0: no register value gives this value")
    x = float(x)
    if step.offset != 0.0:
        x = x - step.offset
    if step.divisor is not None:
        x = x * step.divisor
    elif step.multiplier != 1.0:
        x = x / step.multiplier
    return x * p if step.exponent and int(f) < 0 else x / p  # type: ignore[arg-type]  # f is a number here


def _numeric_encoder(steps: list[ir.EncodeStep], n: int) -> Encoder:
    unscale = next((s for s in steps if isinstance(s, ir.Unscale)), None)
    by_factor = next((s for s in steps if isinstance(s, ir.UnscaleFactor)), None)
    to_float = next((s for s in steps if isinstance(s, ir.FromFloat)), None)
    to_int = next((s for s in steps if isinstance(s, ir.RoundInt)), None)
    place = next((s for s in steps if isinstance(s, ir.PlaceBits)), None)
    split_step = next(s for s in steps if isinstance(s, ir.Split))
    split = _split(split_step.units, n)

    def encode(value: Scalar, factor: Value = None) -> list[int]:
        if place is not None and place.boolean:
            return split((1 if value else 0) << place.shift)
        x = _number(value)
        if unscale is not None:
            x = float(x)
            if unscale.offset != 0.0:
                x = x - unscale.offset
            x = x * unscale.divisor if unscale.divisor is not None else x / unscale.multiplier
        if by_factor is not None:
            x = _unscale_factor(by_factor, x, factor)
        if to_float is not None:
            fmt = ">f" if to_float.bits == 32 else ">d"
            try:
                return split(int.from_bytes(struct.pack(fmt, float(x)), "big"))
            except OverflowError:  # 1e39 has no FLOAT32
                raise CodecError(f"{value} does not fit float{to_float.bits}") from None
        assert to_int is not None
        if isinstance(x, float):
            if not math.isfinite(x):
                raise CodecError(f"{value} is not a finite number")
            x = math.floor(x + 0.5)
        if not to_int.low <= x <= to_int.high:
            if place is not None:
                raise CodecError(f"{value} does not fit its {to_int.bits} bits (0..{to_int.high})")
            raise CodecError(f"{value} does not fit {'' if to_int.signed else 'u'}int{to_int.bits}")
        v = x & ((1 << to_int.span) - 1)
        return split(v << place.shift if place is not None else v)

    return encode


@record
class Compiled:
    """A function's decoder and encoder (None where it cannot be read or written)."""

    decode: Decoder | None
    encode: Encoder | None


def compile_codec(name: str, codec: ir.Codec) -> Compiled:
    """The IR of a function without an expression as Python closures (expressions are run by
    mdl.device.evaluate with their dependencies)."""
    decode = None
    if codec.decode is not None and not isinstance(codec.decode[0], ir.Expression):
        decode = compile_decoder(name, codec.decode)
    encode = compile_encoder(codec, codec.encode) if codec.encode is not None else None
    return Compiled(decode, encode)


def decode(fn: Function, regs: Sequence[int]) -> Value:
    """Registers -> the engineering value (None where "not implemented"), for one function of the
    model without an expression, readable or not (the simulator decodes write-only ones)."""
    return compile_decoder(fn.name, decode_steps(fn, layout(fn)))(regs)


def encode(fn: Function, value: Scalar, *factor: Value) -> list[int]:
    """The engineering value -> registers, refusing values outside minimum/maximum. A function scaled by
    another takes that one's value as `factor`; without it only what needs no factor is checked (the
    type, minimum and maximum: `mdl write` checks every value before it connects) and nothing is
    returned. A function with bits gets registers holding only its bits (ir.Merge says how they are written)."""
    lay = layout(fn)
    steps = encode_steps(fn, lay)
    if fn.factor is not None and not factor:
        _number(value)
        check = steps[0]
        if isinstance(check, ir.CheckRange):
            _range_check(check)(value)
        return []
    return compile_encoder(build(fn, lay), steps)(value, *factor)


def merge(current: Sequence[int], new: Sequence[int], masks: Sequence[int]) -> list[int]:
    """`ir.Merge`: the registers `current` with the bits of `masks` taken from `new`."""
    return [(c & ~m & 0xFFFF) | (n & m) for c, n, m in zip(current, new, masks, strict=True)]


def parse_value(fn: Function, text: str) -> Scalar:
    """A value typed by a user (`NAME=VALUE`) -> a Python value for `encode`."""
    kind = layout(fn).kind
    span = fn.bit_range
    if kind == "int" and span is not None and span[0] == span[1]:
        kind = "bool"  # one bit of a register
    if fn.values:
        for key, label in fn.values.items():
            if label == text:
                return key
    fragment = fn.write_function_code is not None and not fn.mask_write
    if kind == "string" and not fragment:
        return text
    if kind == "bool" and not fragment:
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
