"""Register address notations shared by csv2xml and the expression language (seed 002).

- named, exact wire addresses: `hr:101`, `holding-register:101`, `ir:`, `input-register:`, `c:`,
  `coil:`, `di:`, `discrete-input:` (case-insensitive);
- Modicon register numbers, one more than the wire address: `4x0102`, `40102` (5 digits),
  `400102` (6 digits); the first digit names the table (0 coil, 1 discrete, 3 input, 4 holding).
"""

from __future__ import annotations

import re

MODICON_TABLE = {"0": "coil", "1": "discrete", "3": "input", "4": "holding"}
NAMED_TABLE = {"c": "coil", "coil": "coil", "di": "discrete", "discrete-input": "discrete",
               "ir": "input", "input-register": "input", "hr": "holding", "holding-register": "holding"}
TABLE_PREFIX = {"coil": "c", "discrete": "di", "input": "ir", "holding": "hr"}

NAMED = re.compile(r"(?i)(coil|c|discrete[-_]input|di|input[-_]register|ir|holding[-_]register|hr)\s*:\s*(\d+)")
XFORM = re.compile(r"(?i)([0134])x(\d+)")
MODICON = re.compile(r"([0134]\d{4,5})(?!\d)")


class AddressError(ValueError):
    pass


def match_address(text: str, pos: int = 0, modicon_digits: bool = True, x_coils: bool = True):
    """(table, wire address, end position) for an address at text[pos:], or None."""
    m = NAMED.match(text, pos)
    if m:
        return NAMED_TABLE[m.group(1).lower().replace("_", "-")], int(m.group(2)), m.end()
    m = XFORM.match(text, pos)
    if m and (x_coils or m.group(1) != "0"):
        number = int(m.group(2))
        if number < 1:
            raise AddressError(f"register number in '{m.group(0)}' must be 1 or more")
        return MODICON_TABLE[m.group(1)], number - 1, m.end()
    if modicon_digits:
        m = MODICON.match(text, pos)
        if m:
            number = int(m.group(1)[1:])
            if number < 1:
                raise AddressError(f"register number in '{m.group(1)}' must be 1 or more")
            return MODICON_TABLE[m.group(1)[0]], number - 1, m.end()
    return None


def parse_address(text: str) -> tuple[str, int]:
    """A whole string that is one address -> (table, wire address)."""
    t = text.strip()
    found = match_address(t)
    if not found or found[2] != len(t):
        raise AddressError(f"'{t}' is not a register address (hr:N, ir:N, c:N, di:N, 4xN, 40001, 400001)")
    if found[1] > 65535:
        raise AddressError(f"address {found[1]} is over 65535")
    return found[0], found[1]
