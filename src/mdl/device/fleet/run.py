"""Polling several devices from one process (SPEC sections 9 and 11, docs/fleet.md): `mdl read
FILE@CONNECTION[#UNIT]...`, and `mdl read ... --interval S --publish URL`.

A target is a description and where its device is: `meter.xml@tcp://10.0.0.5:502#3`,
`meter.xml@rtu+tcp://10.0.0.6:4001#2` (RTU frames over TCP), `meter.xml@rtu:///dev/ttyUSB0?baud=9600&parity=E#2`.
Each target is polled by its own asyncio task on one event loop, on its own schedule (an inventory's
devices each at their own interval, mdl.device.fleet.inventory): its first poll STAGGER s after the one
before it (wrapped into its interval: hundreds of devices never connect and poll at once), then one every
interval from when the last was due (next_start), through a pymodbus asyncio client: a device that does
not answer waits out its own timeout and delays no other. The devices of one description share its read
plan and compiled decoder (_Fleet._session). Devices on one serial line, or behind one RTU-over-TCP
converter, share the line's client and take turns, as the bus makes them, the line held only while one
polls. A device that fails BACK_OFF_AFTER polls in a row is backed off (after_poll: 2, 4, 8 ... intervals,
at most MAX_BACK_OFF s), said once going and once coming back. Every poll goes to the sinks: the printer
(records on stdout, naming their device when there are several) and the publishers (mdl.device.fleet.mqtt,
mdl.device.fleet.prometheus).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TextIO, runtime_checkable

from pymodbus.exceptions import ModbusException

from mdl.device import output
from mdl.device.connection import _AT, TARGET_FORMS, Connection, parse_connection
from mdl.device.fleet.poll import STOP_SIGNALS, _refuse_time_clash, _silence
from mdl.device.frames import Wire
from mdl.device.link import ModbusExceptionError
from mdl.device.runtime import Session
from mdl.diagnostics import EXIT_DEVICE, MdlError, error
from mdl.fileio import input_path
from mdl.model import Function, Value
from mdl.model.names import unique_identifiers

if TYPE_CHECKING:
    from pymodbus.client import ModbusBaseClient
    from pymodbus.pdu import ModbusPDU

    from mdl.device.fleet.mqtt import Classify
    from mdl.plan import Request
    from mdl.resolver import ResolvedDevice, ResolvedFunction


@dataclass(frozen=True)
class Target:
    """A device to poll: its description file, where it is, and its unit id; `text` as it was given."""

    text: str
    file: Path
    connection: Connection
    unit: int = 1


def parse_target(text: str) -> Target:
    """`FILE@CONNECTION[#UNIT]` -> a Target; ValueError saying what is wrong."""
    found = _AT.search(text)
    if found is None:
        raise ValueError(f"not a target: write {TARGET_FORMS}")
    file_text, url = text[: found.start()], text[found.end() :]
    if not file_text:
        raise ValueError("no FILE before '@'")
    connection, unit = parse_connection(url)
    return Target(text, input_path(file_text), connection, 1 if unit is None else unit)


def device_ids(stems: Sequence[str], units: Sequence[int]) -> tuple[list[str], list[str]]:
    """A name for each polled device (records, MQTT topics, metric labels): its stem (SPEC 3), with
    `_u<unit>` where stems repeat, made unique (_2, _3, ...) where they still do; and the notes saying so."""
    repeated = {s for s in stems if list(stems).count(s) > 1}
    wanted = [f"{s}_u{u}" if s in repeated else s for s, u in zip(stems, units, strict=True)]
    ids = unique_identifiers(wanted)
    notes = [
        f"device {i + 1} ({stem} unit {unit}) is named {ident}: several targets are {stem}"
        for i, (stem, unit, ident) in enumerate(zip(stems, units, ids, strict=True))
        if ident != stem
    ]
    return ids, notes


def kind_of(f: ResolvedFunction) -> str:
    """What a function's value is to a publisher: `bool`, `number` (an enumeration's too: its label is
    text in records and payloads) or `text` (strings, bitsets)."""
    vt = f.codec.value_type
    kind = vt.expr_type if vt.kind == "expr" else vt.kind
    if kind == "bool":
        return "bool"
    return "number" if kind in ("int", "float", "long", "double") else "text"


@dataclass
class Polled:
    """A target with what polling it takes: its resolved device, the functions read and its name."""

    target: Target
    resolved: ResolvedDevice
    functions: list[Function]
    ident: str
    interval: float | None = None  # its own seconds between polls (an inventory's); None: the run's --interval
    backing_off: bool = False  # failed BACK_OFF_AFTER polls in a row and has not read since (set by the poller)


class Sink(Protocol):
    """Where polls go: records printed, or published."""

    def started(self, polled: list[Polled]) -> None: ...
    def record(self, polled: Polled, values: dict[str, Value], when: datetime) -> None: ...
    def failed(self, polled: Polled, when: datetime, exc: MdlError) -> None: ...
    def close(self) -> None: ...


@runtime_checkable
class Teller(Protocol):
    """A sink that says when a device starts backing off and when it answers again (the printer, on stderr)."""

    def told(self, polled: Polled, when: datetime, text: str) -> None: ...


@runtime_checkable
class Stoppable(Protocol):
    """A sink that can end the run (a broker that refuses mdl): it calls `abort` from any thread."""

    def stop_with(self, abort: Callable[[MdlError], None]) -> None: ...


class Printer:
    """Records on stdout, as `mdl read --interval` prints them (one device), or naming their device
    (several: output.device_record); failed polls on stderr."""

    def __init__(self, fmt: str, several: bool, out: TextIO, err: TextIO) -> None:
        self.fmt, self.several, self.out, self.err = fmt, several, out, err
        self.gone = False  # the reader of stdout went away: records are no longer printed

    def started(self, polled: list[Polled]) -> None:
        if not self.several:
            _refuse_time_clash(polled[0].functions, self.fmt)
        head = (
            output.device_record_header(self.fmt)
            if self.several
            else output.record_header(polled[0].functions, self.fmt)
        )
        self._emit(self.out, head)

    def record(self, polled: Polled, values: dict[str, Value], when: datetime) -> None:
        name = polled.resolved.device.name
        if self.several:
            self._emit(self.out, output.device_record(polled.ident, polled.functions, values, self.fmt, when, name))
        else:
            self._emit(self.out, output.record(polled.functions, values, self.fmt, when, name))

    def failed(self, polled: Polled, when: datetime, exc: MdlError) -> None:
        if polled.backing_off:  # said once when it went (told); its failed polls are not printed again
            return
        who = f"{polled.ident}: " if self.several else ""
        for diag in exc.diagnostics:
            self._emit(self.err, f"{output.iso_time(when)}: {who}{diag}\n")

    def told(self, polled: Polled, when: datetime, text: str) -> None:
        who = f"{polled.ident}: " if self.several else ""
        self._emit(self.err, f"{output.iso_time(when)}: {who}{text}\n")

    def close(self) -> None:
        pass

    def _emit(self, stream: TextIO, text: str) -> None:
        if not text or (self.gone and stream is self.out):
            return
        try:
            stream.write(text)
            stream.flush()
        except BrokenPipeError:  # `| head`: stop printing; publishing goes on
            self.gone = True
            _silence(stream)
        except OSError as exc:  # a full disk: the run ends with the reason, never a traceback or a clean exit
            raise error(f"cannot write the records: {exc.strerror or exc}") from None


class _Line:
    """An asyncio client and the turns taken on it: a TCP device's own, or a bus's, shared."""

    def __init__(self, connection: Connection) -> None:
        self.wire = Wire(connection.rtu)
        self.client: ModbusBaseClient = connection.async_client(self.wire.trace)
        self.lock = asyncio.Lock()


def line_settings(conn: Connection) -> tuple[object, ...]:
    """What a shared line has one of: its serial settings and its timing."""
    return (conn.baud, conn.parity, conn.stopbits, conn.bytesize, conn.timeout, conn.retries)


def shared_line(conn: Connection) -> tuple[str, ...] | None:
    """The line a connection shares with others: a serial device, or an RTU-over-TCP converter's host and
    port; None for a Modbus TCP device, which has a connection of its own."""
    if conn.serial is not None:
        return ("serial", conn.serial)
    return ("rtu", conn.host, str(conn.port)) if conn.rtu else None


def _line_key(target: Target, index: int) -> object:
    """Targets on one serial line or one RTU-over-TCP converter share a line; a Modbus TCP device has its own."""
    line = shared_line(target.connection)
    return index if line is None else line


# A device that fails BACK_OFF_AFTER polls in a row is backed off (SPEC 15): polled again after 2, 4, 8 ...
# times its interval, at most MAX_BACK_OFF seconds apart (or its interval, where that is longer).
BACK_OFF_AFTER = 3
MAX_BACK_OFF = 600.0


@dataclass(frozen=True)
class Outcome:
    """What one poll's end means for its device: its failed polls in a row since, the seconds from this
    poll's start to the next, and what to say (`backing off`, `answering again`, or nothing)."""

    failures: int
    delay: float
    said: str | None = None


