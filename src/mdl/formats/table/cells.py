"""Reading the cells of vendor register tables: addresses, formats, lengths, numbers."""

from __future__ import annotations

import re
import struct
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, TypeVar, cast

from mdl.diagnostics import shown
from mdl.formats.table.lazy import lazy
from mdl.model.addressing import (
    MODICON_TABLE,
    NAMED,
    AddressError,
    address_range,
    address_run,
    match_address,
    whole_number,
)
from mdl.model.layout import MAX_ADDRESS


class CellError(ValueError):
    """A cell that cannot be understood; the message says what it holds."""


F = TypeVar("F", bound=Callable[..., Any])


def cell_cache(reader: F) -> F:
    """`reader`, keeping what it read of the last 4,096 distinct cells. A cell's reading depends on its
    text alone and is immutable, and a column repeats its cells (int16, 0.1, R/W) thousands of times:
    each is read once. A cell it refuses is read again each time (no CellError is kept)."""
    return cast(F, lru_cache(maxsize=4096)(reader))


_HEX = lazy(r"(?i)^0x[0-9a-f]+h?$|^[0-9a-f]+h$")
_RANGE = lazy(r"(?i)^(.+?)\s*(?:\bto\b|to|\.\.|-|–|—|~|～)\s*(.+)$")  # ～: the full-width tilde


_SPACE_RUN = lazy(r"\s+")


def squeeze(text: str) -> str:
    """`text` with each run of whitespace one character: a line break if it holds one, else a space.
    An address cell is read after this, so that no pattern's `\\s*` walks a long run from each of its
    characters (quadratic: `1`, 20,000 spaces, `x`)."""
    return _SPACE_RUN().sub(lambda m: "\n" if "\n" in m.group() else " ", text)


_LISTED = lazy(r"^\s*([0-9]+)\.\s*$")


def unlisted(text: str) -> str:
    """A number written as a numbered list writes it (`35.`: Growatt's input registers) as the number;
    any other text as it is."""
    m = _LISTED().match(text)
    return m.group(1) if m else text


def is_digits(text: str) -> bool:
    """ASCII decimal digits only (str.isdigit() also takes '²' and other scripts' digits, which int() refuses)."""
    return text.isascii() and text.isdigit()


def _number(digits: str, what: str) -> int:
    try:
        return whole_number(digits, what)
    except AddressError as exc:
        raise CellError(str(exc)) from None


def _addresses(build: Callable[[int, int], range], first: int, other: int, part: str) -> list[int]:
    try:
        return list(build(first, other))
    except AddressError as exc:
        raise CellError(f"{shown(part)}: {exc}") from None


def is_modicon_number(text: str) -> bool:
    t = text.strip()
    return is_digits(t) and len(t) in (5, 6) and t[0] in MODICON_TABLE and int(t[1:]) >= 1


# `hreg 6`, `coil 1`: a table's word, a space, the address (counted as plain numbers are: address_base)
WORDED_TABLES = {
    "hreg": "holding",
    "holding": "holding",
    "hr": "holding",
    "ireg": "input",
    "input": "input",
    "ir": "input",
    "coil": "coil",
    "co": "coil",
    "dinput": "discrete",
    "discrete": "discrete",
    "di": "discrete",
    "istat": "discrete",
}
_WORDED = lazy(r"^([A-Za-z]+)\s+([0-9]{1,12})$")


def _one(text: str, base: str) -> tuple[int, str | None]:
    """One address token -> (wire address, table or None)."""
    t = text.strip()
    if is_digits(t):  # no notation below reads plain digits (each needs a letter, `:` or `#`)
        return _plain(t, base)
    try:  # 0x... is hexadecimal here, not a Modicon coil; plain digits follow the address base
        found = match_address(t, modicon_digits=False, x_coils=False)
    except AddressError as exc:
        raise CellError(str(exc)) from None
    if found and found[2] == len(t):
        return found[1], found[0]
    if _HEX().match(t):
        digits = t.lower().removeprefix("0x").removesuffix("h").lstrip("0")
        if len(digits) > 12:
            raise CellError(f"address '{t[:20]}...' is too large")
        return int(digits or "0", 16), None
    worded = _WORDED().match(t)
    if worded and worded.group(1).lower() in WORDED_TABLES:
        number, _ = _one(worded.group(2), "0" if base == "modicon" else base)
        return number, WORDED_TABLES[worded.group(1).lower()]
    raise CellError(f"{shown(t)} is not an address")


