"""Register address notations shared by csv2xml and the expression language (seed 002).

- named, exact wire addresses: `hr:101`, `holding-register:101`, `ir:`, `input-register:`, `c:`,
  `coil:`, `di:`, `discrete-input:` (case-insensitive);
- Modicon register numbers, one more than the wire address: `4x0102`, `40102` (5 digits),
  `400102` (6 digits); the first digit names the table (0 coil, 1 discrete, 3 input, 4 holding).

Runs of addresses (`a#n`, `a..b`, `a to b`) are checked against the address space before any
list of them is built, so a cell such as `hr:1#3000000000` costs nothing to refuse.
"""

from __future__ import annotations

import re

from mdl.model.layout import MAX_ADDRESS, MAX_BITS, MAX_REGISTERS

MODICON_TABLE = {"0": "coil", "1": "discrete", "3": "input", "4": "holding"}
NAMED_TABLE = {
    "c": "coil",
    "coil": "coil",
    "di": "discrete",
    "discrete-input": "discrete",
    "ir": "input",
    "input-register": "input",
    "hr": "holding",
    "holding-register": "holding",
}
TABLE_PREFIX = {"coil": "c", "discrete": "di", "input": "ir", "holding": "hr"}

NAMED = re.compile(r"(?i)(coil|c|discrete[-_]input|di|input[-_]register|ir|holding[-_]register|hr)\s*:\s*([0-9]+)")
# a pattern's text, compiled where it is used (re.compile keeps it): no compiling at import (issue 40)
XFORM = r"(?i)([0134])x([0-9]+)"
MODICON = r"([0134][0-9]{4,5})(?![0-9])"
# Decimal digits read as a number; longer ones would only be refused later (and Python
# refuses to convert more than 4300 of them), so they are refused while still text.
_MAX_DIGITS = 12


class AddressError(ValueError):
    pass


def _short(text: str) -> str:
    return text if len(text) <= 20 else text[:20] + "..."


def whole_number(digits: str, what: str) -> int:
    """ASCII decimal digits -> int; AddressError for a number too long to be any address or count."""
    significant = digits.lstrip("0")
    if len(significant) > _MAX_DIGITS:
        raise AddressError(f"{what} '{_short(digits)}' is too large")
    return int(significant or "0")


def _wire(number: int) -> int:
    if number > MAX_ADDRESS:
        raise AddressError(f"address {number} is over {MAX_ADDRESS}")
    return number


def _register_number(digits: str, token: str) -> int:
    """A Modicon register number (1-based) -> its wire address."""
    number = whole_number(digits, "register number")
    if number < 1:
        raise AddressError(f"register number in '{token}' must be 1 or more")
    return _wire(number - 1)


Found = tuple[str, int, int]  # (table, wire address, end position in the text)


def match_address(text: str, pos: int = 0, modicon_digits: bool = True, x_coils: bool = True) -> Found | None:
    """(table, wire address, end position) for an address at text[pos:], or None.

    AddressError for an address in a known notation that names no register (0, over 65535).
    """
    m = NAMED.match(text, pos)
    if m:
        table = NAMED_TABLE[m.group(1).lower().replace("_", "-")]
        return table, _wire(whole_number(m.group(2), "address")), m.end()
    m = re.compile(XFORM).match(text, pos)
    if m and (x_coils or m.group(1) != "0"):
        return MODICON_TABLE[m.group(1)], _register_number(m.group(2), m.group(0)), m.end()
    if modicon_digits:
        m = re.compile(MODICON).match(text, pos)
        if m:
            return MODICON_TABLE[m.group(1)[0]], _register_number(m.group(1)[1:], m.group(1)), m.end()
    return None


def parse_address(text: str) -> tuple[str, int]:
    """A whole string that is one address -> (table, wire address)."""
    t = text.strip()
    found = match_address(t)
    if not found or found[2] != len(t):
        raise AddressError(f"'{_short(t)}' is not a register address (hr:N, ir:N, c:N, di:N, 4xN, 40001, 400001)")
    return found[0], found[1]


def address_run(first: int, count: int) -> range:
    """`count` consecutive addresses from `first` (`a#n`), refused unless all exist and one request
    could read them (at most 2000, the bits of one request; the register tables' 125 is checked by
    the caller, which knows the device's own limit)."""
    if count < 1:
        raise AddressError(f"the register count {count} must be 1 or more")
    if count > MAX_BITS:
        raise AddressError(
            f"{count} addresses are more than one request reads (at most {MAX_REGISTERS} registers or {MAX_BITS} bits)"
        )
    last = first + count - 1
    if last > MAX_ADDRESS:
        raise AddressError(f"address {last} is over {MAX_ADDRESS}")
    return range(first, last + 1)


def address_range(first: int, last: int) -> range:
    """The addresses `first` to `last`, both included (`a..b`, `a to b`), checked as address_run."""
    if last < first:
        raise AddressError("the range ends before it starts")
    return address_run(first, last - first + 1)
