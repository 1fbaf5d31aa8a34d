"""A function of the model -> its value IR (`mdl.ir.steps.Codec`), the one place that knows how
formats, byte and word orders, "not implemented", scaling, fragments and expressions combine
(SPEC section 2.3). Every consumer gets the IR from here through `mdl.resolver`."""

from __future__ import annotations

import functools
from collections.abc import Hashable

from mdl.ir.steps import (
    Bits,
    CheckRange,
    Codec,
    Compose,
    DecodeStep,
    EncodeStep,
    Expression,
    Fragment,
    FromBool,
    FromFloat,
    FromText,
    Mask,
    Merge,
    NotImplemented,
    PlaceBits,
    RoundInt,
    Scale,
    ScaleFactor,
    SignExtend,
    Split,
    ToBool,
    ToFloat,
    ToText,
    Unit,
    Unscale,
    UnscaleFactor,
    ValueType,
)
from mdl.model import CompiledExpression, Function
from mdl.model.layout import Layout, int_type_bits, integer_range

# the largest divisor the rounding rule uses: below 2**53 every integer is exact in a double
_MAX_DIVISOR = 1 << 53


def divisor_of(multiplier: float) -> int | None:
    """The integer d with multiplier == 1/d exactly (0.1 -> 10, 0.25 -> 4), else None."""
    if not 1.0 / _MAX_DIVISOR < multiplier < 1:
        return None
    d = round(1.0 / multiplier)
    return d if 1 < d < _MAX_DIVISOR and 1.0 / d == multiplier else None


def units(lay: Layout) -> tuple[Unit, ...]:
    """The units of a value, most significant first: which register, which part, what shift."""
    return _units(len(lay.addresses), lay.unit, lay.byte_order, lay.word_order)


@functools.lru_cache(maxsize=1024)
def _units(n: int, unit: str, byte_order: str, word_order: str) -> tuple[Unit, ...]:
    """`units`, built once per shape (units are immutable, and a large device has few shapes)."""
    order = range(n) if word_order == "big" else reversed(range(n))
    part = ("word" if byte_order == "big" else "swap") if unit == "word" else unit
    unit_bits = 16 if unit == "word" else 8
    return tuple(Unit(i, part, unit_bits * (n - 1 - pos)) for pos, i in enumerate(order))  # type: ignore[arg-type]


def span_bits(lay: Layout) -> int:
    return len(lay.addresses) * (16 if lay.unit == "word" else 8)


def int_range(lay: Layout) -> tuple[int, int]:
    return integer_range(lay.bits, lay.signed)


def not_implemented_patterns(fn: Function, n: int) -> tuple[tuple[int, ...], ...]:
    """Each `not_implemented` value as the register values it stands for: one of up to 4 hex digits
    in every register, a longer one split into words, first register most significant."""
    out = []
    for token in fn.not_implemented or ():
        pattern = int(token, 16)
        if len(token) <= 6:
            out.append((pattern,) * n)
        else:
            out.append(tuple((pattern >> (16 * (n - 1 - i))) & 0xFFFF for i in range(n)))
    return tuple(out)


def split_value(units_: tuple[Unit, ...], n: int, v: int) -> tuple[int, ...]:
    """`Split`: each unit of `v` into its register."""
    regs = [0] * n
    for u in units_:
        x = (v >> u.shift) & (0xFFFF if u.part in ("word", "swap") else 0xFF)
        regs[u.index] = {"word": x, "swap": ((x & 0xFF) << 8) | (x >> 8), "low": x, "high": x << 8}[u.part]
    return tuple(regs)


def bit_fields(fn: Function, lay: Layout) -> tuple[int, int] | None:
    """(shift, width) of the function's bits where it has bits of an integer, else None."""
    if fn.bits is None or lay.kind != "int":  # most functions: no bits to parse (asked several times of each)
        return None
    span = fn.bit_range
    if span is None:
        return None
    return span[0], span[1] - span[0] + 1


