"""The read plan as the C driver's tables print it (device.c.j2's `mdl_groups` and `mdl_splits`): one row
per request, some 10,000 of the smaller requests for a device of 10,000 functions, printed with Python
rather than a template loop."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from mdl.resolve import ResolvedDevice


@dataclass(frozen=True)
class PlanTables:
    """The `groups` rows of mdl_groups (`group_rows`: table, start, count, offset in read_all's buffer,
    first and number of its smaller requests) and the `splits` rows of mdl_splits (`split_rows`: table,
    start, count, first slot within its group), each row a line ending with a newline."""

    groups: int
    group_rows: str
    splits: int
    split_rows: str


def plan_tables(rd: ResolvedDevice, table_names: Mapping[str, str]) -> PlanTables:
    """The rows of the device's read plan (as mdl.targets.base.plan_rows gives them), `table_names`
    spelling each table."""
    groups: list[str] = []
    splits: list[str] = []
    for group in rd.plan:
        req, smaller = group.request, group.smaller
        groups.append(
            f"    {{{table_names[req.table]}, {req.start}, {req.count}, {group.offset}U, {len(splits)}U,"
            f" {len(smaller)}U}},\n"
        )
        splits += [f"    {{{table_names[s.table]}, {s.start}, {s.count}, {s.start - req.start}U}},\n" for s in smaller]
    return PlanTables(len(groups), "".join(groups), len(splits), "".join(splits))