def after_poll(interval: float, failures: int, ok: bool) -> Outcome:
    """The schedule of a device after a poll (`failures`: its failed polls in a row before this one; `ok`:
    this one read). A pure function: the poller's whole back-off is here."""
    if ok:
        return Outcome(0, interval, "answering again" if failures >= BACK_OFF_AFTER else None)
    failures += 1
    return Outcome(failures, retry_delay(interval, failures), "backing off" if failures == BACK_OFF_AFTER else None)


def retry_delay(interval: float, failures: int) -> float:
    """Seconds from the start of a poll to the next after `failures` failed polls in a row: the interval,
    then from the BACK_OFF_AFTER-th failure 2, 4, 8 ... intervals, at most MAX_BACK_OFF (never less than
    the interval)."""
    if failures < BACK_OFF_AFTER:
        return interval
    doubling = min(failures - BACK_OFF_AFTER + 1, 32)  # 2**32 intervals outgrow any cap: no overflow
    return max(interval, min(interval * float(2**doubling), MAX_BACK_OFF))


# Devices start polling STAGGER seconds apart, wrapped into each one's interval (first_start): hundreds of
# devices never connect and poll all at once, and their polls stay spread over every interval after.
STAGGER = 0.01


def first_start(index: int, interval: float, count: int | None) -> float:
    """Seconds from the start of the run to the first poll of the `index`-th device: index x STAGGER,
    wrapped into its interval (a few devices start within milliseconds; thousands spread evenly over their
    interval); 0 for one read of each (`count` 1), which nothing follows."""
    return 0.0 if count == 1 else (index * STAGGER) % interval