def _plain(t: str, base: str) -> tuple[int, str | None]:
    """A plain number (ASCII digits) as the address base reads it."""
    if base == "modicon":
        if not is_modicon_number(t):
            raise CellError(f"{shown(t)} is not a Modicon 5- or 6-digit register number")
        return int(t[1:]) - 1, MODICON_TABLE[t[0]]
    value = _number(t, "address")
    if base == "1":
        if value < 1:
            raise CellError(f"{shown(t)} is not a 1-based address")
        return value - 1, None
    return value, None


def hexify(text: str) -> str:
    """An address cell of a column whose header says hex: every plain number is hexadecimal."""
    return re.sub(r"(?i)(?<![\w:])(?:0x)?([0-9a-f]+)(?!\w)", lambda m: "0x" + m.group(1), text)


_LINES = lazy(r"\s*\n\s*")
_LIST = lazy(r"\s*[,;\n]\s*")  # `31003 (1002)` on each line of a list
_PARTS = lazy(r"\s*[,;/&\n]\s*|\s+and\s+")  # the parts of an address cell (parse_addresses)
_BIT_OF = lazy(r"^\s*([0-9]+|0x[0-9a-fA-F]+)\s*([./]|\.[bB])\s*([0-9]{1,2})\s*$")  # 40001.3, 40001/3, 0x0103.b8
_BRACKETED = lazy(r"^\s*([0-9]+)\s*\(\s*([0-9]+|0x[0-9a-fA-F]+)\s*\)\s*$")


@dataclass
class AddressCell:
    """What an address cell says: its wire addresses, the table it names, a bit of the register. (Not
    frozen: one is made for every row, and a frozen dataclass is made several times slower.)"""

    addresses: list[int]
    table: str | None = None
    bits: str | None = None  # `40001.3`, `40001/3`: register, then bit
    said: str | None = None  # how a cell that could be read two ways was read (for a note)


def bit_of(text: str) -> re.Match[str] | None:
    """A register-then-bit cell (`40001.3`, `40001/3`, `0x0103.b8`; `17/18`, whose second number is no bit
    below the first, is a list): the register is group 1, the bit group 3."""
    m = _BIT_OF().match(text)
    if m and int(m.group(3)) <= 15 and (m.group(2) != "/" or int(m.group(3)) < int(m.group(1), 0)):
        return m
    return None


def read_address_cell(text: str, base: str = "0") -> AddressCell:
    """An address cell (parse_addresses), also `40001.3` / `40001/3` (register, then bit: `17/18`, whose
    second number is no bit below the first, stays a list) and `30101 (100)` (a register number and the
    wire address in brackets: the bracket wins, and the two must agree); `35.` is 35."""
    t = text.strip()
    if is_digits(t):  # most cells: one plain number, which every form below reads as _one does
        address, table = _plain(t, base)
        if address > MAX_ADDRESS:
            raise CellError(f"address {address} is over {MAX_ADDRESS}")
        return AddressCell([address], table)
    text = squeeze(unlisted(text))
    iec = [p for p in _LINES().split(text.strip()) if p]
    if iec and all(_IEC().match(p) for p in iec):
        return _iec_address(text, iec)
    m = bit_of(text)
    if m:
        addresses, table = parse_addresses(m.group(1), base)
        said = None
        if m.group(2) == "/":
            said = f"{shown(text.strip())} read as bit {int(m.group(3))} of register {m.group(1)}, not as a list of two"
        return AddressCell(addresses, table, str(int(m.group(3))), said)
    parts = [p for p in _LIST().split(text.strip()) if p]
    if len(parts) > 1 and all(_BRACKETED().match(p) for p in parts):  # `31003 (1002)` on each line of a list
        cells = [read_address_cell(p, base) for p in parts]
        tables = {c.table for c in cells} - {None}
        if len(tables) > 1:
            raise CellError(f"{shown(' '.join(text.split()))} mixes register tables")
        addresses = [a for c in cells for a in c.addresses]
        if len(set(addresses)) != len(addresses):
            raise CellError(f"{shown(' '.join(text.split()))} lists an address twice")
        return AddressCell(addresses, tables.pop() if tables else None)
    m = _BRACKETED().match(text)
    if m:
        number, wire = m.group(1), int(m.group(2), 0)
        table = MODICON_TABLE[number[0]] if is_modicon_number(number) else None
        agree = {int(number), int(number) - 1} | ({int(number[1:]) - 1} if table else set())
        if wire not in agree:
            raise CellError(
                f"{shown(text.strip())}: register {number} and the address {m.group(2)} in brackets disagree "
                f"({number} is address {int(number[1:]) - 1 if table else int(number) - 1})"
            )
        if wire > MAX_ADDRESS:
            raise CellError(f"address {wire} is over {MAX_ADDRESS}")
        return AddressCell([wire], table)
    return AddressCell(*parse_addresses(text, base))


