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
or not; units that do not answer are not; none at all is exit 3. Progress goes to stderr: a bar on a
terminal, else a line per unit. docs/discovery.md has the workflow.

Replies are not trusted: an identification reply is checked byte by byte (`parse_identification`) and a
malformed one shows nothing, with a warning naming the unit and what was wrong. After a request that got
no clean reply, late bytes of it must not reach the next request (they would make a silent unit look
present): on TCP the connection is opened anew, on a serial line what still comes is read and dropped
until the line is quiet (`_Unit._settle`).
"""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Generator, Iterable
from contextlib import closing
from dataclasses import dataclass, replace
from pathlib import Path

from pymodbus.constants import DeviceInformation
from pymodbus.exceptions import ModbusException

from mdl.device.connection import Connection
from mdl.device.link import Link, ModbusExceptionError
from mdl.device.replies import (
    DRAIN_MIN,
    DRAIN_TIMEOUTS,
    OBJECT_NAMES,
    IdReply,
    LineLost,
    came_from,
    drain,
    parse_identification,
    refused_problem,
    reply_pdu,
)
from mdl.diagnostics import DeviceError, Diagnostic, one_line
from mdl.exchange.text import aligned
from mdl.ir.build import decode_steps
from mdl.ir.codec import Decoder, compile_decoder
from mdl.model import Function, Value
from mdl.model.layout import Layout
from mdl.plan import Request
from mdl.resolver import ResolvedDevice

MAX_UNIT_ID = 255  # a unit id is one byte; 248-255 are reserved on a serial bus, used by some TCP devices
GATEWAY_SILENT = (10, 11)  # GATEWAY PATH UNAVAILABLE, GATEWAY TARGET DEVICE FAILED TO RESPOND
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
        raise ValueError(
            f"{one_line(text.strip())!r}: {'; '.join(problems)} (expected unit ids 0-{MAX_UNIT_ID} "
            "and ranges, e.g. 1-10,17)"
        )
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
    return replace(
        fn,
        multiplier=None,
        offset=None,
        read_function_code=None,
        write_function_code=None,
        not_implemented=None,
        minimum=None,
        maximum=None,
    )


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
    markers = tuple(
        _Marker(f.name, f.layout, raw_decoder(f.fn, f.layout), frozenset(f.fn.marker))
        for f in resolved.functions
        if f.fn.marker
    )
    return _Candidate(path, resolved.name, markers)


class _Unit:
    """The requests made to one unit: marker reads (each address run read once) and the identification.
    `answered`: the unit replied to something; `absent`: its first request got no reply. `command` names the
    command in its messages (mdl probe asks units this way too)."""

    command = "mdl discover"

    def __init__(self, session: Link, unit: int) -> None:
        self.session, self.unit = session, unit
        self.answered = self.absent = False
        self.reads: dict[tuple[str, tuple[tuple[int, int], ...]], list[int] | None] = {}

    def _gateway_silent(self) -> None:
        """Exception 10 or 11: a gateway saying nothing answers behind it; the unit is absent if it never
        answered. The connection is opened again if that closed it (pymodbus closes a TCP connection after
        several silent requests); DeviceError (exit 3) if it cannot be."""
        if not self.answered:
            self.absent = True
        self.session.connect()

    def _failed(self) -> None:
        """A request got no reply the client took (nothing, or bytes it could not decode). The unit answered
        if what came back is its reply (`came_from`), and is absent if nothing of it came and it never
        answered. Then the line is settled, so that nothing late reaches the next request."""
        if came_from(self.session.wire, self.unit):
            self.answered = True
        elif not self.answered:
            self.absent = True
        self._settle()

    def _stale(self) -> bool:
        """Whether the last request got bytes, none of them its reply (late bytes of an earlier reply, of
        another unit perhaps): then they are said and dropped, the line settled, and the request is to be
        sent again."""
        wire = self.session.wire
        if not wire.received or came_from(wire, self.unit):
            return False
        data = wire.received[-1]
        shown = data[:8].hex(" ") + (" ..." if len(data) > 8 else "")
        how = "a new connection" if self.session.connection.serial is None else "the line drained"
        what = (
            f"{len(data)} bytes came that are no reply of this unit ({shown}), late bytes of an earlier reply "
            f"perhaps: dropped, with {how}, and asked again"
        )
        _say(f"warning: {self.session.where(what)}", self.command)
        self._settle()
        return True

    def _settle(self) -> None:
        """Make sure no late byte of the last reply is read as part of the next: on TCP (either framing) a
        new connection; on a serial line, where bytes came, drop what comes until the line is quiet for one
        timeout. DeviceError (exit 3) if the connection cannot be opened again, or the line never goes quiet."""
        session, conn = self.session, self.session.connection
        if conn.serial is None:
            session.close()
            try:
                session.connect()
            except DeviceError as exc:
                raise LineLost(exc.diagnostics[0].message) from None
            return
        port = getattr(session.client, "socket", None)
        if not session.wire.received or port is None:
            return
        limit = max(DRAIN_TIMEOUTS * conn.timeout, DRAIN_MIN)
        busy = drain(port, conn.timeout, limit)
        if busy is not None:
            raise LineLost(
                f"{conn}: the line did not go quiet: bytes kept coming for {limit:g} s after unit "
                f"{self.unit} was asked ({busy.hex(' ')} ...), a device still sending; no other unit "
                "can be asked on this line"
            )

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
                values = self._read_request(Request(lay.table, start, count, (name,)))
            except ModbusExceptionError as exc:
                if exc.code in GATEWAY_SILENT:
                    self._gateway_silent()
                else:
                    self.answered = True  # it is there, but has no such registers
                return None
            except LineLost:
                raise
            except DeviceError:
                self._failed()
                return None
            self.answered = True
            got.update(zip(range(start, start + count), values, strict=True))
        return [got[a] for a in lay.addresses]

    def _read_request(self, request: Request) -> list[int]:
        """session.read_request, sent once more where someone else's late bytes spoilt the first reply."""
        try:
            return self.session.read_request(request)
        except ModbusExceptionError:
            raise
        except DeviceError:
            if not self._stale():
                raise
        return self.session.read_request(request)

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
        "more follows", which must be a later basic object: three requests at most), or None where the unit
        answers with an exception, no reply, or none of them. A malformed reply gives None, whatever earlier
        replies gave, and a warning saying what was wrong with it."""
        found: dict[str, str] = {}
        object_id = 0
        for _ in OBJECT_NAMES:  # each reply must name a later object: one request per object at most
            reply = self._identification_reply(object_id)
            if reply is None:
                return None
            if isinstance(reply, int):  # an exception
                break
            for oid, data in reply.objects:
                if 0 <= oid < len(OBJECT_NAMES) and OBJECT_NAMES[oid] not in found:
                    found[OBJECT_NAMES[oid]] = data.decode("utf-8", "replace")
            if not reply.more:
                break
            object_id = reply.next_object
        return {name: found[name] for name in OBJECT_NAMES if name in found} or None

    def _identification_reply(self, object_id: int) -> IdReply | int | None:
        """One Read Device Identification request from `object_id`: the reply, the exception code, or None
        (no reply, or a malformed one: then a warning says what was wrong)."""
        session = self.session
        for attempt in (1, 2):  # once more where someone else's late bytes spoilt the first
            session.wire.clear()
            try:
                session.client.read_device_information(
                    read_code=DeviceInformation.BASIC, object_id=object_id, device_id=self.unit
                )
                break
            except (ModbusException, OSError):
                if attempt == 1 and self._stale():
                    continue
                if came_from(session.wire, self.unit):
                    self._warn(refused_problem(session.wire, self.unit, object_id, session.connection.timeout))
                self._failed()
                return None
        pdu = reply_pdu(session.wire, self.unit)
        try:
            if pdu is None:
                raise ValueError("the reply the client decoded is not in the bytes received")
            reply = parse_identification(pdu, object_id)
        except ValueError as exc:
            self.answered = True
            self._warn(str(exc))
            self._settle()
            return None
        if isinstance(reply, int) and reply in GATEWAY_SILENT:
            self._gateway_silent()
        else:
            self.answered = True  # with its identification, or an exception: it is there
        return reply

    def _warn(self, problem: str) -> None:
        _say(
            f"warning: {self.session.where('reading the device identification (function 43)')}: {problem}; "
            "none of it is shown"
        )


def _ask(session: Link, unit: int, candidates: list[_Candidate]) -> UnitResult | None:
    """The unit's result, or None if it did not answer."""
    session.unit = unit
    asked = _Unit(session, unit)
    matched = [c for c in candidates if not asked.absent and asked.matches(c)]
    identification = None if asked.absent else asked.identification()
    if asked.absent or not asked.answered:
        return None
    return UnitResult(unit, [c.path for c in matched], [c.name for c in matched], identification)


