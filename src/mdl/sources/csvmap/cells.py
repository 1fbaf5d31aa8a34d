"""Reading the cells of vendor register tables: addresses, formats, lengths, numbers."""

from __future__ import annotations

import math
import re
from collections.abc import Callable

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


_HEX = re.compile(r"(?i)^0x[0-9a-f]+h?$|^[0-9a-f]+h$")
_RANGE = re.compile(r"(?i)^(.+?)\s*(?:\bto\b|to|\.\.|-|–|—)\s*(.+)$")


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
        raise CellError(f"'{part}': {exc}") from None


def is_modicon_number(text: str) -> bool:
    t = text.strip()
    return is_digits(t) and len(t) in (5, 6) and t[0] in MODICON_TABLE and int(t[1:]) >= 1


def _one(text: str, base: str) -> tuple[int, str | None]:
    """One address token -> (wire address, table or None)."""
    t = text.strip()
    try:  # 0x... is hexadecimal here, not a Modicon coil; plain digits follow the address base
        found = match_address(t, modicon_digits=False, x_coils=False)
    except AddressError as exc:
        raise CellError(str(exc)) from None
    if found and found[2] == len(t):
        return found[1], found[0]
    if _HEX.match(t):
        digits = t.lower().removeprefix("0x").removesuffix("h").lstrip("0")
        if len(digits) > 12:
            raise CellError(f"address '{t[:20]}...' is too large")
        return int(digits or "0", 16), None
    if not is_digits(t):
        raise CellError(f"'{t}' is not an address")
    if base == "modicon":
        if not is_modicon_number(t):
            raise CellError(f"'{t}' is not a Modicon 5- or 6-digit register number")
        return int(t[1:]) - 1, MODICON_TABLE[t[0]]
    value = _number(t, "address")
    if base == "1":
        if value < 1:
            raise CellError(f"'{t}' is not a 1-based address")
        return value - 1, None
    return value, None


def parse_addresses(text: str, base: str = "0") -> tuple[list[int], str | None]:
    """An address cell -> (wire addresses in order, table named by the cell or None).

    Accepts numbers, hex, Modicon numbers (when base is 'modicon'), 4x0102, hr:101 ...,
    ranges (`0 to 3`, `22to100`, `566 - 583`, `hr:2..hr:5`, `hr:2#4`) and lists (`17,18,19`).
    """
    text = text.strip()
    if not text:
        raise CellError("the address cell is empty")
    parts = [p for p in re.split(r"\s*[,;/&]\s*|\s+and\s+", text) if p]
    addresses: list[int] = []
    table = None
    for part in parts:
        if "#" in part:
            first, _, count = part.partition("#")
            start, tbl = _one(first, base)
            if not is_digits(count.strip()):
                raise CellError(f"'{part}': the count after '#' must be a positive number")
            run = _addresses(address_run, start, _number(count.strip(), "count"), part)
        else:
            m = _RANGE.match(part)
            if m and not NAMED.fullmatch(part.strip()) and not is_digits(part.strip().lstrip("-")):
                start, tbl = _one(m.group(1), base)
                end, tbl2 = _one(m.group(2), base)
                if tbl2 and tbl and tbl != tbl2:
                    raise CellError(f"'{part}' mixes register tables")
                tbl = tbl or tbl2
                run = _addresses(address_range, start, end, part)
            else:
                start, tbl = _one(part, base)
                run = [start]
        if tbl and table and tbl != table:
            raise CellError(f"'{text}' mixes register tables")
        table = table or tbl
        addresses += run
    if any(a > MAX_ADDRESS for a in addresses):
        raise CellError(f"address {max(addresses)} is over {MAX_ADDRESS}")
    if len(set(addresses)) != len(addresses):
        raise CellError(f"'{text}' lists an address twice")
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
_FORMATS = [(re.compile(rf"(?i)^(?:{pattern})$"), fmt) for pattern, fmt in FORMAT_WORDS]
_STRING = re.compile(r"(?i)^(?:char|string|str|ascii|text)\s*[\[(]\s*([0-9]+)\s*[\])]$"
                     r"|^(?:string|str|ascii|text)([0-9]*)$")