# IEC 61131-3's based numbers, as Schneider's drives print addresses: `16#2136`, with the decimal after
# it (`16#2136 = 08502`) and a remark (`16#219B = 8603 (speed)`)
_IEC = lazy(r"^(2|8|16)#([0-9A-Fa-f][0-9A-Fa-f_]*)(?:\s*=\s*([0-9]+))?(?:\s*\(([^()]{0,40})\))?$")


def _iec_address(text: str, lines: list[str]) -> AddressCell:
    """`16#2136` or `16#2136 = 08502` (the two must agree) -> the address; a cell with one such address on
    each of several lines names one register per remark (`(speed)`, `(frequency)`: the drive's profile),
    not a list: an error saying so (the row is skipped; `[function NAME] addresses =` gives the one meant)."""
    if len(lines) > 1:
        remarks = [m.group(4) for m in map(_IEC().match, lines) if m and m.group(4)]
        why = f", one for each of {', '.join(repr(r) for r in remarks)}" if remarks else ""
        raise CellError(
            f"{shown(' '.join(text.split()))} names {len(lines)} addresses{why}: one register is meant "
            "(give it in [function NAME] addresses =)"
        )
    m = _IEC().match(lines[0])
    assert m is not None
    radix, digits, decimal = int(m.group(1)), m.group(2).replace("_", ""), m.group(3)
    try:
        address = int(digits, radix)
    except ValueError:
        raise CellError(f"{shown(lines[0])}: {digits!r} is not a base-{radix} number") from None
    if decimal is not None and int(decimal) != address:
        raise CellError(f"{shown(lines[0])}: {m.group(1)}#{digits} is {address}, not {int(decimal)}")
    if address > MAX_ADDRESS:
        raise CellError(f"address {address} is over {MAX_ADDRESS}")
    return AddressCell([address], None)


def parse_addresses(text: str, base: str = "0") -> tuple[list[int], str | None]:
    """An address cell -> (wire addresses in order, table named by the cell or None).

    Accepts numbers, hex, Modicon numbers (when base is 'modicon'), 4x0102, hr:101 ...,
    ranges (`0 to 3`, `22to100`, `566 - 583`, `hr:2..hr:5`, `hr:2#4`) and lists (`17,18,19`).
    """
    text = squeeze(text).strip()
    if not text:
        raise CellError("the address cell is empty")
    parts = [p for p in _PARTS().split(text) if p]
    addresses: list[int] = []
    table = None
    for part in parts:
        if "#" in part:
            first, _, count = part.partition("#")
            start, tbl = _one(first, base)
            if not is_digits(count.strip()):
                raise CellError(f"{shown(part)}: the count after '#' must be a positive number")
            run = _addresses(address_run, start, _number(count.strip(), "count"), part)
        else:
            m = _RANGE().match(part)
            if m and not NAMED.fullmatch(part.strip()) and not is_digits(part.strip().lstrip("-")):
                start, tbl = _one(m.group(1), base)
                end, tbl2 = _one(m.group(2), base)
                if tbl2 and tbl and tbl != tbl2:
                    raise CellError(f"{shown(part)} mixes register tables")
                tbl = tbl or tbl2
                run = _addresses(address_range, start, end, part)
            else:
                start, tbl = _one(part, base)
                run = [start]
        if tbl and table and tbl != table:
            raise CellError(f"{shown(text)} mixes register tables")
        table = table or tbl
        addresses += run
    if any(a > MAX_ADDRESS for a in addresses):
        raise CellError(f"address {max(addresses)} is over {MAX_ADDRESS}")
    if len(set(addresses)) != len(addresses):
        raise CellError(f"{shown(text)} lists an address twice")
    return addresses, table


