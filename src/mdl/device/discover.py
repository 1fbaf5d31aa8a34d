"""`mdl discover` (SPEC section 10): which of a library of descriptions answers at each unit id.

A description matches a unit when every function of it that carries `marker` values reads one of
them there, compared as the raw value (the registers composed by format, byte and word order, before
multiplier, offset, fragment and "not implemented"; 0/1 for a bit). Each marker function is read
alone, with the requests that read it alone (its address runs), so that nothing but its own addresses
is touched; a description's remaining marker functions are not read once one fails, and two
descriptions with a marker function at the same addresses share one read. A description without
markers never matches. Then the unit is asked function 43 / MEI 14 (Read Device Identification,
the basic objects).

The first request a unit gets decides whether it is there: no reply within the connection's timeout
(or exception 10/11, a gateway saying nothing answers behind it) and the unit is skipped, at the cost
of that one timeout. Units that answer anything, even only exceptions, are in the results, matched
or not; units that do not answer are not. Progress goes to stderr: a bar on a terminal, else a line
per unit. docs/discovery.md has the workflow.
"""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Generator, Iterable
from contextlib import closing
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import click
from pymodbus.constants import DeviceInformation, MoreData
from pymodbus.exceptions import ModbusException
from pymodbus.pdu.mei_message import ReadDeviceInformationResponse

from mdl.device.connection import Connection
from mdl.device.runtime import ModbusExceptionError, Session
from mdl.device.sim import IDENTIFICATION
from mdl.diagnostics import DeviceError, Diagnostic, one_line
from mdl.model import Device, Function, Value
from mdl.model.layout import Layout
from mdl.plan import Request
from mdl.resolve import ResolvedDevice
from mdl.values.build import decode_steps
from mdl.values.codec import Decoder, compile_decoder

MAX_UNIT_ID = 255  # a unit id is one byte; 248-255 are reserved on a serial bus, used by some TCP devices
GATEWAY_SILENT = (10, 11)  # GATEWAY PATH UNAVAILABLE, GATEWAY TARGET DEVICE FAILED TO RESPOND
OBJECT_NAMES = tuple(name for name, _ in IDENTIFICATION)  # the basic objects, by object id
_UNIT_ITEM = re.compile(r"\s*([0-9]{1,6})\s*(?:-\s*([0-9]{1,6})\s*)?", re.ASCII)
_NUMBER_LIKE = re.compile(r"\s*[0-9]+\s*(?:-\s*[0-9]+\s*)?", re.ASCII)


def parse_units(text: str) -> list[int]:
    """The unit ids of a list like `1-10,17`: numbers and ranges FIRST-LAST (both included) separated by
    commas, each from 0 to 255; ascending, each once. ValueError naming every bad item otherwise."""
    units: set[int] = set()
    problems: list[str] = []
    for item in text.split(","):
        shown = item.strip()
        match = _UNIT_ITEM.fullmatch(item)
        if match is None:
            if _NUMBER_LIKE.fullmatch(item):  # more than 6 digits
                problems.append(f"'{shown}' is outside 0-{MAX_UNIT_ID}")
            else:
                problems.append(f"'{shown}' is not a unit id or a range FIRST-LAST" if shown else "an empty item")
            continue
        first = int(match[1])
        last = int(match[2]) if match[2] is not None else first
        outside = [n for n in dict.fromkeys((first, last)) if n > MAX_UNIT_ID]
        if outside:
            problems += [f"{n} is outside 0-{MAX_UNIT_ID}" for n in outside]
        elif first > last:
            problems.append(f"'{shown}' runs backwards (write {last}-{first})")
        else:
            units.update(range(first, last + 1))
    if problems:
        raise ValueError(f"{one_line(text.strip())!r}: {'; '.join(problems)} (expected unit ids 0-{MAX_UNIT_ID} "
                         "and ranges, e.g. 1-10,17)")
    return sorted(units)


@dataclass(frozen=True)
class UnitResult:
    """A unit that answered: the descriptions that matched it (the paths as given, in the library's order),
    their device names, and its basic device identification (object name -> text), None where it gave none."""

    unit: int
    matches: list[Path]
    devices: list[str]
    identification: dict[str, str] | None


def raw_function(fn: Function) -> Function:
    """`fn` as its raw value reads: without multiplier, offset, fragments, "not implemented" and bounds
    (SPEC 2.2 `marker`). Its value IR is then the function's own up to the point where scaling begins."""
    return replace(fn, multiplier=None, offset=None, read_function_code=None, write_function_code=None,
                   not_implemented=None, minimum=None, maximum=None)