def parse_format(text: str) -> tuple[str, int | None]:
    """A format cell -> (MDL format, string length in characters or None)."""
    t = " ".join(text.strip().split())
    m = _STRING.match(t)
    if m:
        n = m.group(1) or m.group(2)
        return "STRING", _number(n, "string length") if n else None
    for rx, fmt in _FORMATS:
        if rx.match(t):
            return fmt, None
    raise CellError(f"unknown format '{text.strip()}'")


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
    raise CellError(f"unknown length '{text.strip()}' (expected Lower byte, Upper byte or Full word)")


_NUM = re.compile(r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?")


def parse_number(text: str, decimal_comma: bool = False, what: str = "") -> float:
    """A number cell (`0.1`, `0,1` with decimal commas, `0.1(?)`, `x10`, `1/10`) -> float."""
    t = text.strip().replace("\u2212", "-")
    if decimal_comma or re.fullmatch(r"[-+]?\d+,\d+", t):
        if re.fullmatch(r"[-+]?\d{1,3}(\.\d{3})+,\d+", t):  # 1.234,5: the dots group thousands
            t = t.replace(".", "")
        t = t.replace(",", ".")
    frac = re.fullmatch(r"\s*([-+]?\d+(?:\.\d+)?)\s*/\s*(\d+(?:\.\d+)?)\s*", t)
    if frac and float(frac.group(2)) != 0:
        value = float(frac.group(1)) / float(frac.group(2))
    else:
        m = _NUM.search(t)
        if not m:
            raise CellError(f"'{text.strip()}' is not a number")
        value = float(m.group(0))
    if not math.isfinite(value):  # 1e999: no target computes with it
        raise CellError(f"{what} '{text.strip()}' is not a finite number".lstrip())
    return value


def parse_int(text: str) -> int:
    t = text.strip()
    try:
        return int(t, 0)
    except ValueError:
        value = parse_number(t)
        if not value.is_integer():
            raise CellError(f"'{t}' is not a whole number") from None
        return int(value)


ACCESS_WORDS = {"r": "read", "ro": "read", "read": "read", "read only": "read", "read-only": "read",
                "w": "write", "wo": "write", "write": "write", "write only": "write",
                "rw": "read_write", "r/w": "read_write", "w/r": "read_write", "r/w/": "read_write",
                "read/write": "read_write", "read write": "read_write", "read-write": "read_write",
                "wr": "read_write", "r+w": "read_write"}


def parse_access(text: str) -> str:
    t = " ".join(text.strip().lower().split())
    if t in ACCESS_WORDS:
        return ACCESS_WORDS[t]
    raise CellError(f"unknown access '{text.strip()}' (expected R, W or R/W)")


TABLE_WORDS = {"holding": "holding", "holding register": "holding", "hr": "holding", "4x": "holding",
               "input": "input", "input register": "input", "ir": "input", "3x": "input",
               "coil": "coil", "coils": "coil", "0x": "coil", "c": "coil",
               "discrete": "discrete", "discrete input": "discrete", "di": "discrete", "1x": "discrete",
               "holding registers": "holding", "input registers": "input", "discrete inputs": "discrete"}


def parse_table(text: str) -> str:
    t = " ".join(text.strip().lower().replace("_", " ").replace("-", " ").split())
    if t in TABLE_WORDS:
        return TABLE_WORDS[t]
    if t in ("1", "2", "3", "4"):
        return {"1": "coil", "2": "discrete", "3": "holding", "4": "input"}[t]
    for code, table in (("fc01", "coil"), ("fc02", "discrete"), ("fc03", "holding"), ("fc04", "input")):
        if code in t.replace(" ", ""):
            return table
    raise CellError(f"unknown register type '{text.strip()}'")