FORMAT_WORDS = [
    (r"(?:ieee\s*754\s*)?(?:float|real|single|fp|ieee\s*754)\s*(?:32)?|f32|float32", "FLOAT32"),
    (r"(?:ieee\s*754\s*)?(?:double|float\s*64|real\s*64|lreal)|f64|ieee\s*754\s*64", "FLOAT64"),
    (r"(?:u|unsigned\s*|uint)\s*64|uint64_t|ulong\s*long|u?qword", "UINT64"),
    (r"(?:s|i|signed\s*|int)\s*64|int64_t|long\s*long", "INT64"),
    (r"(?:u|unsigned\s*|uint)\s*32|uint32_t|udint|ulong|dword", "UINT32"),
    (r"(?:s|i|signed\s*|int)\s*32|int32_t|dint|long", "INT32"),
    (r"(?:u|unsigned\s*|uint)\s*16|uint16_t|uint|word|unsigned(?:\s*int)?|ushort", "UINT16"),
    (r"(?:s|i|signed\s*|int)\s*16|int16_t|int|integer|short|signed", "INT16"),
    (r"(?:u|unsigned\s*|uint)\s*8|uint8_t|byte|uchar|usint", "UINT8"),
    (r"(?:s|i|signed\s*|int)\s*8|int8_t|sint|char", "INT8"),
    (r"bool(?:ean)?|bit|coil|binary|digital", "BIT"),
]
_FORMATS = [(lazy(rf"(?i)^(?:{pattern})$"), fmt) for pattern, fmt in FORMAT_WORDS]
_STRING = lazy(
    r"(?i)^(?:char|string|str|ascii|text)\s*[\[(]\s*([0-9]+)\s*[\])]$"
    r"|^(?:string|str|ascii|text)([0-9]*)$"
)


# format words that give no width (some projects mean 32 bits by INT): read as one register, and said
_WIDTHLESS = lazy(r"(?i)^(?:u?int|integer|signed(?:\s*int)?|unsigned(?:\s*int)?)$")
# a Python struct type as VOLTTRON's register maps write them: byte order, then one code, with a pad
# byte (x) beside a one-byte code (>xB: the lower byte of a register, >Bx: the upper)
_STRUCT_TYPE = lazy(r"^([<>=!])(x?)([bBhHiIlLqQfd])(x?)$")
STRUCT_ORDERS = {"<": "little", ">": "big", "!": "big", "=": "little"}  # '=': the host's order (x86, ARM: little)


@dataclass(frozen=True)
class TypeCell:
    """What a format cell says: the MDL format, and what else it fixes."""

    format: str
    strlen: int | None = None  # characters of a string
    length: str | None = None  # a struct type with a pad byte: "Lower byte" or "Upper byte"
    order: str | None = None  # a struct type's byte order, which is its word order too (< reverses all bytes)
    native: bool = False  # '=': the order of the host, read as little-endian
    widthless: bool = False  # INT, UINT ...: no width said, read as one register
    bits: str | None = None  # `bit 3`, `bool (bit 3)`, `B3`: one bit of a register (format UINT16)


def _struct_type(t: str) -> TypeCell | None:
    m = _STRUCT_TYPE().match(t)
    if m is None:
        return None
    prefix, pad_before, code, pad_after = m.groups()
    size = struct.calcsize(prefix + code)  # with a prefix, the standard sizes: i 4, l 4, q 8
    fmt = f"FLOAT{8 * size}" if code in "fd" else f"{'INT' if code.islower() else 'UINT'}{8 * size}"
    if size == 1:
        if bool(pad_before) == bool(pad_after):
            raise CellError(
                f"struct type {shown(t)} is one byte: it needs one pad byte to fill a register "
                f"('{prefix}x{code}' the lower byte, '{prefix}{code}x' the upper)"
            )
        return TypeCell(fmt, length="Lower byte" if pad_before else "Upper byte")
    if pad_before or pad_after:
        raise CellError(f"struct type {shown(t)}: a pad byte (x) beside a value of {size} bytes fills no register")
    return TypeCell(fmt, order=STRUCT_ORDERS[prefix], native=prefix == "=")


