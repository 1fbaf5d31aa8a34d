"""`mdl probe` (SPEC section 14): which unit ids of an unknown device answer (at which serial settings), and
which address ranges of each table a unit defines. It only reads; docs/probe.md has the rules.

A unit is there when it answers its first request with anything but a gateway's exception 10/11 (mdl
discover's rule, and its `_Unit` keeps the line settled between requests). Then each table is read over
`--range`: one address at a time in undefined territory, and from each defined address reads of 2, 4, 8,
... addresses, then halving, so the edges of every defined run are exact (exception 2 marks the gaps; a
read across a gap gets it even where both sides are defined). Exception 1 ends the table (the unit has
none). Anything else (another exception, no reply, a reply the checks of mdl.device.frames refuse)
leaves the addresses asked "unknown": never defined. Bounded and polite: `max_requests` per unit (each
table an even share of what is left), at most `rate` requests a second, and a unit is left after
STRUGGLING signs in a row that it is struggling (no reply, a malformed reply, exception 4, 5 or 6).
Guesses at the address base and the word order (mdl.device.survey.probe_guess) are said as guesses; the
command's options are read by mdl.device.survey.probe_options. Progress goes to stderr: a line per unit, and
where stderr is a terminal a line redrawn as requests go (`_Progress`, mdl discover's bar), not under -q.
"""

from __future__ import annotations

import json
import re
import shutil
import sys
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

from mdl.device.connection import Connection
from mdl.device.link import EXCEPTION_NAMES, Link, ModbusExceptionError
from mdl.device.replies import LineLost
from mdl.device.survey.discover import GATEWAY_SILENT, _Unit, unit_list
from mdl.device.survey.probe_guess import guesses
from mdl.device.survey.probe_options import ProbeOptions, Span
from mdl.diagnostics import DeviceError
from mdl.model import BIT_TABLES, REGISTER_TYPES
from mdl.model.layout import MAX_ADDRESS, MAX_BITS, MAX_REGISTERS
from mdl.plan import Request
from mdl.records import replace

STRUGGLING = 3  # signs in a row that a unit is struggling before it is left alone
STRUGGLE_CODES = (4, 5, 6)  # SERVER DEVICE FAILURE, ACKNOWLEDGE, SERVER DEVICE BUSY


class _Stop(Exception):
    """The unit is left: its budget is spent, or it is struggling. `unasked`: why the rest is not probed."""

    def __init__(self, message: str, unasked: str) -> None:
        super().__init__(message)
        self.unasked = unasked


BUDGET_RAN_OUT = "the request budget ran out: --max-requests, or a narrower --range"
NOT_ASKED = "not in --tables"
LINE_LOST = "the connection was lost"


@dataclass
class UnitProbe:
    """What a probe found at one unit: the defined ranges of each table, the spans it could not judge and
    those it left unasked (each with why), the registers read (for the guesses), the requests used, and
    notes to say."""

    unit: int
    serial: dict[str, object] | None
    ranges: dict[str, list[Span]] = field(default_factory=lambda: {t: [] for t in REGISTER_TYPES})
    unknown: dict[str, list[tuple[Span, str]]] = field(default_factory=lambda: {t: [] for t in REGISTER_TYPES})
    unasked: dict[str, list[tuple[Span, str]]] = field(default_factory=lambda: {t: [] for t in REGISTER_TYPES})
    values: dict[str, dict[int, int]] = field(default_factory=lambda: {t: {} for t in REGISTER_TYPES})
    requests: int = 0
    notes: list[str] = field(default_factory=list)
    tables: tuple[str, ...] = REGISTER_TYPES  # the tables asked (--tables): the others were not probed
    span: Span = (0, MAX_ADDRESS)  # the addresses asked (--range)

    def defined(self, table: str, first: int, values: list[int]) -> None:
        last = first + len(values) - 1
        runs = self.ranges[table]
        if runs and runs[-1][0] <= first <= runs[-1][1] + 1:  # reads go up the table: merge with the last run
            runs[-1] = (runs[-1][0], max(last, runs[-1][1]))
        else:
            runs.append((first, last))
        self.values[table].update(zip(range(first, last + 1), values, strict=True))

    def json(self) -> dict[str, object]:
        """SPEC 14's object, with what the notes say of the spans not found: `unknown` (asked, no answer to
        trust) and `not_probed` (never asked: the budget ran out, the unit was left alone, or the table is
        not in --tables), each a list of {"table", "range": [FIRST, LAST], "why"}."""
        not_asked = [(t, self.span, NOT_ASKED) for t in REGISTER_TYPES if t not in self.tables]
        return {
            "unit": self.unit,
            "serial": self.serial,
            # null: a table --tables did not ask, unlike [] (asked: nothing defined)
            "ranges": {
                t: [list(span) for span in self.ranges[t]] if t in self.tables else None for t in REGISTER_TYPES
            },
            "requests": self.requests,
            "unknown": _spans_json((t, span, why) for t in REGISTER_TYPES for span, why in self.unknown[t]),
            "not_probed": _spans_json(
                sorted(
                    [*((t, span, why) for t in REGISTER_TYPES for span, why in self.unasked[t]), *not_asked],
                    key=lambda item: (REGISTER_TYPES.index(item[0]), item[1]),
                )
            ),
        }