def _say(message: str, command: str = "mdl discover") -> None:
    print(f"{command}: {message}", file=sys.stderr, flush=True)


def library_warnings(path: Path, resolved: ResolvedDevice) -> list[Diagnostic]:
    """What makes a description useless for discovery (the command prints these, and --fail-on-warning
    refuses them): no function with a marker, so it never matches."""
    if any(f.fn.marker for f in resolved.functions):
        return []
    return [
        Diagnostic(
            str(path),
            None,
            None,
            "no function has a marker: this description never matches (mdl discover compares marker values)",
            "warning",
        )
    ]


def _summary(unit: int, result: UnitResult | None) -> str:
    if result is None:
        return f"unit {unit}: no answer"
    found = ", ".join(one_line(str(p)) for p in result.matches) or "no description matches"
    ident = " ".join(result.identification.values()) if result.identification else ""
    return f"unit {unit}: {found}" + (f" (identification: {one_line(ident)})" if ident else "")


def _progress(units: list[int], connection: Connection) -> Generator[tuple[int, bool], None, None]:
    """Each unit, and whether to print a line for it (not on a terminal, where a bar shows progress)."""
    if sys.stderr.isatty():
        label = f"asking units on {connection}"
        try:
            for done, unit in enumerate(units):
                sys.stderr.write(f"\r\x1b[K{label} [{done}/{len(units)}] unit {unit}")
                sys.stderr.flush()
                yield unit, False
        finally:
            sys.stderr.write(f"\r\x1b[K{label} [{len(units)}/{len(units)}]\n")
            sys.stderr.flush()
    else:
        for unit in units:
            yield unit, True


