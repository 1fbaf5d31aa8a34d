"""What a target registers (its name and how it renders a device), and the read plan as the rows of
the C and C++ drivers' tables."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mdl.resolver import ResolvedDevice

if TYPE_CHECKING:
    from mdl.targets.profile import Interface


@dataclass(frozen=True)
class Target:
    name: str
    # (device, source file name, a profile's interface or None) -> file name -> text
    render: Callable[[ResolvedDevice, str, Interface | None], dict[str, str]]


# A request of the read plan as a row of the C and C++ drivers' groups table: (table as the target
# spells it, start, count, its first slot in read_all's buffer, the first row of its smaller requests
# (used when the device refuses it) in the splits table, their number). Tuples: some 10,000 rows are
# made for a large device.
GroupRow = tuple[str, int, int, int, int, int]
# one of a group's smaller requests as a row of the splits table: (table, start, count, its first slot
# within its group)
SplitRow = tuple[str, int, int, int]

Run = tuple[str, int, int, int]  # (table as the target spells it, first address, count, first register in r)


def runs_at(table: str, runs: tuple[tuple[int, int], ...]) -> list[Run]:
    """A function's requests (`Layout.runs`) with where each one's registers start in the
    function's own register array: the rows a single read or write loops over."""
    out = []
    at = 0
    for start, count in runs:
        out.append((table, start, count, at))
        at += count
    return out


def plan_rows(resolved: ResolvedDevice, table_names: Mapping[str, str]) -> tuple[list[GroupRow], list[SplitRow]]:
    """The read plan as rows of a groups table (table, start, count, offset in the buffer, first and
    number of its smaller requests) and a splits table (table, start, count, delta: first slot
    within its group); `table_names` spells each table in the target's language."""
    groups: list[GroupRow] = []
    splits: list[SplitRow] = []
    for group in resolved.plan:
        req, smaller = group.request, group.smaller
        groups.append((table_names[req.table], req.start, req.count, group.offset, len(splits), len(smaller)))
        splits += [(table_names[s.table], s.start, s.count, s.start - req.start) for s in smaller]
    return groups, splits
