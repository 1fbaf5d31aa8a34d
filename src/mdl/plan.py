"""The read plan (SPEC section 8): the functions a read needs -> the fewest requests.

A request covers consecutive addresses of one table, up to 125 registers or 2000 bits, and never
an address the device does not define. Greedy from the lowest needed address is optimal for
covering points with intervals of bounded length.

Every function here takes the layouts it needs as an optional `layouts` (function name -> Layout,
as the resolve step computes them once); without it each computes them once per call. Planning is
linear in the number of functions: `plan_groups` plans a device and splits every request in one pass.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from mdl.model import Device, Function
from mdl.model.layout import MAX_BITS, MAX_REGISTERS, Layout, address_runs, layouts_by_name
from mdl.records import record

TABLE_ORDER = ("coil", "discrete", "holding", "input")


@record
class Request:
    table: str
    start: int
    count: int
    functions: tuple[str, ...]  # names of the functions whose registers it carries

    @property
    def end(self) -> int:
        return self.start + self.count


Layouts = Mapping[str, Layout]  # function name -> its layout


def defined_addresses(device: Device, layouts: Layouts | None = None) -> dict[str, set[int]]:
    if layouts is None:
        layouts = layouts_by_name(device.functions)
    tables: dict[str, set[int]] = {t: set() for t in TABLE_ORDER}
    for fn in device.functions:
        lay = layouts[fn.name]
        tables[lay.table].update(lay.addresses)
    return tables


def plan_reads(
    device: Device,
    functions: Iterable[Function] | None = None,
    max_registers: int | None = None,
    layouts: Layouts | None = None,
    defined: Mapping[str, set[int]] | None = None,
) -> list[Request]:
    """The requests that read `functions` (every readable one by default). `defined` (table -> the
    addresses the device defines) may be given as `defined_addresses` computes it."""
    if max_registers is None:
        max_registers = device.max_registers or MAX_REGISTERS
    if functions is None:
        functions = [fn for fn in device.functions if fn.readable]
    if layouts is None:
        layouts = layouts_by_name(device.functions)
    if defined is None:
        defined = defined_addresses(device, layouts)
    needed: dict[str, dict[int, list[str]]] = {t: {} for t in TABLE_ORDER}
    for fn in functions:
        lay = layouts[fn.name]
        at = needed[lay.table]
        for a in lay.addresses:
            names = at.get(a)
            if names is None:
                at[a] = [fn.name]
            else:
                names.append(fn.name)
    requests = []
    for table in TABLE_ORDER:
        limit = MAX_BITS if table in ("coil", "discrete") else max_registers
        at = needed[table]
        points = sorted(at)
        there = defined[table]
        i, n = 0, len(points)
        while i < n:
            start = end = points[i]
            names_in: dict[str, None] = {}  # ordered, without repeats
            while i < n:
                point = points[i]
                if point - start >= limit or (point != end + 1 and not there.issuperset(range(end + 1, point + 1))):
                    break
                end = point
                for name in at[point]:
                    names_in[name] = None
                i += 1
            requests.append(Request(table, start, end - start + 1, tuple(names_in)))
    return requests


def split_request(device: Device, request: Request, layouts: Layouts | None = None) -> list[Request]:
    """Smaller requests for a group the device refused with exception 2: one per run of each
    function's addresses within the group, each distinct run once (functions that share registers
    share its request), in the order the group names the functions."""
    if layouts is None:
        wanted = set(request.functions)
        layouts = layouts_by_name(fn for fn in device.functions if fn.name in wanted)
    names_of: dict[tuple[int, int], list[str]] = {}  # (start, count) -> the functions whose run it is
    start, end = request.start, request.end
    for name in request.functions:
        addresses = layouts[name].addresses
        first = addresses[0] if addresses else 0
        if addresses and addresses == tuple(range(first, first + len(addresses))):  # one ascending run (most)
            low, high = max(first, start), min(first + len(addresses), end)  # its part in the request
            runs: Iterable[tuple[int, int]] = ((low, high - low),) if low < high else ()
        else:
            runs = address_runs(sorted({a for a in addresses if start <= a < end}))
        for run in runs:
            names = names_of.setdefault(run, [])
            if name not in names:
                names.append(name)
    return [Request(request.table, start, count, tuple(names)) for (start, count), names in names_of.items()]


def plan_groups(device: Device, layouts: Layouts | None = None) -> list[tuple[Request, list[Request]]]:
    """The read plan of every readable function, each request with the smaller ones `split_request`
    gives for it (empty where that is the request itself), in one linear pass."""
    if layouts is None:
        layouts = layouts_by_name(device.functions)
    out = []
    for req in plan_reads(device, layouts=layouts):
        parts = split_request(device, req, layouts)
        out.append((req, parts if parts != [req] else []))
    return out