def discover(library: list[tuple[Path, ResolvedDevice]], connection: Connection, units: list[int]) -> list[UnitResult]:
    """Ask each unit over `connection` which descriptions of `library` it is (SPEC section 10); the units
    that answered, in ascending order. DeviceError (exit 3) if no unit answered, if the connection cannot
    be opened, or is lost and cannot be opened again, or if a serial line never goes quiet."""
    candidates = [_candidate(path, resolved) for path, resolved in library]
    if connection.serial is not None and 0 in units:
        _say("unit 0 is the broadcast address on a serial line, which no device answers: not asked")
        units = [u for u in units if u != 0]
    session = Link(connection)
    session.client.set_max_no_responses(len(units) + 3)  # silent units are the rule here, not a broken line
    session.asking_units(units)
    results: list[UnitResult] = []
    with session:
        _say(
            f"asking {len(units)} unit{'s' * (len(units) != 1)} on {connection} "
            f"(at most {connection.timeout:g} s each when nothing answers)"
        )
        with closing(_progress(units, connection)) as steps:  # the bar ends on an error too
            for unit, line in steps:
                result = _ask(session, unit, candidates)
                if line:
                    _say(_summary(unit, result))
                if result is not None:
                    results.append(result)
    matched = sum(1 for r in results if r.matches)
    _say(f"{len(results)} unit{'s' * (len(results) != 1)} answered, {matched} matched a description")
    if not results:
        hint = connection.silence_hint()
        raise DeviceError(
            f"{connection}: no unit answered (asked {unit_list(units) or 'none'})" + (f"; {hint}" if hint else "")
        )
    return results


def unit_list(units: Iterable[int]) -> str:
    """Unit ids as `--units` takes them: ascending, runs as FIRST-LAST (`1-10,17`); parse_units reads it back."""
    runs: list[list[int]] = []
    for unit in sorted(set(units)):
        if runs and unit == runs[-1][1] + 1:
            runs[-1][1] = unit
        else:
            runs.append([unit, unit])
    return ",".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


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
        data = [
            {"unit": r.unit, "matches": [str(p) for p in r.matches], "identification": r.identification}
            for r in results
        ]
        return json.dumps(data, indent=2) + "\n"
    if fmt != "table":
        raise ValueError(f"unknown format {fmt!r}")
    rows = [["UNIT", "FILE", "DEVICE", *OBJECT_NAMES]]
    rows += [[one_line(cell) for cell in cells] for r in results for cells in _cells(r)]
    return "".join(line.rstrip() + "\n" for line in aligned(rows))