def _spans_json(spans: Iterable[tuple[str, Span, str]]) -> list[dict[str, object]]:
    return [{"table": table, "range": [first, last], "why": why} for table, (first, last), why in spans]


REDRAW = 0.1  # seconds between two drawings of the progress line at most (it is drawn at once when a unit begins)


def _clock() -> float:
    return time.monotonic()


class _Progress:
    """Where stderr is a terminal (and not under -q), one line redrawn as the requests go, as mdl discover's
    bar: `asking units on LINE [DONE/TOTAL] unit U: TABLE ADDRESS, N/BUDGET requests`, drawn when a unit
    begins and then at most every REDRAW seconds; at the end `asking units on LINE [DONE/TOTAL]` stays.
    Elsewhere it draws nothing (the line said for each unit is the progress)."""

    def __init__(self, on: bool, line: Connection, total: int) -> None:
        self.on, self.total = on, total
        self.label = f"asking units on {line}"
        self.done = 0
        self.unit = ""
        self.shown = False
        self.last = -1.0e9
        self.width = max(20, shutil.get_terminal_size().columns - 1) if on else 0

    def begin(self, unit: int) -> None:
        self.unit = f"unit {unit}"
        self._draw(self.unit)

    def request(self, table: str, address: int, requests: int, budget: int) -> None:
        if self.on and (not self.shown or _clock() - self.last >= REDRAW):
            self._draw(f"{self.unit}: {table} {address}, {requests}/{budget} requests")

    def hide(self) -> None:
        """Clear the line, before a line of stderr's own; the next request draws it again."""
        if self.shown:
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()
            self.shown = False

    def close(self) -> None:
        if self.on:
            sys.stderr.write(f"\r\x1b[K{self.label} [{self.done}/{self.total}]\n")
            sys.stderr.flush()
            self.shown = False

    def _draw(self, where: str) -> None:
        if not self.on:
            return
        text = f"{self.label} [{self.done}/{self.total}] {where}"
        sys.stderr.write(f"\r\x1b[K{text[: self.width]}")
        sys.stderr.flush()
        self.shown, self.last = True, _clock()


class _Pace:
    """At most `rate` requests a second (0: no limit), measured from the start of one to the next."""

    def __init__(self, rate: float) -> None:
        self.gap = 1.0 / rate if rate > 0 else 0.0
        self.next = 0.0

    def wait(self) -> None:
        now = time.monotonic()
        if now < self.next:
            time.sleep(self.next - now)
        self.next = max(now, self.next) + self.gap


class _Line(_Unit):
    """mdl discover's judge of a unit's presence, and what settles the line after a reply not to trust (its
    warning on a line of its own: the progress line is cleared first)."""

    command = "mdl probe"

    def __init__(self, session: Link, unit: int, bar: _Progress) -> None:
        super().__init__(session, unit)
        self.bar = bar

    def _stale(self) -> bool:
        self.bar.hide()
        return super()._stale()


