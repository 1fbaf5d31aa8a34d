"""What `mdl probe` guesses from the ranges and values it found (SPEC 14), each said as a guess, and only
where the values allow one:

- the address base: register ranges that start at 1 (with 0 undefined) suggest a vendor table that
  numbers registers from 1; ranges that start at 40001/30001 (or 40000/30000) a device that takes
  Modicon register numbers as wire addresses;
- the word order: pairs of registers at even offsets of each defined run, decoded as float32 both ways;
  a value is plausible when it is finite and between 1e-4 and 1e9 in size (or zero from two zero words,
  which says nothing and is skipped). One order is guessed when it gives at least MIN_PAIRS plausible
  values and the other at most a third as many.
"""

from __future__ import annotations

import math
import struct

MIN_PAIRS = 2
MODICON_BASES = {"holding": 40000, "input": 30000}
_FLOAT = struct.Struct(">f")


def _plausible(high: int, low: int) -> bool:
    value: float = _FLOAT.unpack(struct.pack(">HH", high, low))[0]
    return math.isfinite(value) and 1e-4 <= abs(value) <= 1e9


def word_order_counts(ranges: dict[str, list[tuple[int, int]]], values: dict[str, dict[int, int]]) -> tuple[int, int]:
    """(pairs plausible as float32 with the first register most significant, pairs plausible the other way)."""
    big = little = 0
    for table in ("holding", "input"):
        got = values.get(table, {})
        for first, last in ranges.get(table, []):
            for a in range(first, last, 2):
                if a + 1 > last or a not in got or a + 1 not in got:
                    continue
                one, two = got[a], got[a + 1]
                if one == two == 0:
                    continue
                big += _plausible(one, two)
                little += _plausible(two, one)
    return big, little


def guesses(ranges: dict[str, list[tuple[int, int]]], values: dict[str, dict[int, int]], low: int) -> list[str]:
    """The guesses the ranges and values allow, as sentences that say they are guesses."""
    out: list[str] = []
    for table in ("holding", "input"):
        spans = ranges.get(table, [])
        if not spans:
            continue
        start = spans[0][0]
        base = MODICON_BASES[table]
        if start == 1 and low == 0:
            out.append(
                f"guess: the {table} registers start at wire address 1, not 0: a vendor table numbering them "
                "from 1 may give wire addresses as they are (check one value against the manual)"
            )
        elif base <= start <= base + 1:
            out.append(
                f"guess: the {table} registers start at wire address {start}: the device may take Modicon "
                f"numbers ({base + 1} = the first register) as wire addresses"
            )
    big, little = word_order_counts(ranges, values)
    if big >= MIN_PAIRS and little * 3 <= big:
        out.append(
            f"guess: word order big (first register most significant): {big} register pairs read as plausible "
            f"float32 values that way, {little} the other way"
        )
    elif little >= MIN_PAIRS and big * 3 <= little:
        out.append(
            f"guess: word order little (first register least significant): {little} register pairs read as "
            f"plausible float32 values that way, {big} the other way"
        )
    return out