def value_type(fn: Function, lay: Layout, compiled: CompiledExpression | None = None) -> ValueType:
    nullable = bool(fn.not_implemented)
    if compiled is not None:
        return ValueType("expr", nullable=True, expr_type=compiled.type)
    if fn.factor is not None:
        return ValueType("float", 64, True, nullable=True)  # null where the factor has no value
    field = bit_fields(fn, lay)
    if field is not None:
        if field[1] == 1:
            return ValueType("bool", nullable=nullable)
        if fn.scales:
            return ValueType("float", 64, True, nullable=nullable)
        return ValueType("int", int_type_bits(field[1]), False, nullable=nullable)
    if fn.read_function_code or (lay.kind == "int" and fn.scales) or (lay.kind == "float" and fn.scales):
        return ValueType("float", 64, True, nullable=nullable)
    if lay.kind == "int":
        return ValueType("int", int_type_bits(lay.bits), lay.signed, nullable=nullable)
    if lay.kind == "float":
        return ValueType("float", lay.bits, True, nullable=nullable)
    if lay.kind == "string":
        return ValueType("string", nbytes=span_bits(lay) // 8, nullable=nullable)
    return ValueType("bool", nullable=nullable)


def write_type(
    fn: Function, lay: Layout, compiled: CompiledExpression | None = None, read_type: ValueType | None = None
) -> ValueType:
    """The type a write takes; `read_type`, when given, is `value_type(fn, lay, compiled)`, worked out
    already (`build` has it)."""
    if fn.factor is not None:
        return ValueType("float", 64, True)
    if fn.write_function_code and not fn.mask_write:
        return ValueType("float", 64, True)
    if bit_fields(fn, lay) is not None:
        return value_type(fn, lay)
    if (lay.kind in ("int", "float")) and fn.scales:
        return ValueType("float", 64, True)
    return value_type(fn, lay, compiled) if read_type is None else read_type


def decode_steps(fn: Function, lay: Layout, compiled: CompiledExpression | None = None) -> tuple[DecodeStep, ...]:
    if compiled is not None:
        return (Expression(compiled.lowered, tuple(compiled.deps)),)
    n = len(lay.addresses)
    steps: list[DecodeStep] = []
    if fn.not_implemented:
        steps.append(NotImplemented(not_implemented_patterns(fn, n)))
    if fn.read_function_code:
        from mdl.dsl.cfrag import compile_fragment  # here: the fragment compiler only for a fragment

        code = fn.read_function_code
        return (*steps, Fragment(code, n, True, compile_fragment(code, n, True)))
    if lay.kind == "bool":
        return (*steps, ToBool())
    if lay.kind == "string":
        return (*steps, ToText(units(lay), span_bits(lay) // 8))
    steps.append(Compose(units(lay)))
    field = bit_fields(fn, lay)
    if lay.kind == "float":
        steps.append(ToFloat(lay.bits))
    else:
        if lay.bits < span_bits(lay):
            steps.append(Mask(lay.bits))
        if field is not None:
            steps.append(Bits(field[0], field[1], field[1] == 1))
            if field[1] == 1:
                return tuple(steps)
        elif lay.signed:
            steps.append(SignExtend(lay.bits))
    if fn.factor is not None:
        m = fn.eff_multiplier
        steps.append(ScaleFactor(fn.scale_exponent is not None, divisor_of(m), m, fn.eff_offset))
    elif fn.scales:
        steps.append(Scale(divisor_of(fn.eff_multiplier), fn.eff_multiplier, fn.eff_offset))
    return tuple(steps)


def encode_steps(fn: Function, lay: Layout) -> tuple[EncodeStep, ...]:
    steps: list[EncodeStep] = []
    if lay.kind != "string" and (fn.minimum is not None or fn.maximum is not None):
        steps.append(CheckRange(fn.minimum, fn.maximum))
    n = len(lay.addresses)
    if fn.write_function_code and not fn.mask_write:
        from mdl.dsl.cfrag import compile_fragment

        code = fn.write_function_code
        return (*steps, Fragment(code, n, False, compile_fragment(code, n, False)))
    field = bit_fields(fn, lay)
    if field is not None:
        shift, width = field
        if width > 1:
            if fn.scales:
                steps.append(Unscale(divisor_of(fn.eff_multiplier), fn.eff_multiplier, fn.eff_offset))
            steps.append(RoundInt(0, (1 << width) - 1, width, False, width))
        lay_units = units(lay)
        masks = split_value(lay_units, n, ((1 << width) - 1) << shift)
        return (*steps, PlaceBits(shift, width == 1), Split(lay_units), Merge(masks, fn.mask_write))
    if lay.kind == "bool":
        return (*steps, FromBool())
    if lay.kind == "string":
        return (*steps, FromText(units(lay), span_bits(lay) // 8))
    if fn.factor is not None:
        m = fn.eff_multiplier
        steps.append(UnscaleFactor(fn.scale_exponent is not None, divisor_of(m), m, fn.eff_offset))
    elif fn.scales:
        steps.append(Unscale(divisor_of(fn.eff_multiplier), fn.eff_multiplier, fn.eff_offset))
    if lay.kind == "float":
        steps.append(FromFloat(lay.bits))
    else:
        low, high = int_range(lay)
        steps.append(RoundInt(low, high, span_bits(lay), lay.signed, lay.bits))
    return (*steps, Split(units(lay)))


def build(fn: Function, lay: Layout, compiled: CompiledExpression | None = None) -> Codec:
    """The function's IR; `lay` is its layout (mdl.model.layout), computed once by the caller, and
    `compiled` its compiled expression, if it has one (mdl.resolver keeps it)."""
    read_type = value_type(fn, lay, compiled)
    return Codec(
        table=lay.table,
        addresses=lay.addresses,
        value_type=read_type,
        write_type=write_type(fn, lay, compiled, read_type),
        decode=decode_steps(fn, lay, compiled) if fn.readable else None,
        encode=encode_steps(fn, lay) if fn.writable else None,
    )


def shape_key(fn: Function, lay: Layout) -> Hashable | None:
    """Everything `build` reads of a function without an expression, a fragment or function 22,
    apart from its table and addresses: functions of one key have equal types and steps (numbers by
    their repr, which tells 0.0 from -0.0 and 1 from 1.0). None for the others, built alone."""
    if fn.read_function_code is not None or fn.write_function_code is not None:
        return None
    return (
        lay.unit,
        lay.kind,
        lay.bits,
        lay.signed,
        lay.byte_order,
        lay.word_order,
        len(lay.addresses),
        tuple(fn.not_implemented) if fn.not_implemented else (),
        fn.bits,
        fn.scale_exponent is not None,
        fn.scale_by is not None,
        fn.readable,
        fn.writable,
        repr((fn.eff_multiplier, fn.eff_offset, fn.minimum, fn.maximum)),
    )


def build_shared(fn: Function, lay: Layout, built: dict[Hashable, Codec]) -> Codec:
    """`build` of a function without an expression, its steps and types taken from a function of
    the same shape_key built before (`built`, key -> its codec): a large device repeats a few shapes."""
    key = shape_key(fn, lay)
    if key is None:
        return build(fn, lay)
    before = built.get(key)
    if before is None:
        before = built[key] = build(fn, lay)
        return before
    return Codec(lay.table, lay.addresses, before.value_type, before.write_type, before.decode, before.encode)
