"""Straight-line register arithmetic shared by the Python and C++ generators.

A value is composed from its units most significant first: `units_msb_first` says which register
(by index in address order) and which part of it each unit is; `register_parts` says, for each
register, which unit goes where when encoding.
"""

from __future__ import annotations

from mdl.model.layout import Layout


def units_msb_first(lay: Layout) -> list[tuple[int, str]]:
    """(register index, part) for each unit, most significant first. part: word | swap | low | high."""
    n = len(lay.addresses)
    order = list(range(n)) if lay.word_order == "big" else list(reversed(range(n)))
    if lay.unit == "word":
        part = "word" if lay.byte_order == "big" else "swap"
    else:
        part = lay.unit
    return [(i, part) for i in order]


def span_bits(lay: Layout) -> int:
    return len(lay.addresses) * (16 if lay.unit == "word" else 8)


def unit_shift(lay: Layout, position: int) -> int:
    """Bit shift of the unit at `position` (0 = most significant) inside the composed value."""
    ubits = 16 if lay.unit == "word" else 8
    return ubits * (len(lay.addresses) - 1 - position)