def raw_decoder(fn: Function, lay: Layout) -> Decoder:
    """Registers (address order) -> the raw value of `fn` (an int, a float for FLOAT32/64, a bool for a bit)."""
    return compile_decoder(fn.name, decode_steps(raw_function(fn), lay))


@dataclass(frozen=True)
class _Marker:
    name: str
    layout: Layout
    decode: Decoder
    values: frozenset[int]

    def matches(self, raw: Value) -> bool:
        return isinstance(raw, (bool, int, float)) and raw in self.values  # True == 1, 3.0 == 3


@dataclass(frozen=True)
class _Candidate:
    path: Path
    name: str
    markers: tuple[_Marker, ...]


def _candidate(path: Path, resolved: ResolvedDevice) -> _Candidate:
    markers = tuple(_Marker(f.name, f.layout, raw_decoder(f.fn, f.layout), frozenset(f.fn.marker))
                    for f in resolved.functions if f.fn.marker)
    return _Candidate(path, resolved.name, markers)


class _Unit:
    """The requests made to one unit: marker reads (each address run read once) and the identification.
    `answered`: the unit replied to something; `absent`: its first request got no reply."""

    def __init__(self, session: Session, unit: int) -> None:
        self.session, self.unit = session, unit
        self.answered = self.absent = False
        self.reads: dict[tuple[str, tuple[tuple[int, int], ...]], list[int] | None] = {}

    def _silent(self) -> None:
        """A request got no reply: the unit is absent if it never answered. The connection is opened
        again if that closed it (pymodbus closes a TCP connection after several silent requests);
        DeviceError (exit 3) if it cannot be."""
        if not self.answered:
            self.absent = True
        self.session.connect()

    def registers(self, marker: _Marker) -> list[int] | None:
        """The registers of a marker function, read alone; None if the unit did not give them all."""
        lay = marker.layout
        key = (lay.table, lay.runs)
        if key not in self.reads:
            self.reads[key] = self._read(marker.name, lay)
        return self.reads[key]

    def _read(self, name: str, lay: Layout) -> list[int] | None:
        got: dict[int, int] = {}
        for start, count in lay.runs:
            if self.absent:
                return None
            try:
                values = self.session.read_request(Request(lay.table, start, count, (name,)))
            except ModbusExceptionError as exc:
                if exc.code in GATEWAY_SILENT:
                    self._silent()
                else:
                    self.answered = True  # it is there, but has no such registers
                return None
            except DeviceError:
                if self.session.wire.received:
                    self.answered = True  # something came back, not the registers
                else:
                    self._silent()
                return None
            self.answered = True
            got.update(zip(range(start, start + count), values, strict=True))
        return [got[a] for a in lay.addresses]

    def matches(self, candidate: _Candidate) -> bool:
        if not candidate.markers:
            return False
        for marker in candidate.markers:  # stops at the first that does not read its marker
            regs = self.registers(marker)
            if regs is None or not marker.matches(marker.decode(regs)):
                return False
        return True

    def identification(self) -> dict[str, str] | None:
        """The basic objects of Read Device Identification (asked for again from where the device says
        "more follows"), or None where the unit answers with an exception, no reply, or none of them."""
        found: dict[str, str] = {}
        object_id = 0
        for _ in OBJECT_NAMES:  # one request per object at most
            self.session.wire.clear()
            try:
                reply = self.session.client.read_device_information(
                    read_code=DeviceInformation.BASIC, object_id=object_id, device_id=self.unit)
            except (ModbusException, OSError):
                if self.session.wire.received:
                    self.answered = True
                else:
                    self._silent()
                break
            if reply.isError():
                if getattr(reply, "exception_code", 0) in GATEWAY_SILENT:
                    self._silent()
                else:
                    self.answered = True  # it is there, without identification
                break
            self.answered = True
            if not isinstance(reply, ReadDeviceInformationResponse):
                break
            for oid, data in sorted(reply.information.items()):
                if 0 <= oid < len(OBJECT_NAMES):
                    found[OBJECT_NAMES[oid]] = _object_text(data)
            if reply.more_follows != MoreData.KEEP_READING or reply.next_object_id <= object_id:
                break
            object_id = reply.next_object_id
        return {name: found[name] for name in OBJECT_NAMES if name in found} or None


def _object_text(data: Any) -> str:
    """An identification object as text (pymodbus gives bytes, or a list of them for a repeated object)."""
    if isinstance(data, list):
        data = data[0] if data else b""
    return data.decode("utf-8", "replace") if isinstance(data, bytes) else str(data)