_BIT_CELL = lazy(r"(?i)^(?:bool(?:ean)?\s*\(\s*bits?\s*([0-9]{1,2})\s*\)|bits?\s*([0-9]{1,2})|b([0-9]{1,2}))$")
_BIT_RANGE = lazy(r"(?i)^(?:bits?\s*)?([0-9]{1,2})(?:\s*(?:-|\.\.|to)\s*([0-9]{1,2}))?$")


@cell_cache
def parse_bit_cell(text: str) -> str:
    """A cell of a `bits` column (`3`, `0-3`, `bit 3`, `bool (bit 3)`, `B3`) -> MDL bits ("3", "0-3")."""
    t = " ".join(text.strip().split())
    m = _BIT_CELL().match(t)
    if m:
        return str(int(next(g for g in m.groups() if g is not None)))
    m = _BIT_RANGE().match(t)
    if m:
        return str(int(m.group(1))) + (f"-{int(m.group(2))}" if m.group(2) is not None else "")
    raise CellError(f"unknown bits {shown(text.strip())} (expected a bit number such as 3 or B3, or a range 0-3)")


@cell_cache
def read_type(text: str) -> TypeCell:
    """A format cell -> TypeCell: the vendors' words (`int16`, `S16`, `float`, `char[8]` ...), Python
    struct types (`>I`, `<h`, `>f`, `>xB`, as VOLTTRON's maps write them) and a bit of a register
    (`bit 3`, `bool (bit 3)`, `B3`: UINT16 and its bit)."""
    t = " ".join(text.strip().split())
    m = _BIT_CELL().match(t)
    if m:
        return TypeCell("UINT16", bits=parse_bit_cell(t))
    found = _struct_type(t)
    if found is not None:
        return found
    m = _STRING().match(t)
    if m:
        n = m.group(1) or m.group(2)
        return TypeCell("STRING", _number(n, "string length") if n else None)
    for rx, fmt in _FORMATS:
        if rx().match(t):
            return TypeCell(fmt, widthless=bool(_WIDTHLESS().match(t)))
    m = _REMARKED().match(t)
    if m:  # `INT (Signed16)`, `WORD (BitString16)`, `UINT (Unsigned16)`: a type and what it is, in brackets
        return _remarked(text, m.group(1), m.group(2))
    raise CellError(f"unknown format {shown(text.strip())}")


_REMARKED = lazy(r"^([^()]+?)\s*\(([^()]{1,40})\)$")


def _remarked(text: str, outer: str, inner: str) -> TypeCell:
    """A type with a remark in brackets (Schneider's `INT (Signed16)`): the remark where it is a type of
    its own with a width (it says more), and it must be the type's; else the type, the remark a word of
    the vendor's (`WORD (Enumeration)`, `WORD (BitString16)`)."""
    try:
        typed = read_type(outer)
    except CellError:
        raise CellError(f"unknown format {shown(text.strip())}") from None
    try:
        said = read_type(inner)
    except CellError:
        return typed
    if said.widthless:
        return typed
    if said.format == typed.format or (typed.widthless and said.format.startswith(typed.format.rstrip("0123456789"))):
        return said  # INT (Signed16), UINT (Unsigned16): the width the type leaves out
    raise CellError(f"{shown(text.strip())}: {outer} and {inner} are not one format ({typed.format}, {said.format})")


@dataclass(frozen=True)
class MappedFormat:
    """A `[format cells]` value: a format cell, optionally with a count or bits (`STRING 16`, `UINT16 bit 3`)."""

    typed: TypeCell
    count: int | None = None
    bits: str | None = None


_WITH = lazy(r"(?i)^(.+?)\s+(?:(bits?\s*[0-9]{1,2}(?:\s*-\s*[0-9]{1,2})?)|([0-9]{1,3}))$")


@cell_cache
def read_mapped_format(text: str) -> MappedFormat:
    """`UINT16`, `STRING 16` (16 registers), `UINT16 bit 3`, `UINT32 bits 0-3` -> MappedFormat."""
    try:
        return MappedFormat(read_type(text))
    except CellError:
        m = _WITH().match(" ".join(text.strip().split()))
        if m is None:
            raise
    typed = read_type(m.group(1))
    if m.group(2):
        return MappedFormat(typed, bits=parse_bit_cell(m.group(2)))
    count = int(m.group(3))
    if count < 1:
        raise CellError(f"the count in {shown(text.strip())} must be 1 or more")
    return MappedFormat(typed, count=count)


