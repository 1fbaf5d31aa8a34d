"""What the C and C++ targets share: the integer types' ranges and the bounds a range check compares
with, and `share`, which gives functions of the same value IR one decoder and one encoder (and one
read or write of their run of registers). Each target keeps only its spelling: its types, literals
and templates."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import Generic, Protocol, TypeVar

from mdl.dsl.cfrag.tree import int_range
from mdl.ir import steps as ir
from mdl.model import Function
from mdl.model.layout import address_runs
from mdl.targets.base import Run

# functions decoded by each part of read_all (C and C++): one function of 80,000 lines for 10,000
# functions made g++ -O2 quadratic (26 minutes); parts of this size keep it linear
READ_ALL_PART = 64

_INT_TYPE = re.compile(r"(u?)int(8|16|32|64)_t")


def int_limits(t: str) -> tuple[int, int] | None:
    """The values of a C or C++ integer type (`int16_t`, `uint64_t`, ...; bool: 0 and 1), or None
    for any other type."""
    if t == "bool":
        return 0, 1
    m = _INT_TYPE.fullmatch(t)
    return None if m is None else int_range((int(m.group(2)), not m.group(1)))


@dataclass(frozen=True)
class IntBounds:
    """A range check of a value of an integer type: `low`/`high` the integers nearest inside the
    minimum and maximum, None where no value of the type can be outside (-Wtype-limits: no test is
    printed); `never`: no value of the type is within the bounds."""

    low: int | None
    high: int | None
    never: bool


def int_bounds(minimum: float | None, maximum: float | None, t: str) -> IntBounds | None:
    """The bounds a value of C type t is compared with, if t is an integer type (int_limits)."""
    limits = int_limits(t)
    if limits is None:
        return None
    low = high = None
    never = False
    if minimum is not None:
        edge = math.ceil(minimum)
        never = edge > limits[1]
        low = edge if limits[0] < edge <= limits[1] else None
    if maximum is not None:
        edge = math.floor(maximum)
        never = never or edge < limits[0]
        high = edge if limits[0] <= edge < limits[1] else None
    return IntBounds(low, high, never)


class Shareable(Protocol):
    """A function as a C-like target prints it: `decoder`/`encoder` name its decode_<x>/encode_<x>
    (a shared one's number, or its own identifier, with its body in decode_text/encode_text), and
    `reader`/`writer` the shared read_<k>/write_<j> doing its one read or write, if any."""

    ident: str
    runs: list[Run]
    decoder: str
    encoder: str
    decode_text: str
    encode_text: str
    reader: int | None
    writer: int | None

    @property
    def fn(self) -> Function: ...

    @property
    def deps(self) -> Sequence[object]: ...


F = TypeVar("F", bound=Shareable)


@dataclass
class SharedCode(Generic[F]):
    """`decode_<k>` or `encode_<k>`: the decoder or encoder of `functions` (the first one's
    printing); `reads`: for a decoder, a function whose one run `read_<k>` reads, if several read
    one run; `proto`: for an expression's decoder, its first function, whose parameters it takes."""

    k: int
    functions: list[F]
    text: str
    reads: F | None = None
    proto: F | None = None

    @property
    def first(self) -> F:
        return self.functions[0]

    @property
    def name(self) -> str:
        """The name of the first function it serves (for a comment)."""
        return str(self.first.fn.name)

    @property
    def uses(self) -> int:
        return len(self.functions)


@dataclass
class SharedWriter(Generic[F]):
    """`write_<j>`: encodes a value with `encode_<encoder>` and writes one run of registers, as
    `first` does (with function 15/16 only where `multiple`)."""

    j: int
    encoder: int
    first: F
    multiple: bool


@dataclass
class Shared(Generic[F]):
    decoders: list[SharedCode[F]] = field(default_factory=list)
    encoders: list[SharedCode[F]] = field(default_factory=list)
    writers: list[SharedWriter[F]] = field(default_factory=list)


@dataclass(frozen=True)
class Printing(Generic[F]):
    """How a target shares and prints decoders and encoders. A key says what makes two functions'
    decoders (encoders) the same: None for a function that cannot be read (written), its
    identifier for one whose IR no other has (a fragment). The printers give the first function
    of each key its body."""

    decode_key: Callable[[F], Hashable | None]
    encode_key: Callable[[F], Hashable | None]
    print_decoder: Callable[[F], str]
    print_encoder: Callable[[F], str]
    expression: Callable[[F], bool]  # whether its decoder takes parameters (an expression's, a scaled value's factor)
    # whether its write is more than encoding a value and writing its run (bits: the registers are read
    # and merged, or written with function 22; a scale factor is read first): no shared write_<j>
    own_write: Callable[[F], bool] = lambda f: False


def share(functions: list[F], printing: Printing[F]) -> Shared[F]:
    """Each function's decoder and encoder. Functions of the same key share one decoder and one
    encoder (and those that read or write one run of registers, one function doing it), so that a
    device of 10,000 functions compiles some ten of each and every read and write of a function is
    one call; a function whose key no other has keeps its own, named after it."""
    decoding: dict[Hashable, list[F]] = {}
    encoding: dict[Hashable, list[F]] = {}
    for f in functions:
        key = printing.decode_key(f)
        if key is not None:
            decoding.setdefault(key, []).append(f)
            f.decoder = f.ident
        key = printing.encode_key(f)
        if key is not None:
            encoding.setdefault(key, []).append(f)
            f.encoder = f.ident
    for group in decoding.values():  # printed once per group: its first function's
        group[0].decode_text = printing.print_decoder(group[0])
    for group in encoding.values():
        group[0].encode_text = printing.print_encoder(group[0])
    out: Shared[F] = Shared()
    for group in decoding.values():
        if len(group) > 1:
            first = group[0]
            d = SharedCode(
                len(out.decoders), group, first.decode_text, proto=first if printing.expression(first) else None
            )
            out.decoders.append(d)
            one_run = [f for f in group if len(f.runs) == 1 and not f.deps]
            d.reads = one_run[0] if len(one_run) > 1 else None
            number = str(d.k)
            for f in group:
                f.decoder, f.decode_text = number, ""
            for f in one_run if d.reads is not None else ():
                f.reader = d.k
    writers: dict[tuple[int, bool], list[F]] = {}
    for group in encoding.values():
        if len(group) > 1:
            e = SharedCode(len(out.encoders), group, group[0].encode_text)
            out.encoders.append(e)
            number = str(e.k)
            for f in group:
                f.encoder, f.encode_text = number, ""
                if len(f.runs) == 1 and not printing.own_write(f):
                    writers.setdefault((e.k, bool(f.fn.write_multiple)), []).append(f)
    for (k, multiple), group in writers.items():
        if len(group) > 1:
            w = SharedWriter(len(out.writers), k, group[0], multiple)
            out.writers.append(w)
            for f in group:
                f.writer = w.j
    return out


@dataclass(frozen=True)
class MergeRow:
    """A register of a function with bits, as its write changes it (ir.Merge): `index` in its registers,
    its `address`, `mask` the function's bits in it (0: none) and `keep` the others (~mask)."""

    index: int
    address: int
    mask: int
    keep: int


def merge_rows(codec: ir.Codec) -> list[MergeRow]:
    """The registers a write of a function with bits merges its bits into (none without bits)."""
    merge = ir.find_step(codec.encode, ir.Merge)
    if merge is None:
        return []
    return [
        MergeRow(i, address, mask, ~mask & 0xFFFF)
        for i, (address, mask) in enumerate(zip(codec.addresses, merge.masks, strict=True))
    ]


@dataclass(frozen=True)
class Chunk(Generic[F]):
    """A part of read_all's decoding (`decode_part_<k>`, C `read_all_part_<k>`): its functions, and
    whether they take registers from the buffer and whether an expression among them asks which
    were answered."""

    functions: list[F]
    uses_raw: bool
    uses_have: bool


def chunks(readable: list[F], registers: Callable[[F], int], expression: Callable[[F], bool]) -> list[Chunk[F]]:
    """read_all's functions in parts of READ_ALL_PART, in their order (each after those it needs)."""
    return [
        Chunk(part, any(registers(f) for f in part), any(registers(f) and expression(f) for f in part))
        for part in (readable[i : i + READ_ALL_PART] for i in range(0, len(readable), READ_ALL_PART))
    ]


def ranges(slots: list[int]) -> list[tuple[int, int]]:
    """Sorted slots as (first, end) ranges of consecutive ones: read_all's table of the slots functions
    without an expression need, checked before its values change."""
    return [(start, start + count) for start, count in address_runs(slots)]


def first_slot(slots: Sequence[int]) -> int | None:
    """The first of slots that follow each other (a decoder then reads read_all's buffer in place), else None."""
    if not slots:
        return None
    first = slots[0]
    return first if all(s == first + i for i, s in enumerate(slots)) else None