def _ask(session: Session, unit: int, candidates: list[_Candidate]) -> UnitResult | None:
    """The unit's result, or None if it did not answer."""
    session.unit = unit
    asked = _Unit(session, unit)
    matched = [c for c in candidates if not asked.absent and asked.matches(c)]
    identification = None if asked.absent else asked.identification()
    if asked.absent or not asked.answered:
        return None
    return UnitResult(unit, [c.path for c in matched], [c.name for c in matched], identification)


def _say(message: str) -> None:
    click.echo(f"mdl discover: {message}", err=True)


def library_warnings(path: Path, resolved: ResolvedDevice) -> list[Diagnostic]:
    """What makes a description useless for discovery (the command prints these, and --fail-on-warning
    refuses them): no function with a marker, so it never matches."""
    if any(f.fn.marker for f in resolved.functions):
        return []
    return [Diagnostic(str(path), None, None, "no function has a marker: this description never matches "
                                              "(mdl discover compares marker values)", "warning")]


def _summary(unit: int, result: UnitResult | None) -> str:
    if result is None:
        return f"unit {unit}: no answer"
    found = ", ".join(one_line(str(p)) for p in result.matches) or "no description matches"
    ident = " ".join(result.identification.values()) if result.identification else ""
    return f"unit {unit}: {found}" + (f" (identification: {one_line(ident)})" if ident else "")


def _progress(units: list[int], connection: Connection) -> Generator[tuple[int, bool], None, None]:
    """Each unit, and whether to print a line for it (not on a terminal, where a bar shows progress)."""
    if sys.stderr.isatty():
        with click.progressbar(units, label=f"asking units on {connection}", file=sys.stderr,
                               item_show_func=lambda u: None if u is None else f"unit {u}") as bar:
            for unit in bar:
                yield unit, False
    else:
        for unit in units:
            yield unit, True


def discover(library: list[tuple[Path, ResolvedDevice]], connection: Connection,
             units: list[int]) -> list[UnitResult]:
    """Ask each unit over `connection` which descriptions of `library` it is (SPEC section 10); the units
    that answered, in ascending order. DeviceError (exit 3) if the connection cannot be opened, or is
    lost and cannot be opened again."""
    candidates = [_candidate(path, resolved) for path, resolved in library]
    if connection.serial is not None and 0 in units:
        _say("unit 0 is the broadcast address on a serial line, which no device answers: not asked")
        units = [u for u in units if u != 0]
    device = library[0][1] if library else Device("discover", "")
    session = Session(device, connection)
    session.client.set_max_no_responses(len(units) + 3)  # silent units are the rule here, not a broken line
    results: list[UnitResult] = []
    with session:
        _say(f"asking {len(units)} unit{'s' * (len(units) != 1)} on {connection} "
             f"(at most {connection.timeout:g} s each when nothing answers)")
        with closing(_progress(units, connection)) as steps:  # the bar ends on an error too
            for unit, line in steps:
                result = _ask(session, unit, candidates)
                if line:
                    _say(_summary(unit, result))
                if result is not None:
                    results.append(result)
    matched = sum(1 for r in results if r.matches)
    _say(f"{len(results)} unit{'s' * (len(results) != 1)} answered, {matched} matched a description")
    return results


def _cells(result: UnitResult) -> Iterable[list[str]]:
    ident = result.identification or {}
    tail = [ident.get(name) or "-" for name in OBJECT_NAMES]
    rows = [(str(path), name) for path, name in zip(result.matches, result.devices, strict=True)] or [("-", "-")]
    for path, name in rows:
        yield [str(result.unit), path, name, *tail]


def render(results: list[UnitResult], fmt: str) -> str:
    """`table`: a row per unit and matched description (unit, file, device name, VendorName, ProductCode,
    MajorMinorRevision; `-` where there is none); `json`: a list of objects
    `{"unit": U, "matches": [FILE...], "identification": {...} or null}`."""
    if fmt == "json":
        data = [{"unit": r.unit, "matches": [str(p) for p in r.matches], "identification": r.identification}
                for r in results]
        return json.dumps(data, indent=2) + "\n"
    if fmt != "table":
        raise ValueError(f"unknown format {fmt!r}")
    rows = [["UNIT", "FILE", "DEVICE", *OBJECT_NAMES]]
    rows += [[one_line(cell) for cell in cells] for r in results for cells in _cells(r)]
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "".join("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() + "\n"
                   for row in rows)