def parse_format(text: str) -> tuple[str, int | None]:
    """A format cell -> (MDL format, string length in characters or None)."""
    found = read_type(text)
    return found.format, found.strlen


@cell_cache
def parse_length(text: str) -> str:
    t = text.strip().lower()
    if not t or t in ("full", "full word", "word", "16 bit", "16-bit", "16bit", "all"):
        return "Full word"
    if re.match(r"^(low|lower|lo|lsb|l)\b", t) or "low" in t:
        return "Lower byte"
    if re.match(r"^(high|upper|hi|msb|h)\b", t) or "high" in t or "upper" in t:
        return "Upper byte"
    if "full" in t or "word" in t:
        return "Full word"
    raise CellError(f"unknown length {shown(text.strip())} (expected Lower byte, Upper byte or Full word)")


ACCESS_WORDS = {
    "r": "read",
    "ro": "read",
    "read": "read",
    "read only": "read",
    "read-only": "read",
    "readonly": "read",
    "read_only": "read",
    "r/o": "read",
    "r/-": "read",
    "-/w": "write",
    "rd": "read",
    "w": "write",
    "wo": "write",
    "write": "write",
    "write only": "write",
    "write-only": "write",
    "writeonly": "write",
    "write_only": "write",
    "w/o": "write",
    "rw": "read_write",
    "r/w": "read_write",
    "w/r": "read_write",
    "r/w/": "read_write",
    "read/write": "read_write",
    "read write": "read_write",
    "read-write": "read_write",
    "wr": "read_write",
    "r+w": "read_write",
    "r & w": "read_write",
    "r&w": "read_write",
    "read_write": "read_write",
    "rd/wr": "read_write",
    "rdwr": "read_write",
    # a "Writable" column (VOLTTRON, Victron): yes or no
    "true": "read_write",
    "yes": "read_write",
    "y": "read_write",
    "false": "read",
    "no": "read",
    "n": "read",
}
BOTH_LETTERS = frozenset(k for k, v in ACCESS_WORDS.items() if v == "read_write" and "r" in k and "w" in k)


def access_words(cells: list[str]) -> str:
    """What `W` alone means in a column of these cells (SPEC 4): "read_write" where the column holds
    only the letters R and W (W: writable), "write" where it also holds R/W, RW ... (W: write-only)."""
    seen = {" ".join(c.strip().lower().split()) for c in cells}
    return "write" if seen & BOTH_LETTERS else "read_write"


@cell_cache
def parse_access(text: str, w_alone: str = "write") -> str:
    t = " ".join(text.strip().lower().split())
    if t.endswith(")") and "(" in t:  # W/R(Reboot after write): the remark says nothing of access
        t = t[: t.index("(")].rstrip() or t
    if t == "w":
        return w_alone
    if t in ACCESS_WORDS:
        return ACCESS_WORDS[t]
    raise CellError(f"unknown access {shown(text.strip())} (expected R, W or R/W)")


# a word-order column (VOLTTRON's `Mixed Endian`, `Word Swap`): swapped or not, relative to the type's own order
_SWAPPED = {
    "true": True,
    "t": True,
    "yes": True,
    "y": True,
    "1": True,
    "swap": True,
    "swapped": True,
    "reversed": True,
    "mixed": True,
    "on": True,
    "false": False,
    "f": False,
    "no": False,
    "n": False,
    "0": False,
    "off": False,
    "normal": False,
    "not swapped": False,
    "none": False,
}
# ... or the order itself: of the words, or of the bytes A (most significant) to D
_WORD_ORDERS = {
    "big": "big",
    "be": "big",
    "big endian": "big",
    "msw first": "big",
    "high word first": "big",
    "hi lo": "big",
    "little": "little",
    "le": "little",
    "little endian": "little",
    "lsw first": "little",
    "low word first": "little",
    "lo hi": "little",
}
_BYTE_ORDERS = {
    "abcd": ("big", "big"),
    "cdab": ("big", "little"),
    "badc": ("little", "big"),
    "dcba": ("little", "little"),
    "1234": ("big", "big"),
    "3412": ("big", "little"),
    "2143": ("little", "big"),
    "4321": ("little", "little"),
}