def next_start(due: float, delay: float, now: float) -> float:
    """When a device's next poll starts: `delay` after the one that just ended was due, not after it began
    (a poll that began late, waiting for the event loop or its line, shifts none after it), or `now` if that
    has passed (a poll slower than its interval is followed at once, never by a burst to catch up)."""
    return max(due + delay, now)


async def _fetch(session: Session, client: ModbusBaseClient, req: Request) -> list[int]:
    """One request on the asyncio client, judged as Session.read_request judges its replies."""
    what = session.reading(req)
    method: Callable[..., asyncio.Future[ModbusPDU]] = getattr(client, session._methods[req.table].__name__)
    session.wire.clear()
    try:
        result = await method(req.start, count=req.count, device_id=session.unit)
    except (ModbusException, OSError) as exc:
        raise session.failed(what, exc) from None
    except asyncio.TimeoutError:  # not an OSError before Python 3.11
        raise session.failed(what, TimeoutError()) from None
    return session.unpacked(req, session.checked(what, result))


async def _read(session: Session, line: _Line, functions: list[Function], turn: list[datetime]) -> dict[str, Value]:
    """Session.read on the line's asyncio client: the same steps (runtime.drive), awaited. The time its
    turn on the line came is appended to `turn` (the poll's time, a failed poll's too)."""
    async with line.lock:
        turn.append(datetime.now(timezone.utc))
        try:
            if not line.client.connected and not await line.client.connect():
                raise session.connect_error()
            steps = session.read_steps(functions)
            try:
                req = next(steps)
                while True:
                    try:
                        regs = await _fetch(session, line.client, req)
                    except ModbusExceptionError as exc:
                        req = steps.throw(exc)
                    else:
                        req = steps.send(regs)
            except StopIteration as done:
                values: dict[str, Value] = done.value
                return values
        except MdlError as exc:
            if not isinstance(exc, ModbusExceptionError):
                line.client.close()  # the next poll on this line connects again (in turn: a bus's others wait)
            raise


