"""`mdl read CONNECTION --raw hr:0-9 [--as TYPE]` (SPEC section 14): raw registers without a description,
as mbpoll reads them.

The ranges become a description of their own: one function per value (named `hr:0`, `ir:5`, `co:16`,
`di:3` by table and first wire address), of the format `--as` names, so that the read plan, the
session's checked replies, the output writers and polling of `mdl read` do the rest unchanged.
`--as hex` and `--as bits` read each register as UINT16 and show it as `0x00FF` / `0000000011111111`
(`RawSession`). Bit tables (coils, discrete inputs) always read 0/1, whatever `--as` says.

A raw read reads what the device answers: a range it refuses (exception 2) is read again in smaller
requests, down to one value each, and a value it refuses even alone has no value (null), said in a
warning naming its registers (`RawSession.unanswered`, `refused`), as mbpoll marks a failed register.
A range such as `hr:40001` that the device refuses is said to look like a manual's register number
(Modicon: 40001 is hr:0), as is a bare `--raw 40001`.
"""

from __future__ import annotations

import re

from mdl.device.connection import Connection
from mdl.device.runtime import Session
from mdl.model import BIT_TABLES, Device, Function, Value
from mdl.model.addressing import NAMED_TABLE, TABLE_PREFIX, AddressError, whole_number
from mdl.model.layout import MAX_ADDRESS, MAX_REGISTERS
from mdl.plan import Request
from mdl.records import record
from mdl.resolver import ResolvedDevice, resolve

# --as TYPE -> (MDL format, registers per value); string: the whole range is one value
AS_TYPES: dict[str, tuple[str, int]] = {
    "uint16": ("UINT16", 1),
    "int16": ("INT16", 1),
    "uint32": ("UINT32", 2),
    "int32": ("INT32", 2),
    "float32": ("FLOAT32", 2),
    "uint64": ("UINT64", 4),
    "int64": ("INT64", 4),
    "float64": ("FLOAT64", 4),
    "string": ("STRING", 0),
    "hex": ("UINT16", 1),
    "bits": ("UINT16", 1),
}
SHOWN_AS_TEXT = ("hex", "bits")  # read as UINT16, shown as text
RAW_TABLES = {
    **NAMED_TABLE,
    "co": "coil",
    "holding": "holding",
    "input": "input",
    "discrete": "discrete",
}
RAW_PREFIX = {**TABLE_PREFIX, "coil": "co"}  # the names of the values: hr:0, ir:5, co:16, di:3
_RANGE = re.compile(r"\s*([A-Za-z-]+)\s*:\s*([0-9]+)\s*(?:([-+])\s*([0-9]+)\s*)?", re.ASCII)
TABLE_WORDS = "hr (holding), ir (input), co (coil), di (discrete)"
# how manuals number registers (Modicon): the first digit says the table, the rest counts from 1
MODICON = {"4": "holding", "3": "input", "1": "discrete", "0": "coil"}


def modicon(number: int, digits: int) -> tuple[str, int] | None:
    """(table, wire address) of a Modicon register number (40001 -> holding 0, 300001 -> input 0), or
    None where `number` written with `digits` digits is not one."""
    if digits not in (5, 6):
        return None
    text = f"{number:0{digits}d}"
    table, rest = MODICON.get(text[0]), int(text[1:])
    if table is None or not 1 <= rest <= MAX_ADDRESS + 1:
        return None
    return table, rest - 1


def modicon_hint(rng: RawRange) -> str:
    """`: 40001 looks like a manual's number (Modicon) for hr:0: ...` where a refused range starts at
    what looks like a Modicon number of its own table; "" otherwise."""
    for digits in (5, 6):
        guess = modicon(rng.first, digits)
        if guess is not None and guess[0] == rng.table and len(str(rng.first)) == digits:
            meant = f"{RAW_PREFIX[rng.table]}:{guess[1]}"
            return f": {rng.first} looks like a manual's number (Modicon) for {meant}: did you mean {meant}?"
    return ""


@record
class RawRange:
    """A range of one table, wire addresses `first` to `last`, both included."""

    table: str
    first: int
    last: int

    @property
    def count(self) -> int:
        return self.last - self.first + 1

    def __str__(self) -> str:
        prefix = RAW_PREFIX[self.table]
        return f"{prefix}:{self.first}" if self.first == self.last else f"{prefix}:{self.first}-{self.last}"


