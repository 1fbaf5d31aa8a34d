"""The read plan (SPEC section 8): the functions a read needs -> the fewest requests.

A request covers consecutive addresses of one table, up to 125 registers or 2000 bits, and never
an address the device does not define. Greedy from the lowest needed address is optimal for
covering points with intervals of bounded length.
"""

from __future__ import annotations

from dataclasses import dataclass

from mdl.model import Device, Function
from mdl.model.layout import MAX_BITS, MAX_REGISTERS, layout

TABLE_ORDER = ("coil", "discrete", "holding", "input")


@dataclass(frozen=True)
class Request:
    table: str
    start: int
    count: int
    functions: tuple[str, ...]  # names of the functions whose registers it carries

    @property
    def end(self) -> int:
        return self.start + self.count


def defined_addresses(device: Device) -> dict[str, set[int]]:
    tables: dict[str, set[int]] = {t: set() for t in TABLE_ORDER}
    for fn in device.functions:
        lay = layout(fn)
        tables[lay.table].update(lay.addresses)
    return tables


def plan_reads(
    device: Device, functions: list[Function] | None = None, max_registers: int | None = None
) -> list[Request]:
    if max_registers is None:
        max_registers = device.max_registers or MAX_REGISTERS
    if functions is None:
        functions = [fn for fn in device.functions if fn.readable]
    defined = defined_addresses(device)
    needed: dict[str, dict[int, list[str]]] = {t: {} for t in TABLE_ORDER}
    for fn in functions:
        lay = layout(fn)
        for a in lay.addresses:
            needed[lay.table].setdefault(a, []).append(fn.name)
    requests = []
    for table in TABLE_ORDER:
        limit = MAX_BITS if table in ("coil", "discrete") else max_registers
        points = sorted(needed[table])
        i = 0
        while i < len(points):
            start = end = points[i]
            names: list[str] = []
            while i < len(points) and points[i] - start < limit and all(
                a in defined[table] for a in range(end + 1, points[i] + 1)
            ):
                end = points[i]
                names += [n for n in needed[table][end] if n not in names]
                i += 1
            requests.append(Request(table, start, end - start + 1, tuple(names)))
    return requests


def split_request(device: Device, request: Request) -> list[Request]:
    """Smaller requests for a group the device refused with exception 2: one per run of each
    function's addresses within the group, each distinct run once (functions that share registers
    share its request), in the order the group names the functions."""
    by_name = {fn.name: fn for fn in device.functions}
    names_of: dict[tuple[int, int], list[str]] = {}  # (start, count) -> the functions whose run it is
    for name in request.functions:
        lay = layout(by_name[name])
        for run in _runs(sorted({a for a in lay.addresses if request.start <= a < request.end})):
            names = names_of.setdefault(run, [])
            if name not in names:
                names.append(name)
    return [Request(request.table, start, count, tuple(names)) for (start, count), names in names_of.items()]


def _runs(addrs: list[int]) -> list[tuple[int, int]]:
    """(start, count) of each run of consecutive addresses in a sorted list without repeats."""
    out: list[tuple[int, int]] = []
    for a in addrs:
        if out and a == out[-1][0] + out[-1][1]:
            out[-1] = (out[-1][0], out[-1][1] + 1)
        else:
            out.append((a, 1))
    return out