async def _cancelled(tasks: list[asyncio.Future[Any]]) -> None:
    """Cancel `tasks` and wait until every one has ended. A cancellation can be lost: in Python before 3.12,
    asyncio.wait_for (pymodbus's connect and requests) returns its awaitable's result, or raises its error,
    when that comes at the moment it is cancelled; the task then polls on (a device that refuses connections,
    under load: a stop that never ended). Each task still running is cancelled again until it ends; the
    polling loop also ends at its next turn once the stop is set."""
    pending = set(tasks)
    while pending:
        for task in pending:
            task.cancel()
        _, pending = await asyncio.wait(pending, timeout=CANCEL_AGAIN)
    for task in tasks:  # retrieved, as gather would: the run has said what it had to of each
        if not task.cancelled():
            task.exception()


CANCEL_AGAIN = 0.5  # s: a task still running this long after its cancellation is cancelled again


class _Fleet:
    """The polling tasks of one run, their last exit statuses, and the sinks they feed."""

    def __init__(self, polled: list[Polled], sinks: list[Sink], interval: float, count: int | None) -> None:
        self.polled, self.sinks, self.interval, self.count = polled, sinks, interval, count
        self.status = [0] * len(polled)
        self.stop = asyncio.Event()
        self.sessions: dict[int, Session] = {}  # the first session of each description (one read plan for all)
        lines: dict[object, tuple[_Line, Polled]] = {}
        self.lines = []
        for i, p in enumerate(polled):
            key = _line_key(p.target, i)
            if key not in lines:
                lines[key] = (_Line(p.target.connection), p)
            line, first = lines[key]
            if line_settings(p.target.connection) != line_settings(first.target.connection):
                raise error(
                    f"{p.target.text} and {first.target.text} share a line but give it different settings "
                    "(baud, parity, stop bits, byte size, timeout, retries): a line has one; give both the same"
                )
            self.lines.append(line)

    async def run(self) -> int:
        loop = asyncio.get_running_loop()
        for sig in STOP_SIGNALS:
            loop.add_signal_handler(sig, self.stop.set)
        aborted: list[MdlError] = []

        def abort_here(exc: MdlError) -> None:
            aborted.append(exc)
            self.stop.set()

        def abort(exc: MdlError) -> None:  # from a sink's thread
            try:
                loop.call_soon_threadsafe(abort_here, exc)
            except RuntimeError:  # the loop is closed: the run is over, the sink's close says it
                pass

        for sink in self.sinks:
            if isinstance(sink, Stoppable):
                sink.stop_with(abort)
        tasks = [asyncio.create_task(self._poll(i)) for i in range(len(self.polled))]
        stopping: asyncio.Future[Any] = asyncio.ensure_future(self.stop.wait())
        polling: asyncio.Future[Any] = asyncio.ensure_future(asyncio.gather(*tasks))
        failure: BaseException | None = None
        try:
            await asyncio.wait([polling, stopping], return_when=asyncio.FIRST_COMPLETED)
            if polling.done() and not polling.cancelled() and polling.exception() is not None:
                failure = polling.exception()  # a task that failed ends the run, said, never as a clean exit
        finally:
            await _cancelled([*tasks, stopping, polling])
            for sig in STOP_SIGNALS:
                loop.remove_signal_handler(sig)
            for line in {id(line): line for line in self.lines}.values():
                line.client.close()
        if failure is not None:
            raise failure
        if aborted:
            raise aborted[0]
        return max(self.status, default=0)

    async def _poll(self, i: int) -> None:
        """Poll one target on its own schedule (its interval, backed off while it fails: after_poll) until
        --count or a stop. The line is held only while it polls: a device backed off delays no other."""
        p, line = self.polled[i], self.lines[i]
        interval = self.interval if p.interval is None else p.interval
        session = self._session(p)
        session.wire = line.wire  # the line's client traces into the line's wire
        loop = asyncio.get_running_loop()
        due, polls, failures = loop.time() + first_start(i, interval, self.count), 0, 0
        tellers = [sink for sink in self.sinks if isinstance(sink, Teller)]
        while (self.count is None or polls < self.count) and not self.stop.is_set():
            wait = due - loop.time()
            if wait > 0:  # a stop cancels the task (run)
                await asyncio.sleep(wait)
            turn: list[datetime] = []
            try:
                values = await _read(session, line, p.functions, turn)
            except MdlError as exc:
                when = turn[0] if turn else datetime.now(timezone.utc)
                outcome = after_poll(interval, failures, ok=False)
                self.status[i] = EXIT_DEVICE
                for sink in self.sinks:
                    sink.failed(p, when, exc)
                if outcome.said is not None:
                    reason = exc.diagnostics[0].message if exc.diagnostics else str(exc)
                    for teller in tellers:
                        teller.told(p, when, f"{outcome.said}: {reason} ({_BACK_OFF_NOTE})")
                    p.backing_off = True
            else:
                outcome = after_poll(interval, failures, ok=True)
                self.status[i] = 0
                if outcome.said is not None:
                    p.backing_off = False
                    for teller in tellers:
                        teller.told(p, turn[0], outcome.said)
                for sink in self.sinks:
                    sink.record(p, values, turn[0])
            failures = outcome.failures
            due = next_start(due, outcome.delay, loop.time())
            polls += 1

    def _session(self, p: Polled) -> Session:
        """A session with the device; the devices of one description share its read plan and decoder (made
        and compiled once, not once per device: a site of hundreds of one meter compiles one)."""
        session = Session(p.resolved, p.target.connection, p.target.unit)
        first = self.sessions.setdefault(id(p.resolved), session)
        if first is not session:  # the plan is the description's; what a device refused stays its own
            session._evaluator, session._plans = first.evaluator, first._plans
        return session


