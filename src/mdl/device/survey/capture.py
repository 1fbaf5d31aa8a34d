"""`mdl capture` (SPEC section 14): record a device's registers as the raw image `mdl sim --registers` serves
back (SPEC 6's JSON, keys wire addresses), or as an MDL test scenario `mdl test` replays.

With a description, every register its readable functions name is read with the description's read plan
(the grouped requests; where the device refuses one with exception 2, its smaller requests, as `mdl read`
falls back), then those of its write-only functions, run by run (a device that refuses them: a warning);
with `--ranges` from `mdl probe --format json`, every address of the unit's ranges, in requests of at most
125 registers / 2000 bits. The scenario's expected values are decoded from the very
registers captured, with the decoders `mdl read` uses, so replaying it gives what `mdl read` got.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

from mdl.device.connection import Connection
from mdl.device.evaluate import Evaluator
from mdl.device.link import Link, ModbusExceptionError
from mdl.diagnostics import MdlError, error, one_line
from mdl.fileio import read_text
from mdl.model import BIT_TABLES, REGISTER_TYPES, Device, Scenario, ScenarioInput, Value
from mdl.model.layout import MAX_ADDRESS, MAX_BITS, MAX_REGISTERS, address_runs
from mdl.plan import Request
from mdl.resolver import ResolvedDevice

Image = dict[str, dict[int, int]]  # table -> wire address -> register or bit value


def _empty() -> Image:
    return {t: {} for t in REGISTER_TYPES}


def capture_described(resolved: ResolvedDevice, connection: Connection, unit: int) -> tuple[Image, list[str]]:
    """The registers of every function the description names, and a warning for each request the device
    refused even alone (its registers are then not in the image). A write-only function's registers are
    asked too, run by run, after the read plan: a device may let them be read (a coil's state), and
    replayed by `mdl sim` they should read as they did."""
    image: Image = _empty()
    warnings: list[str] = []
    with Link(connection, unit) as session:
        for group in resolved.plan:
            _read_into(session, group.request, image, warnings, group.smaller)
        for f in resolved.functions:
            if f.fn.readable or f.compiled is not None:
                continue
            for start, count in f.runs:
                missing = [a for a in range(start, start + count) if a not in image[f.layout.table]]
                for first, n in address_runs(missing):
                    req = Request(f.layout.table, first, n, (f.name,))
                    try:
                        values = session.read_request(req)
                    except MdlError as exc:  # write-only: a device may refuse reading it in any way
                        warnings.append(f"{f.name} is write-only, and {exc.diagnostics[0].message}: not captured")
                        continue
                    image[req.table].update(zip(range(req.start, req.end), values, strict=True))
    return image, warnings


def _read_into(
    session: Link, req: Request, image: Image, warnings: list[str], smaller: tuple[Request, ...] = ()
) -> None:
    try:
        values = session.read_request(req)
    except ModbusExceptionError as exc:
        if exc.code != 2:
            raise
        if smaller:
            for part in smaller:
                _read_into(session, part, image, warnings)
            return
        warnings.append(f"{exc.diagnostics[0].message}: these registers are not captured")
        return
    image[req.table].update(zip(range(req.start, req.end), values, strict=True))


def _halves(req: Request) -> tuple[Request, ...]:
    """A refused read of a probe's range split in two (a device may refuse reads across its own blocks
    or through a 32-bit value); one address alone is not split."""
    if req.count == 1:
        return ()
    half = req.count // 2
    return (Request(req.table, req.start, half, ()), Request(req.table, req.start + half, req.count - half, ()))


def _read_split(session: Link, req: Request, image: Image, warnings: list[str]) -> None:
    try:
        values = session.read_request(req)
    except ModbusExceptionError as exc:
        if exc.code != 2:
            raise
        parts = _halves(req)
        if not parts:
            warnings.append(f"{exc.diagnostics[0].message}: not captured")
        for part in parts:
            _read_split(session, part, image, warnings)
        return
    image[req.table].update(zip(range(req.start, req.end), values, strict=True))


def capture_ranges(
    ranges: dict[str, list[tuple[int, int]]], connection: Connection, unit: int
) -> tuple[Image, list[str]]:
    """Every address of `ranges` (a probe's), read in requests as large as the protocol allows; a read the
    device refuses (exception 2) is split in halves down to single addresses, and what it refuses even
    alone is said, not captured."""
    image = _empty()
    warnings: list[str] = []
    with Link(connection, unit) as session:
        for table, spans in ranges.items():
            step = MAX_BITS if table in BIT_TABLES else MAX_REGISTERS
            for first, last in spans:
                for start in range(first, last + 1, step):
                    _read_split(session, Request(table, start, min(step, last + 1 - start), ()), image, warnings)
    return image, warnings


def image_json(image: Image) -> str:
    """SPEC 6's raw image: {"holding": {"101": 215}, ...}, tables in SPEC order, addresses ascending."""
    data = {t: {str(a): image[t][a] for a in sorted(image[t])} for t in REGISTER_TYPES}
    return json.dumps(data, indent=2) + "\n"


def read_ranges(path: Path, unit: int | None) -> tuple[int, dict[str, list[tuple[int, int]]]]:
    """The unit id and ranges of one unit of `mdl probe --format json` output (the one there is, or the one
    `unit` names). MdlError naming the file and what is wrong."""
    text = read_text(path)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"invalid JSON: {exc.msg}", path, exc.lineno, exc.colno) from None
    except ValueError as exc:
        raise error(f"invalid JSON: {exc}", path) from None
    if not isinstance(data, list) or not all(isinstance(u, dict) and _unit_id(u.get("unit")) for u in data):
        raise error(
            'expected the output of mdl probe --format json: a list of {"unit": U (0-255), "ranges": {...}}', path
        )
    units = [u["unit"] for u in data]
    if unit is None and len(units) != 1:
        raise error(f"it holds units {', '.join(map(str, units)) or 'none'}: pick one with --unit", path)
    chosen = next((u for u in data if unit is None or u["unit"] == unit), None)
    if chosen is None:
        raise error(f"no unit {unit} (it holds units {', '.join(map(str, units)) or 'none'})", path)
    ranges = chosen.get("ranges")
    if not isinstance(ranges, dict):
        raise error(f'unit {chosen["unit"]}: no "ranges" object', path)
    out: dict[str, list[tuple[int, int]]] = {}
    for table, spans in ranges.items():
        if spans is None and table in REGISTER_TYPES:  # a table the probe did not ask
            continue
        if table not in REGISTER_TYPES or not isinstance(spans, list):
            shown = one_line(str(table))[:20]
            raise error(f"unit {chosen['unit']}: unknown table {shown!r} (expected {', '.join(REGISTER_TYPES)})", path)
        out[table] = [_span(span, table, path) for span in spans]
    return int(chosen["unit"]), out


