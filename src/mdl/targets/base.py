"""What a target registers (its name and how it renders a device), and the read plan as the rows of
the C and C++ drivers' tables."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from mdl.resolve import ResolvedDevice


@dataclass(frozen=True)
class Target:
    name: str
    render: Callable[[ResolvedDevice, str], dict[str, str]]  # (device, source file name) -> file name -> text


Rows = list[dict[str, Any]]
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


def plan_rows(resolved: ResolvedDevice, table_names: Mapping[str, str]) -> tuple[Rows, Rows]:
    """The read plan as rows of a groups table (table, start, count, offset in the buffer, first and
    number of its smaller requests) and a splits table (table, start, count, delta: first slot
    within its group); `table_names` spells each table in the target's language."""
    groups: Rows = []
    splits: Rows = []
    for group in resolved.plan:
        req, smaller = group.request, group.smaller
        groups.append({"table": table_names[req.table], "start": req.start, "count": req.count,
                       "offset": group.offset, "split_first": len(splits), "split_count": len(smaller)})
        splits += [{"table": table_names[s.table], "start": s.start, "count": s.count, "delta": s.start - req.start}
                   for s in smaller]
    return groups, splits
