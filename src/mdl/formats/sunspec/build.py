"""A SunSpec chain -> the document model (SPEC 12): the `SunS` marker at the base address, then each
model's ID, L and points, then the end marker (ID 0xFFFF, L 0), every register a function of its own.

`build_chain` takes checked model definitions (mdl.formats.sunspec.models) with the repeat count of each
one's repeating groups, so that `mdl import --from sunspec` and a discovered chain build alike. Names:
`<model>_<point>`; a point of a group `<model>_<group>_<point>`, of a repeating group's i-th instance
`<model>_<group>_<i>_<point>` (i from 1); a model met again in the chain `<model>-<k>_...` (k from 2).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from mdl.diagnostics import Diagnostic, error
from mdl.formats.sunspec.models import TYPE_REGISTERS, ModelDef
from mdl.formats.sunspec.roles import assign_roles
from mdl.model import Device, Function
from mdl.model.layout import MAX_ADDRESS, MAX_REGISTERS

BASES = (40000, 0, 50000)  # where SunSpec clients look for the marker, in their order
SUNS = (0x5375, 0x6E53)  # "SunS"
END_ID = 0xFFFF

# SunSpec type -> MDL format and the raw values SunSpec calls "not implemented"
FORMAT: dict[str, tuple[str, list[str] | None]] = {
    "int16": ("INT16", ["0x8000"]),
    "sunssf": ("INT16", ["0x8000"]),
    "uint16": ("UINT16", ["0xFFFF"]),
    "count": ("UINT16", ["0xFFFF"]),
    "enum16": ("UINT16", ["0xFFFF"]),
    "bitfield16": ("UINT16", ["0xFFFF"]),
    "acc16": ("UINT16", ["0x0000"]),
    "pad": ("UINT16", None),
    "int32": ("INT32", ["0x80000000"]),
    "uint32": ("UINT32", ["0xFFFFFFFF"]),
    "enum32": ("UINT32", ["0xFFFFFFFF"]),
    "bitfield32": ("UINT32", ["0xFFFFFFFF"]),
    "acc32": ("UINT32", ["0x0000"]),
    "ipaddr": ("UINT32", ["0x0000"]),
    "float32": ("FLOAT32", ["0x7FC00000"]),
    "int64": ("INT64", ["0x8000000000000000"]),
    "uint64": ("UINT64", ["0xFFFFFFFFFFFFFFFF"]),
    "acc64": ("UINT64", ["0x0000"]),
    "float64": ("FLOAT64", ["0x7FF8000000000000"]),
    "eui48": ("UINT64", ["0x0000", "0x0000FFFFFFFFFFFF", "0xFFFFFFFFFFFFFFFF"]),  # the last 6 bytes
    "ipv6addr": ("UINT64", None),  # two parts of 4 registers: MDL has no 128-bit format
    "string": ("STRING", ["0x0000"]),
}
INTEGER_FORMATS = ("INT16", "UINT16", "INT32", "UINT32", "INT64", "UINT64")
UNSCALED = ("string", "eui48", "ipv6addr", "ipaddr", "pad", "sunssf")  # no number to scale (or a scale factor)


@dataclass
class _Scope:
    """The points of one group instance: SunSpec name -> function name, and the scale factor points'."""

    names: dict[str, str] = field(default_factory=dict)
    factors: set[str] = field(default_factory=set)


@dataclass
class _Chain:
    max_registers: int
    address: int
    functions: list[Function] = field(default_factory=list)
    notes: list[Diagnostic] = field(default_factory=list)

    def add(self, fn: Function, registers: int) -> None:
        if self.address + registers - 1 > MAX_ADDRESS:
            raise error(
                f"the SunSpec chain does not fit the address space: '{fn.name}' would end past {MAX_ADDRESS} "
                "(give a lower --base or a smaller --repeat)"
            )
        fn.addresses = [self.address]
        self.functions.append(fn)
        self.address += registers


def build_chain(
    models: Sequence[tuple[ModelDef, int]], base: int = BASES[0], max_registers: int = MAX_REGISTERS
) -> Device:
    """The device whose chain at `base` holds `models` in order, each (definition, repeat count of its
    repeating groups). Model 1 is not added here (the caller decides); strings longer than
    `max_registers` become parts `_1`, `_2`, ... that each fit one request."""
    chain = _Chain(max_registers, base)
    chain.add(_fixed("SunS", "SunSpec marker 'SunS' (0x5375 0x6E53)", "UINT32", list(SUNS), "sunspec"), 2)
    chain.functions[-1].marker = [(SUNS[0] << 16) | SUNS[1]]
    seen: dict[int, int] = {}
    ids = []
    prefixes = []
    for model, repeat in models:
        mid = int(model["id"])
        seen[mid] = seen.get(mid, 0) + 1
        ids.append(str(mid))
        prefix = str(mid) if seen[mid] == 1 else f"{mid}-{seen[mid]}"
        prefixes.append((mid, prefix))
        _add_model(chain, model, repeat, prefix)
    chain.notes.extend(assign_roles(chain.functions, prefixes))
    label = "end"
    chain.add(_fixed("end_ID", "SunSpec end marker: model ID 0xFFFF", "UINT16", [END_ID], label), 1)
    chain.add(_fixed("end_L", "SunSpec end marker: length 0", "UINT16", [0], label), 1)
    device = Device(
        name=f"SunSpec {' '.join(ids)}",
        description=f"SunSpec chain at {base}: models {', '.join(ids)} (mdl import --from sunspec)",
        functions=chain.functions,
        version="1.0",
        max_registers=max_registers,
    )
    device.notes.extend(chain.notes)
    return device