def parse_raw_range(text: str) -> RawRange:
    """`TABLE:A`, `TABLE:A-B` (both included) or `TABLE:A+N` (N addresses from A) -> the range; TABLE is
    hr/holding, ir/input, co/coil, di/discrete (case-insensitive); wire addresses 0-65535.
    ValueError (AddressError) saying what is wrong."""
    match = _RANGE.fullmatch(text)
    if match is None:
        bare = text.strip()
        guess = modicon(int(bare), len(bare)) if bare.isascii() and bare.isdigit() else None
        if guess is not None:
            kind, address = guess
            raise AddressError(
                f"'{bare}' names no table: {bare} is how a manual numbers {kind} register {address} (Modicon): "
                f"write {RAW_PREFIX[kind]}:{address}"
            )
        raise AddressError(f"'{text.strip()[:40]}' is not a range: write TABLE:A, TABLE:A-B or TABLE:A+N, e.g. hr:0-9")
    word, first_text, how, second_text = match.groups()
    table = RAW_TABLES.get(word.lower())
    if table is None:
        raise AddressError(f"'{word[:20]}' is not a table: write {TABLE_WORDS}")
    first = whole_number(first_text, "address")
    if second_text is None:
        last = first
    elif how == "+":
        count = whole_number(second_text, "count")
        if count < 1:
            raise AddressError(f"the count in '{text.strip()[:40]}' must be 1 or more")
        last = first + count - 1
    else:
        last = whole_number(second_text, "address")
        if last < first:
            raise AddressError(f"'{text.strip()[:40]}' runs backwards (write {word}:{last}-{first})")
    if last > MAX_ADDRESS:
        raise AddressError(f"address {last} is over {MAX_ADDRESS}")
    return RawRange(table, first, last)


def raw_functions(
    ranges: list[RawRange], as_type: str = "uint16", word_order: str = "big", byte_order: str = "big"
) -> list[Function]:
    """One function per value of the ranges, in the order given (a value named twice is read once).
    ValueError where a register range does not hold whole values of `as_type`."""
    fmt, width = AS_TYPES[as_type]
    out: dict[str, Function] = {}
    for rng in ranges:
        prefix = RAW_PREFIX[rng.table]
        if rng.table in BIT_TABLES:
            for a in range(rng.first, rng.last + 1):
                out.setdefault(
                    f"{prefix}:{a}", Function(f"{prefix}:{a}", str(rng), [a], format="BIT", register_type=rng.table)
                )
            continue
        size = width or rng.count
        if rng.count % size:
            raise ValueError(
                f"{rng} is {rng.count} register{'s' * (rng.count != 1)}, not a whole number of {as_type} values "
                f"({size} registers each)"
            )
        if size > MAX_REGISTERS:
            raise ValueError(f"{rng}: a string of {size} registers is more than one request reads ({MAX_REGISTERS})")
        for a in range(rng.first, rng.last + 1, size):
            name = f"{prefix}:{a}"
            known = out.get(name)
            if known is not None and known.count != size:  # strings of two lengths at one address
                raise ValueError(f"{name} starts two values, {known.description} and {rng}: give one of them")
            out.setdefault(
                name,
                Function(
                    name,
                    str(rng),
                    [a],
                    count=size,
                    format=fmt,
                    register_type=rng.table,
                    word_order=word_order,
                    byte_order=byte_order,
                ),
            )
    return list(out.values())


def raw_device(functions: list[Function]) -> ResolvedDevice:
    """The description the raw read reads with."""
    return resolve(Device("raw", "mdl read --raw", functions, version="1.0"))


def shown_as(value: Value, as_type: str) -> Value:
    """A register's value as `--as hex` (0x00FF) or `--as bits` (16 binary digits) shows it."""
    if not isinstance(value, int) or isinstance(value, bool):
        return value
    return f"0x{value:04X}" if as_type == "hex" else f"{value:016b}"


class RawSession(Session):
    """A session of a raw read: values of register functions shown as `as_type` says; a value the device
    refuses even alone is null, and listed in `unanswered` (name -> the request refused)."""

    def __init__(self, resolved: ResolvedDevice, connection: Connection, unit: int, as_type: str):
        super().__init__(resolved, connection, unit)
        self.as_type = as_type
        self.unanswered: dict[str, Request] = {}

    def without_value(self, unanswered: list[tuple[str, Request]]) -> None:
        self.unanswered.update(unanswered)

    def read(self, functions: list[Function]) -> dict[str, Value]:
        values = super().read(functions)
        if self.as_type not in SHOWN_AS_TEXT:
            return values
        tables = {fn.name: fn.table for fn in functions}
        return {
            name: value if tables.get(name) in BIT_TABLES else shown_as(value, self.as_type)
            for name, value in values.items()
        }


def refused(functions: list[Function], unanswered: dict[str, Request], ranges: list[RawRange]) -> list[str]:
    """The warnings for values the device refused: one per run of neighbouring values (`hr:8-9`), in
    the order read, with the Modicon hint where a range given looks like a manual's number."""
    runs: list[list[Function]] = []
    for fn in functions:
        if fn.name not in unanswered:
            continue
        if runs and runs[-1][-1].table == fn.table and _end(runs[-1][-1]) + 1 == fn.addresses[0]:
            runs[-1].append(fn)
        else:
            runs.append([fn])
    out = []
    for run in runs:
        first, last = run[0], run[-1]
        span = RawRange(first.table, first.addresses[0], _end(last))
        hint = next((modicon_hint(r) for r in ranges if r.table == span.table and r.first == span.first), "")
        out.append(f"{span}: the device answers Modbus exception 2 (ILLEGAL DATA ADDRESS): no value{hint}")
    return out


def _end(fn: Function) -> int:
    return fn.addresses[0] + (fn.count or 1) - 1
