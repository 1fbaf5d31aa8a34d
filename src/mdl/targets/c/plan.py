"""The read plan as the C driver's tables print it (device.c.j2's `mdl_groups` and `mdl_splits`): one row
per request, some 10,000 of the smaller requests for a device of 10,000 functions, printed with Python
rather than a template loop from the rows mdl.targets.base.plan_rows gives both C and C++."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from mdl.resolver import ResolvedDevice
from mdl.targets.base import plan_rows


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
    """The rows of the device's read plan (mdl.targets.base.plan_rows), `table_names` spelling each table."""
    groups, splits = plan_rows(rd, table_names)
    group_rows = "".join([f"    {{{t}, {s}, {c}, {o}U, {first}U, {n}U}},\n" for t, s, c, o, first, n in groups])
    split_rows = "".join([f"    {{{t}, {s}, {c}, {delta}U}},\n" for t, s, c, delta in splits])
    return PlanTables(len(groups), group_rows, len(splits), split_rows)