def _fixed(name: str, description: str, fmt: str, initial: list[int], block: str) -> Function:
    return Function(
        name,
        description,
        [],
        format=fmt,
        block_labels=[block],
        access="read",
        immutable=True,
        system=True,
        initial=initial,
    )


def _count_points(group: dict[str, Any]) -> set[str]:
    found = set()
    for g in group.get("groups", []):
        if isinstance(g.get("count"), str):
            found.add(g["count"])
        found |= _count_points(g)
    return found


def _add_model(chain: _Chain, model: ModelDef, repeat: int, prefix: str) -> None:
    group = model["group"]
    block = str(group["name"])
    start = len(chain.functions)
    first = chain.address
    _add_group(chain, group, prefix, [], repeat, _count_points(group), block)
    id_fn, len_fn = chain.functions[start], chain.functions[start + 1]
    id_fn.initial = [int(model["id"])]
    len_fn.initial = [chain.address - first - 2]
    for fn in (id_fn, len_fn):
        fn.system = fn.immutable = True
        fn.access, fn.not_implemented = "read", None


def _add_group(
    chain: _Chain,
    group: dict[str, Any],
    prefix: str,
    scopes: list[_Scope],
    repeat: int,
    counts: set[str],
    block: str,
) -> None:
    points = group.get("points", [])
    scope = _Scope(
        {p["name"]: f"{prefix}_{p['name']}" for p in points}, {p["name"] for p in points if p["type"] == "sunssf"}
    )
    inner = [*scopes, scope]
    for point in points:
        for fn, registers in _functions(point, prefix, inner, block, chain):
            if point["name"] in counts or (point["type"] == "count" and not scopes):  # a legacy count too
                fn.initial = [repeat]
            chain.add(fn, registers)
    for sub in group.get("groups", []):
        count = sub.get("count")
        name = f"{prefix}_{sub['name']}"
        if count is None:
            _add_group(chain, sub, name, inner, repeat, set(), block)
            continue
        times = count if isinstance(count, int) and count > 0 else repeat
        for i in range(1, times + 1):
            _add_group(chain, sub, f"{name}_{i}", inner, repeat, set(), block)


def _scale_factor(sf: str, scopes: list[_Scope]) -> str:
    """The function of scale factor point `sf`: the point's own group first, then the model's top-level
    group (as pysunspec2 looks), then the groups between; a point of that name that is no scale factor
    is passed over."""
    for scope in (scopes[-1], scopes[0], *reversed(scopes[1:-1])):
        if sf in scope.factors:
            return scope.names[sf]
    raise AssertionError(f"scale factor {sf} was checked when the model was read")


def _description(point: dict[str, Any]) -> str:
    label = str(point.get("label") or point["name"])
    desc = str(point.get("desc") or "").strip()
    text = f"{label}: {desc}" if desc and desc != label else label
    if point["type"].startswith("bitfield") and point.get("symbols"):
        bits = ", ".join(f"{s['value']} {s['name']}" for s in point["symbols"])
        text += f" Bits: {bits}."
    return text


def _functions(
    point: dict[str, Any], prefix: str, scopes: list[_Scope], block: str, chain: _Chain
) -> list[tuple[Function, int]]:
    """The point as functions with the registers each takes (one, or a long string's or an IPv6
    address's parts)."""
    kind = point["type"]
    fmt, missing = FORMAT[kind]
    registers = TYPE_REGISTERS[kind] or int(point["size"])
    fn = Function(
        f"{prefix}_{point['name']}",
        _description(point),
        [],
        format=fmt,
        block_labels=[block],
        units=point.get("units") or None,
        access="read_write" if point.get("access") == "RW" else "read",
        not_implemented=list(missing) if missing else None,
        immutable=True if point.get("static") == "S" else None,
        system=True if kind == "pad" else None,
    )
    if kind.startswith("enum") and point.get("symbols"):
        fn.values = {int(s["value"]): str(s["name"]) for s in point["symbols"]}
    sf = point.get("sf")
    if (sf is not None and kind in UNSCALED) or (isinstance(sf, str) and fmt not in INTEGER_FORMATS):
        what = f"scale factor {sf!r} left out: MDL scales an integer by a scale factor point, a number by a constant"
        chain.notes.append(Diagnostic(None, None, None, f"'{fn.name}' ({kind}): {what}", "warning"))
    elif isinstance(sf, str):
        fn.scale_exponent = _scale_factor(sf, scopes)
    elif isinstance(sf, int) and sf:
        fn.multiplier = 10.0**sf
    if kind == "string":
        fn.count = registers
    part = chain.max_registers if kind == "string" else 4
    if registers <= part or kind not in ("string", "ipv6addr"):
        return [(fn, registers)]
    parts = []
    pieces = -(-registers // part)
    for i in range(pieces):
        size = min(part, registers - i * part)
        piece = replace(fn, name=f"{fn.name}_{i + 1}", addresses=[])
        piece.description = f"{fn.description} (registers {i * part + 1}-{i * part + size} of {registers})"
        if kind == "string":
            piece.count = size
        parts.append((piece, size))
    return parts