class _Prober:
    """The requests to one unit, counted against its budget; what each got, judged."""

    def __init__(self, session: Link, unit: int, budget: int, pace: _Pace, found: UnitProbe, bar: _Progress) -> None:
        self.session, self.unit, self.budget, self.pace, self.found = session, unit, budget, pace, found
        self.bar = bar
        self.line = _Line(session, unit, bar)
        self.in_a_row = 0
        self.table_limit = budget  # _probe_unit gives each table its share

    def _send(self, req: Request) -> list[int]:
        """session.read_request, sent once more where late bytes of an earlier reply spoilt the first;
        each send is counted."""
        for attempt in (1, 2):
            if self.found.requests >= self.budget:
                raise _Stop(f"its budget of {self.budget} requests is spent (--max-requests)", BUDGET_RAN_OUT)
            if self.found.requests >= self.table_limit:
                raise _Spent
            self.pace.wait()
            self.found.requests += 1
            self.bar.request(req.table, req.start, self.found.requests, self.budget)
            try:
                return self.session.read_request(req)
            except ModbusExceptionError:
                raise
            except DeviceError:
                if attempt == 2 or not self.line._stale():
                    raise
        raise AssertionError("unreachable")

    def ask(self, table: str, start: int, count: int) -> list[int] | int | str:
        """The registers or bits, an exception code, or why there is no answer to trust (a text)."""
        self.session.unit = self.unit
        try:
            values = self._send(Request(table, start, count, ()))
        except ModbusExceptionError as exc:
            code = exc.code or 0
            if code in GATEWAY_SILENT:
                self.line._gateway_silent()
                return self._struggling(f"exception {code} ({EXCEPTION_NAMES[code]}), from a gateway")
            self.line.answered = True
            if code in STRUGGLE_CODES:
                return self._struggling(f"exception {code} ({EXCEPTION_NAMES.get(code, 'unknown')})")
            self.in_a_row = 0
            return code
        except LineLost:
            raise
        except DeviceError as exc:
            silent = not self.session.wire.received
            self.line._failed()
            why = exc.diagnostics[0].message.rsplit(": ", 1)[-1] if silent else _problem(exc)
            return self._struggling(why)
        self.line.answered = True
        self.in_a_row = 0
        return values

    def _struggling(self, why: str) -> str:
        self.in_a_row += 1
        if self.in_a_row >= STRUGGLING and self.line.answered:
            raise _Stop(
                f"it is struggling: {STRUGGLING} requests in a row got no good answer (the last: {why})",
                "the unit was left alone",
            )
        return why


def _problem(exc: DeviceError) -> str:
    """What was wrong with a reply, from the session's message (after the connection, unit and request)."""
    message = exc.diagnostics[0].message
    return message.split(": ", 2)[-1] if message.count(": ") >= 2 else message


class _Spent(Exception):
    """The table's share of the unit's budget is spent."""


@dataclass
class _Scan:
    """One table of one unit, address by address in undefined space and block by block in defined runs:
    an undefined address costs one request, a defined run of k addresses about 2 log2 k + k / block."""

    prober: _Prober
    table: str
    high: int
    pos: int = 0  # the lowest address not yet settled

    @property
    def block(self) -> int:
        return MAX_BITS if self.table in BIT_TABLES else MAX_REGISTERS

    def ask(self, start: int, count: int) -> list[int] | int | str:
        got = self.prober.ask(self.table, start, count)
        if isinstance(got, list):
            self.prober.found.defined(self.table, start, got)
        elif got == 1:
            self.prober.found.notes.append(f"{self.table}: exception 1 (ILLEGAL FUNCTION): the unit has no such table")
            raise _TableDone
        elif got != 2:
            why = got if isinstance(got, str) else f"exception {got} ({EXCEPTION_NAMES.get(got, 'unknown')})"
            self.prober.found.unknown[self.table].append(((start, start + count - 1), why))
        return got

    def run(self, pos: int) -> None:
        single = False  # in undefined space: one address at a time
        while pos <= self.high:
            self.pos = pos
            count = 1 if single else min(self.block, self.high - pos + 1)
            got = self.ask(pos, count)
            if isinstance(got, list) and count == 1:
                pos, single = self.extend(pos)
            elif isinstance(got, list):
                pos, single = pos + count, False
            elif got == 2:
                pos, single = (pos + 1, True) if count == 1 else (pos, True)
            else:  # unknown: said, and passed over
                pos, single = pos + count, False

    def extend(self, pos: int) -> tuple[int, bool]:
        """`pos` is defined: how far its run goes (reads of 2, 4, 8, ... then halving), recorded; the next
        address to ask and whether it is known to be undefined territory."""
        limit = min(self.block, self.high - pos + 1)
        good, bad = 1, limit + 1  # the longest read answered, the shortest refused (none yet: limit + 1)
        growing = True
        while bad - good > 1:
            size = min(good * 2, limit) if growing else (good + bad) // 2
            self.pos = pos + good
            got = self.ask(pos, size)
            if isinstance(got, list):
                good = size
            elif got == 2:
                bad, growing = size, False
            else:
                return pos + size, False
        if bad > limit:
            return pos + good, False
        # the read to pos + good was refused, which says only that the read was: a device may refuse reads
        # across its own blocks, so pos + good is asked alone next
        return pos + good, True


