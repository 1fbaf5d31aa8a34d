"""Where a function's value lives and how wide it is (SPEC section 2.3).

One rule for every consumer (codec, read plan, simulator, generators):
- a function reads `n` units: one register (or bit) each; a unit is a full word, the lower or
  upper byte of a register, or one coil/discrete bit;
- `n` is the number of listed addresses, or, where one address is given, the larger of `count`
  and what the format needs; the following consecutive addresses are then read;
- integers are `n * unit` bits wide, except that one full word holding an 8-bit format is read
  as that 8-bit type (C's conversion keeps the lower byte);
- FLOAT32/FLOAT64 must span exactly 32/64 bits; STRING spans all its units.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal

from mdl.model import BIT_TABLES, CompiledExpression, Function
from mdl.records import record

MAX_REGISTERS = 125
MAX_BITS = 2000
MAX_ADDRESS = 65535

FORMAT_BITS = {
    "INT8": 8,
    "UINT8": 8,
    "INT16": 16,
    "UINT16": 16,
    "INT32": 32,
    "UINT32": 32,
    "INT64": 64,
    "UINT64": 64,
    "FLOAT32": 32,
    "FLOAT64": 64,
    "STRING": 8,
    "BIT": 1,
}
Unit = Literal["word", "low", "high", "bit"]  # a full word, the lower or upper byte of a register, a bit
Kind = Literal["int", "float", "string", "bool", "expr"]  # expr: computed by an expression
UNIT_FOR_LENGTH: dict[str, Unit] = {"Full word": "word", "Lower byte": "low", "Upper byte": "high"}


class LayoutError(ValueError):
    """The function cannot be read as written; the message says why."""


@record
class Layout:
    table: str
    addresses: tuple[int, ...]
    unit: Unit
    kind: Kind
    bits: int
    signed: bool
    byte_order: str
    word_order: str

    @property
    def runs(self) -> tuple[tuple[int, int], ...]:
        """(start, count) of each run of consecutive addresses, in the order the addresses are listed:
        the requests that read (or write) the function alone."""
        return address_runs(self.addresses)

    @property
    def unit_bits(self) -> int:
        return {"word": 16, "low": 8, "high": 8, "bit": 1}[self.unit]


def layout(fn: Function, compiled: CompiledExpression | None = None) -> Layout:
    """The function's layout; a function with an expression reads the registers of its `compiled`
    expression (LayoutError without one: the expression has errors, or was not compiled)."""
    if fn.expression is not None:
        if compiled is None:
            raise LayoutError("the expression has errors")
        lowered = compiled.lowered
        table = lowered.table or "holding"
        unit: Unit = "bit" if table in BIT_TABLES else "word"
        return Layout(table, tuple(lowered.addresses), unit, "expr", 0, False, "big", "big")
    # the defaults of eff_format, table, eff_length, eff_count and the orders spelled out, and the
    # addresses read once: every function is laid out at least once
    fmt = fn.format or "INT8"
    table = fn.register_type or "holding"
    bit_table = table in BIT_TABLES
    if bit_table and fmt != "BIT" and fn.format is not None:
        raise LayoutError(f"a {table} holds one bit; format {fmt} needs registers (use BIT)")
    if bit_table or fmt == "BIT":
        unit = "bit" if bit_table else "word"
        needed = 1
    else:
        unit = UNIT_FOR_LENGTH[fn.length or "Full word"]
        unit_bits = 16 if unit == "word" else 8
        needed = max(1 if fn.count is None else fn.count, -(-FORMAT_BITS[fmt] // unit_bits))
    listed = fn.addresses
    if not listed:
        raise LayoutError("no address")
    n = len(listed) if len(listed) > 1 else needed
    limit = MAX_BITS if unit == "bit" else MAX_REGISTERS
    if n > limit:  # before any tuple of n addresses is built: a count may be 3000000000
        raise LayoutError(f"the value needs {n} registers; one request reads at most {limit}")
    if len(listed) > 1:
        if len(listed) < needed:
            raise LayoutError(f"needs {needed} registers but lists {len(listed)} addresses")
        if len(set(listed)) != len(listed):
            raise LayoutError("an address is listed twice")
        addresses = tuple(listed)
    else:
        addresses = tuple(range(listed[0], listed[0] + needed))
    if max(addresses) > MAX_ADDRESS:
        raise LayoutError(f"address {next(a for a in addresses if a > MAX_ADDRESS)} is over {MAX_ADDRESS}")
    if bit_table or fmt == "BIT":
        if n != 1:
            raise LayoutError("a BIT value is one coil or discrete input")
        return Layout(table, addresses, unit, "bool", 1, False, "big", "big")
    span = n * (16 if unit == "word" else 8)
    byte_order, word_order = fn.byte_order or "big", fn.word_order or "big"
    if fmt == "STRING":
        return Layout(table, addresses, unit, "string", span, False, byte_order, word_order)
    if fmt.startswith("FLOAT"):
        if span != FORMAT_BITS[fmt]:
            raise LayoutError(f"{fmt} needs exactly {FORMAT_BITS[fmt]} bits; the function spans {span}")
        return Layout(table, addresses, unit, "float", span, True, byte_order, word_order)
    bits = FORMAT_BITS[fmt] if (unit == "word" and n == 1 and FORMAT_BITS[fmt] == 8) else span
    if bits > 64:
        raise LayoutError(f"an integer of {bits} bits is wider than 64 (format {fmt}, {n} units)")
    return Layout(table, addresses, unit, "int", bits, not fmt.startswith("U"), byte_order, word_order)


def address_runs(addresses: Iterable[int]) -> tuple[tuple[int, int], ...]:
    """(start, count) of each run of addresses that follow each other by one."""
    if isinstance(addresses, tuple) and addresses:  # a layout's (most often one run): told at once
        first, n = addresses[0], len(addresses)
        if addresses[-1] - first == n - 1 and (n < 3 or addresses == tuple(range(first, first + n))):
            return ((first, n),)
    out: list[tuple[int, int]] = []
    for a in addresses:
        if out and a == out[-1][0] + out[-1][1]:
            out[-1] = (out[-1][0], out[-1][1] + 1)
        else:
            out.append((a, 1))
    return tuple(out)


def layouts_by_name(functions: Iterable[Function]) -> dict[str, Layout]:
    """name -> layout of each function, computed once each (LayoutError as `layout` raises it)."""
    return {fn.name: layout(fn) for fn in functions}


def int_type_bits(bits: int) -> int:
    """The C integer width that holds `bits` bits."""
    for width in (8, 16, 32, 64):
        if bits <= width:
            return width
    raise LayoutError(f"{bits} bits do not fit a 64-bit integer")


def integer_range(bits: int, signed: bool) -> tuple[int, int]:
    """The integers `bits` bits hold, both ends included (two's complement when signed): the one home of
    a width's range for the checks, the encoders, the exports and the gateway."""
    return (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)