_BACK_OFF_NOTE = (
    f"{BACK_OFF_AFTER} failed polls in a row: tried again after 2, 4, 8 ... intervals, "
    f"{MAX_BACK_OFF / 60:g} minutes apart at most"
)


def poll_fleet(polled: list[Polled], sinks: list[Sink], interval: float, count: int | None) -> int:
    """Poll every target until --count polls each, or SIGINT/SIGTERM; 3 if any target's last poll failed."""
    started: list[Sink] = []
    try:
        for sink in sinks:
            sink.started(polled)
            started.append(sink)

        async def main() -> int:
            return await _Fleet(polled, sinks, interval, count).run()

        return asyncio.run(main())
    finally:
        closing: list[MdlError] = []
        for sink in reversed(started):
            try:
                sink.close()
            except MdlError as exc:  # every sink is closed; the first failure is the run's
                closing.append(exc)
        if closing:
            raise closing[0]


def redacted(url: str) -> str:
    """A URL as messages show it: a password in it as `***` (`mqtt://user:***@host/p`), in a malformed URL
    too (a password holding '/' or '@': the last '@' ends the user's part)."""
    scheme, sep, rest = url.partition("://")
    userinfo, at, hostpart = rest.rpartition("@")
    user, colon, _ = userinfo.partition(":")
    return f"{scheme}{sep}{user}:***{at}{hostpart}" if at and colon else url


def publisher(url: str, err: TextIO, classify: Classify | None = None, mqtt_ca: Path | None = None) -> Sink:
    """The publisher a --publish URL names (mqtt://, mqtts://, prometheus://); ValueError saying what is
    wrong, never quoting a password. `classify`: Home Assistant's classes of a unit
    (mdl.exports.ha_units.ha_unit), for MQTT discovery; `mqtt_ca`: the CA certificates of mqtts://
    (the system's without it), MdlError (exit 1) if the file holds none."""
    scheme = url.partition("://")[0].lower()
    if scheme in ("mqtt", "mqtts"):
        from mdl.device.fleet import mqtt as publish_mqtt

        parsed = publish_mqtt.parse_url(url)
        tls = publish_mqtt.tls_context(mqtt_ca) if parsed.tls else None
        return publish_mqtt.MqttPublisher(parsed, err, classify, tls)
    if scheme == "prometheus":
        from mdl.device.fleet import prometheus as publish_prometheus

        return publish_prometheus.PrometheusPublisher(publish_prometheus.parse_url(url), err)
    raise ValueError("publish to mqtt[s]://HOST[:PORT]/PREFIX or prometheus://[HOST]:PORT")