class _TableDone(Exception):
    pass


def _scan_table(prober: _Prober, table: str, low: int, high: int) -> None:
    """The defined runs of `table` between `low` and `high`; what is left unasked when the budget runs out or
    the unit is left alone is said, with why."""
    scan = _Scan(prober, table, high, low)
    try:
        scan.run(low)
    except _TableDone:
        return
    except _Spent:
        prober.found.unasked[table].append(((scan.pos, high), f"its share of {BUDGET_RAN_OUT}"))
        raise
    except _Stop as stop:
        prober.found.unasked[table].append(((scan.pos, high), stop.unasked))
        raise
    except LineLost:
        prober.found.unasked[table].append(((scan.pos, high), LINE_LOST))
        raise


def _probe_unit(prober: _Prober, tables: list[str], low: int, high: int) -> None:
    """Each table in turn, with an even share of what is left of the budget (a table that needs less leaves
    the rest to the tables after it)."""
    found = prober.found
    try:
        for i, table in enumerate(tables):
            left = prober.budget - found.requests
            prober.table_limit = found.requests + max(1, left // (len(tables) - i))
            try:
                _scan_table(prober, table, low, high)
            except _Spent:
                continue
            except _Stop as stop:
                for later in tables[i + 1 :]:
                    found.unasked[later].append(((low, high), stop.unasked))
                found.notes.append(f"left alone: {stop}")
                return
            except LineLost:
                for later in tables[i + 1 :]:
                    found.unasked[later].append(((low, high), LINE_LOST))
                raise
    finally:
        _say_unknown(found, tables)


def _say_unknown(found: UnitProbe, tables: list[str]) -> None:
    for table in tables:
        for (first, last), why in found.unknown[table]:
            found.notes.append(f"{table} {_span(first, last)}: unknown, no answer to trust ({why})")
        for (first, last), why in found.unasked[table]:
            found.notes.append(f"{table} {_span(first, last)}: not probed ({why})")


def _span(first: int, last: int) -> str:
    return str(first) if first == last else f"{first}-{last}"


def _say(message: str, bar: _Progress | None = None) -> None:
    """A line on stderr (the progress line cleared first)."""
    if bar is not None:
        bar.hide()
    print(f"mdl probe: {message}", file=sys.stderr, flush=True)


def _lines(connection: Connection, settings: list[tuple[int, str]]) -> Iterator[Connection]:
    if connection.serial is None:
        yield connection
        return
    for baud, parity in settings:
        yield replace(connection, baud=baud, parity=parity)


def probe(connection: Connection, options: ProbeOptions, quiet: bool = False) -> list[UnitProbe]:
    """Probe each unit over `connection` (on a serial line at each setting in turn, for the units no earlier
    setting found); the units that answered, in ascending order. DeviceError (exit 3) if none did. `quiet`
    (-q): no progress, only warnings."""
    units = options.units
    if connection.serial is not None and 0 in units:
        _say("unit 0 is the broadcast address on a serial line, which no device answers: not asked")
        units = [u for u in units if u != 0]
    results: dict[int, UnitProbe] = {}
    pace = _Pace(options.rate)
    refused: DeviceError | None = None  # why the last setting tried could not be opened
    opened = False
    terminal = not quiet and _is_terminal()
    for line in _lines(connection, options.settings):
        waiting = [u for u in units if u not in results]
        if not waiting:
            break
        if not quiet:
            _say(f"asking {len(waiting)} unit{'s' * (len(waiting) != 1)} on {line}")
        session = Link(line)
        session.client.set_max_no_responses(len(waiting) + 3)  # silent units are the rule here
        session.asking_units(waiting)
        serial = None if line.serial is None else {"baud": line.baud, "parity": line.parity}
        try:
            session.connect()
        except DeviceError as exc:
            if line.serial is None or len(options.settings) == 1:
                raise
            _say(f"warning: {exc.diagnostics[0].message}: these settings are skipped")
            refused = exc
            continue
        opened = True
        bar = _Progress(terminal, line, len(waiting))
        try:
            for unit in waiting:
                found = UnitProbe(unit, serial, tables=tuple(options.tables), span=(options.low, options.high))
                bar.begin(unit)
                try:
                    there = _probe_one(session, found, options, pace, bar)
                finally:
                    bar.done += 1
                if there:
                    results[unit] = found
                if not quiet and (there or not terminal):  # on a terminal the bar says who did not answer
                    _say(_summary(found, there), bar)
        except _Lost as lost:  # what was found is kept: said, and printed
            if lost.found is not None:
                results[lost.found.unit] = lost.found
                if not quiet:
                    _say(_summary(lost.found, True), bar)
            _say(f"warning: {lost.exc.diagnostics[0].message}; the units after it are not asked", bar)
        finally:
            bar.close()
            session.close()
    if refused is not None and not opened:  # no setting could be opened: that is the error
        raise refused
    if not results:
        hint = connection.silence_hint()
        raise DeviceError(
            f"{connection}: no unit answered (asked {unit_list(units) or 'none'})" + (f"; {hint}" if hint else "")
        )
    return [results[u] for u in sorted(results)]


def _is_terminal() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def _summary(found: UnitProbe, there: bool) -> str:
    if not there:
        return f"unit {found.unit}: no answer"
    total = sum(len(r) for r in found.ranges.values())
    return f"unit {found.unit}: {total} defined range{'s' * (total != 1)}, {found.requests} requests"


class _Lost(Exception):
    """The line was lost (LineLost) while a unit was probed: `found` is what it found if it answered."""

    def __init__(self, exc: LineLost, found: UnitProbe | None) -> None:
        super().__init__(str(exc))
        self.exc, self.found = exc, found


def _probe_one(session: Link, found: UnitProbe, options: ProbeOptions, pace: _Pace, bar: _Progress) -> bool:
    """Whether the unit answered; what it defines in `found`. _Lost where the line was lost."""
    prober = _Prober(session, found.unit, options.max_requests, pace, found, bar)
    try:
        prober.ask(options.tables[0], options.low, 1)  # is anybody there? (one request)
    except LineLost as exc:
        raise _Lost(exc, None) from None
    if prober.line.absent or not prober.line.answered:
        return False
    try:
        _probe_unit(prober, options.tables, options.low, options.high)
    except LineLost as exc:
        found.notes += guesses(found.ranges, found.values, options.low)
        raise _Lost(exc, found) from None
    found.notes += guesses(found.ranges, found.values, options.low)
    return True


_SPAN = re.compile(r"\[\n *(\d+),\n *(\d+)\n *\]")  # a JSON string holds no line break: only arrays match


def render(results: list[UnitProbe], fmt: str) -> str:
    """`json`: SPEC 14's list, one object per unit; `table`: per unit a line, then each table's ranges with
    their counts, then its notes and guesses."""
    if fmt == "json":
        text = json.dumps([r.json() for r in results], indent=2)
        return _SPAN.sub(r"[\1, \2]", text) + "\n"  # a span [FIRST, LAST] on one line
    out: list[str] = []
    for r in results:
        where = f" at {r.serial['baud']} baud, parity {r.serial['parity']}" if r.serial else ""
        out.append(f"unit {r.unit}{where}: {r.requests} requests")
        for table in REGISTER_TYPES:
            spans = r.ranges[table]
            shown = ", ".join(f"{_span(a, b)} ({b - a + 1})" for a, b in spans) or "none"
            out.append(f"  {table:<9} {shown if table in r.tables else 'not probed'}")
        out += [f"  {note}" for note in r.notes]
    return "\n".join(out) + "\n"
