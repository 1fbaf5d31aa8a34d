"""The value IR: what each function's value is, as a short list of language-neutral steps.

`mdl.ir.build` turns a resolved function into a `Codec` once; the Python evaluator
(`mdl.ir.codec` per function, `mdl.device.evaluate.Evaluator` per device) runs it for
`mdl read`/`write`/`sim --set`/`test`, and each target (`mdl.targets.<lang>`) prints it. Every
step below says exactly what it computes, so that the evaluator and every target compute the same bits.

Decoding starts from `r`, the function's registers (or bits) in address order, and a 64-bit
unsigned accumulator `v`:

- `NotImplemented(patterns)`: if `r` equals one of the patterns (a value per register), the value
  is null (None / std::nullopt / the C driver's `has_` flag false). Always first when present.
- `Fragment(code, nregs)`: the read fragment's `arg` (a double) is the value. Ends the program.
- `Expression(lowered, deps)`: the Toolkit expression's value. Ends the program.
- `ToBool()`: the value is `r[0] != 0`. Ends the program.
- `Compose(units)`: `v = OR of unit << shift` over the units (see `Unit`).
- `ToText(units, nbytes)`: the units' bytes, most significant first, without trailing NUL and
  space bytes, read as UTF-8 (a malformed sequence as U+FFFD in Python). Ends the program.
- `Mask(bits)`: `v &= 2**bits - 1` (an 8-bit format in a full word keeps the lower byte).
- `SignExtend(bits)`: `v` as a signed `bits`-bit integer.
- `ToFloat(bits)`: `v` as the IEEE 754 float of `bits` (32 or 64) bits; a float32 widens to double.
- `Scale(divisor, multiplier, offset)`: the rounding rule of every target. `x = double(v)`; then
  `x = x / divisor` when the multiplier is the exact reciprocal of an integer (0.1 -> / 10, so 87
  reads 8.7, the double nearest 87 * 0.1), else `x = x * multiplier`; then, as a separate
  operation (never a fused multiply-add), `x = x + offset` when the offset is not 0.
- `Bits(shift, width, boolean)`: `v = (v >> shift) & (2**width - 1)`; `boolean`: the value is
  `v != 0`, which ends the program (SPEC 2.2 `bits`).
- `ScaleFactor(exponent, divisor, multiplier, offset)`: the value of another function, `f` (the
  decoder's one parameter), scales it: null where `f` is null (or, for an exponent, outside
  -22..22); `x = double(v)`, then `x / divisor` or `x * multiplier` as `Scale` (neither when the
  multiplier is 1); then for an exponent `p = 10^|f|` (exact: 1.0 multiplied by 10.0 |f| times),
  `x = x * p` for f >= 0 and `x = x / p` below; for `scale_by` `x = x * double(f)`; then the offset.

Encoding starts from `value` and ends with `r`:

- `CheckRange(minimum, maximum)`: a value below/above the bound (or NaN) is refused.
- `Fragment(code, nregs)`: the write fragment sets `r`. Ends the program.
- `FromBool()`: `r[0] = 1 if value else 0`. Ends the program.
- `FromText(units, nbytes)`: the UTF-8 bytes, NUL-padded; longer text is refused; then split.
- `Unscale(divisor, multiplier, offset)`: `x = value - offset` (when the offset is not 0), then
  `x = x * divisor`, or `x = x / multiplier`; in doubles.
- `FromFloat(bits)`: `v` = the IEEE bits of `x` (rounded to float32 for 32 bits).
- `RoundInt(low, high, span)`: a non-finite `x` is refused; `x = floor(x + 0.5)` for a
  fraction; outside `low..high` is refused; `v = x mod 2**span`.
- `Split(units)`: each unit of `v` back into its register (the inverse of `Compose`).
- `UnscaleFactor(exponent, divisor, multiplier, offset)`: as `Unscale`, with the factor `f` (the
  encoder's second parameter, read from the device just before) inverted after it: refused when `f`
  is null (or, for an exponent, outside -22..22; for `scale_by`, 0); `x = x / p` for f >= 0, `x = x * p`
  below; `x = x / double(f)`.
- `PlaceBits(shift, boolean)`: `v = (1 if value else 0) << shift` (boolean), or `v = v << shift`.
- `Merge(masks)`: after `Split`, the registers hold only the function's bits: each register `i` is
  written as `(current[i] & ~masks[i]) | r[i]`, `current` read just before the write; with Mask
  Write Register (`mask_write`), one request per register with a mask: AND `~masks[i]`, OR `r[i]`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, TypeAlias, TypeVar

from mdl.records import record

if TYPE_CHECKING:
    from mdl.dsl.cfrag import Fragment as FragmentTree
    from mdl.dsl.expr.lower import Lowered

T = TypeVar("T")

# the exponents of scale_exponent whose power of ten every target computes exactly (10^22 is the largest
# exact double); outside them a value has no number
MAX_EXPONENT = 22

Part = Literal["word", "swap", "low", "high"]  # the register as is, its bytes swapped, its low / high byte


@record
class Unit:
    """One unit of a composed value: `(part of r[index]) << shift`. For `low` and `high` the part
    is the byte value (0..255); `high` puts it back into bits 8-15 when splitting."""

    index: int
    part: Part
    shift: int


@record
class NotImplemented:
    patterns: tuple[tuple[int, ...], ...]


@record
class Fragment:
    code: str  # the checked fragment text (mdl.dsl.cfrag compiles it for each target)
    nregs: int
    reading: bool
    tree: FragmentTree


@record
class Expression:
    lowered: Lowered
    deps: tuple[str, ...]  # the function names it refers to, in parameter order


@record
class ToBool:
    pass


@record
class Compose:
    units: tuple[Unit, ...]


@record
class ToText:
    units: tuple[Unit, ...]
    nbytes: int


@record
class Mask:
    bits: int


@record
class SignExtend:
    bits: int


@record
class ToFloat:
    bits: int


@record
class Scale:
    divisor: int | None  # x / divisor, when the multiplier is its exact reciprocal
    multiplier: float  # else x * multiplier
    offset: float


@record
class Bits:
    shift: int
    width: int
    boolean: bool


@record
class ScaleFactor:
    exponent: bool  # True: scale_exponent (10^f), False: scale_by (f)
    divisor: int | None
    multiplier: float  # 1.0: no multiplier
    offset: float


@record
class UnscaleFactor:
    exponent: bool
    divisor: int | None
    multiplier: float
    offset: float


@record
class PlaceBits:
    shift: int
    boolean: bool


@record
class Merge:
    masks: tuple[int, ...]  # per register, address order: the bits the function owns
    mask_write: bool  # write with function 22 (Mask Write Register) instead of read-modify-write


@record
class CheckRange:
    minimum: float | None
    maximum: float | None


@record
class FromBool:
    pass


@record
class FromText:
    units: tuple[Unit, ...]
    nbytes: int


@record
class Unscale:
    divisor: int | None
    multiplier: float
    offset: float


@record
class FromFloat:
    bits: int


@record
class RoundInt:
    low: int
    high: int
    span: int  # bits of v that reach the registers
    signed: bool
    bits: int  # the integer's own width, for messages ("does not fit int16")


@record
class Split:
    units: tuple[Unit, ...]


DecodeStep: TypeAlias = (
    NotImplemented
    | Fragment
    | Expression
    | ToBool
    | Compose
    | ToText
    | Mask
    | SignExtend
    | ToFloat
    | Scale
    | Bits
    | ScaleFactor
)
EncodeStep: TypeAlias = (
    CheckRange
    | Fragment
    | FromBool
    | FromText
    | Unscale
    | UnscaleFactor
    | FromFloat
    | RoundInt
    | PlaceBits
    | Split
    | Merge
)

ValueKind = Literal["int", "float", "string", "bool", "expr"]


@record
class ValueType:
    """The type of a function's value, which every target spells its own way.

    kind int: an integer of `bits` (8/16/32/64) bits, `signed`; float: a float of `bits` (32/64)
    bits (a scaled or fragment value is a 64-bit float); string: text of at most `nbytes` bytes;
    bool; expr: a Toolkit expression's type `expr_type` (long, double, string, bool, list).
    `nullable`: the value may be null ("not implemented", an expression's null)."""

    kind: ValueKind
    bits: int = 0
    signed: bool = False
    nbytes: int = 0
    nullable: bool = False
    expr_type: str = ""


def find_step(steps: tuple[DecodeStep, ...] | tuple[EncodeStep, ...] | None, kind: type[T]) -> T | None:
    """The step of that kind in a program, if it has one (a plain loop: every target asks it of every
    function several times)."""
    for step in steps or ():
        if isinstance(step, kind):
            return step
    return None


@record
class Codec:
    """A function's value IR. `decode` is None for a function that cannot be read, `encode` for
    one that cannot be written; `write_type` is the type a write takes (a number for fragments)."""

    table: str
    addresses: tuple[int, ...]
    value_type: ValueType
    write_type: ValueType
    decode: tuple[DecodeStep, ...] | None
    encode: tuple[EncodeStep, ...] | None