def _unit_id(unit: object) -> bool:
    """Whether a probe's unit is a unit id (0-255; true is not 1)."""
    return isinstance(unit, int) and not isinstance(unit, bool) and 0 <= unit <= 255


def _span(span: object, table: str, path: Path) -> tuple[int, int]:
    if (
        isinstance(span, list)
        and len(span) == 2
        and all(isinstance(a, int) and not isinstance(a, bool) for a in span)
        and 0 <= span[0] <= span[1] <= MAX_ADDRESS
    ):
        return span[0], span[1]
    raise error(f"{table}: {one_line(json.dumps(span))[:40]} is not a range [FIRST, LAST] of wire addresses", path)


def expected_text(value: Value) -> list[str] | None:
    """A value as a scenario's <expect> holds it (SPEC 2.2 tests): None for null; a bitset's labels."""
    if value is None:
        return None
    if isinstance(value, list):
        return list(value)
    if isinstance(value, bool):
        return ["true" if value else "false"]
    if isinstance(value, float):
        return ["NaN" if math.isnan(value) else repr(value)]
    return [str(value)]


def scenario(resolved: ResolvedDevice, image: Image, name: str, where: str) -> Scenario:
    """The test scenario of a capture: the registers as inputs (one per run of addresses), and the value
    every readable function decodes from them."""
    inputs: list[ScenarioInput] = []
    for table in REGISTER_TYPES:
        got = image[table]
        for start, count in address_runs(sorted(got)):
            run = [got[a] for a in range(start, start + count)]
            if table in BIT_TABLES:
                inputs.append(ScenarioInput(table, start, ["".join(str(v) for v in run)]))
            else:
                inputs.append(ScenarioInput(table, start, [f"{v:04X}" for v in run]))
    names = [f.name for f in resolved.readable]
    values = Evaluator(resolved).values(names, lambda table, address: image.get(table, {}).get(address))
    when = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    expected = {n: expected_text(values[n]) for n in names}
    return Scenario(name, f"captured from {where} at {when} (mdl capture)", inputs, expected)


def with_scenario(device: Device, sc: Scenario, path: Path) -> str:
    """The description with the scenario added after its own (as MDL 1.0 XML). MdlError where it already
    has a scenario of that name."""
    from mdl.formats.mdl.write import device_to_xml

    if any(t.id == sc.id for t in device.tests):
        raise error(f"it already has a test scenario '{sc.id}': give another --scenario name", path)
    try:
        return device_to_xml(replace(device, version="1.0", tests=[*device.tests, sc]))
    except (MdlError, ValueError) as exc:
        raise error(f"cannot write the scenario: {exc}", path) from None