@dataclass(frozen=True)
class WordOrderCell:
    swapped: bool | None = None  # the registers reversed from the type's own order (None: the order is given)
    word_order: str | None = None
    byte_order: str | None = None  # ABCD-style cells give the byte order too


@cell_cache
def parse_word_order(text: str) -> WordOrderCell:
    t = " ".join(text.strip().lower().replace("-", " ").replace("_", " ").split())
    if t in _SWAPPED:
        return WordOrderCell(swapped=_SWAPPED[t])
    if t in _WORD_ORDERS:
        return WordOrderCell(word_order=_WORD_ORDERS[t])
    if t.replace(" ", "") in _BYTE_ORDERS:
        byte, word = _BYTE_ORDERS[t.replace(" ", "")]
        return WordOrderCell(word_order=word, byte_order=byte)
    raise CellError(
        f"unknown word order {shown(text.strip())} (expected TRUE/FALSE for swapped, big/little, "
        "or ABCD/CDAB/BADC/DCBA)"
    )


TABLE_WORDS = {
    "holding": "holding",
    "holding register": "holding",
    "holding registers": "holding",
    "hr": "holding",
    "4x": "holding",
    "input": "input",
    "input register": "input",
    "input registers": "input",
    "ir": "input",
    "3x": "input",
    "coil": "coil",
    "coils": "coil",
    "0x": "coil",
    "c": "coil",
    "co": "coil",
    "coil status": "coil",
    "discrete": "discrete",
    "discrete input": "discrete",
    "discrete inputs": "discrete",
    "di": "discrete",
    "1x": "discrete",
    "input status": "discrete",
    "read coils": "coil",
    "read discrete inputs": "discrete",
    "read holding registers": "holding",
    "read input registers": "input",
    "analog input": "input",
    "analog output": "holding",
    # VOLTTRON's table names (modbus_tk register maps)
    "discrete output coils": "coil",
    "discrete input contacts": "discrete",
    "analog input registers": "input",
    "analog output holding registers": "holding",
}
# Modbus function codes -> the table they read or write
FUNCTION_CODES = {
    1: "coil",
    2: "discrete",
    3: "holding",
    4: "input",
    5: "coil",
    6: "holding",
    15: "coil",
    16: "holding",
    22: "holding",
    23: "holding",
}
_CODE = lazy(r"(?i)^(?:fc|func(?:tion)?(?:\s*code)?)?\s*(?:0x)?0*(\d{1,2})h?$")
_CODE_IN_TEXT = lazy(r"(?i)\bfc\s*0*(\d{1,2})\b|\(\s*0x0*(\d{1,2})\s*\)")


@cell_cache
def parse_table(text: str) -> str:
    """A register-type cell -> holding | input | coil | discrete: table names (`Holding Register`,
    `4x`), VOLTTRON's (`analog_output_holding_registers`), function codes (`3`, `FC03`, `0x04`,
    `03/06/16`) and texts naming one (`Read Input Registers (FC04)`)."""
    t = " ".join(text.strip().lower().replace("_", " ").replace("-", " ").split())
    t = t.removeprefix("modbus ") if t.removeprefix("modbus ") in TABLE_WORDS else t  # MODBUS_INPUT_REGISTER
    if t in TABLE_WORDS:
        return TABLE_WORDS[t]
    parts = [p for p in re.split(r"\s*[,/&+;]\s*|\s+and\s+|\s+", t) if p]
    codes = [_CODE().match(p) for p in parts]
    if parts and all(codes):
        tables = set()
        for m in codes:
            assert m is not None
            code = int(m.group(1))
            if code not in FUNCTION_CODES:
                raise CellError(f"function code {code} in {shown(text.strip())} reads or writes no register table")
            tables.add(FUNCTION_CODES[code])
        if len(tables) > 1:
            raise CellError(
                f"{shown(text.strip())} names function codes of different tables ({', '.join(sorted(tables))})"
            )
        return tables.pop()
    found = {FUNCTION_CODES.get(int(a or b)) for a, b in _CODE_IN_TEXT().findall(t)}
    if len(found) == 1 and None not in found:
        return found.pop()  # type: ignore[return-value]
    raise CellError(f"unknown register type {shown(text.strip())}")
