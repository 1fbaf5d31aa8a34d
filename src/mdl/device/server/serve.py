"""`mdl sim DEVICE --as sunspec` and `mdl serve DEVICE --from CONNECTION --as sunspec` (SPEC 13): the
device's roles served as SunSpec models (mdl.device.sunspec.gateway) by the sim's server (mdl.device.server.sim).

`mdl sim --as sunspec` computes the points from the simulated device's registers at every read. `mdl
serve` polls the real device every `interval` seconds with a mdl.device.runtime.Session (the read plan
of `mdl read`) on a thread of its own and serves the last poll; while the device does not answer, every
point is "not implemented", never the last numbers it gave. Values are served for at most `interval` (or
the last poll's own time, where polls take longer) plus one request's time (`--timeout`) after the poll
that read them ended: a device that goes silent is "not implemented" from then on, not only once its poll
has waited out every retry. Each change (the device
stops or starts answering) is said once on stderr.
"""

from __future__ import annotations

import asyncio
import logging
import sys
import threading
import time
from pathlib import Path
from typing import TextIO

from mdl.device.connection import Connection, parse_connection
from mdl.device.evaluate import Evaluator
from mdl.device.link import ModbusExceptionError
from mdl.device.runtime import Session
from mdl.device.server import sim as simulator
from mdl.device.sunspec.gateway import FacadeRegisters, RoleValues, Source, choose, role_values
from mdl.diagnostics import Diagnostic, MdlError, error, one_line
from mdl.model import Value
from mdl.profiles.fit import Fit
from mdl.resolver import ResolvedDevice

FROM_HELP = (
    "The device to poll, as a URL: HOST[:PORT] or tcp://HOST[:PORT] (Modbus TCP, port 502), rtu+tcp://HOST:PORT "
    "(RTU frames over TCP), or rtu://DEVICE[?baud=19200&parity=N&stopbits=1&bytesize=8] (Modbus RTU); "
    "?timeout=S&retries=N and #UNIT as in mdl read's targets."
)


def parse_from(text: str, timeout: float, retries: int) -> tuple[Connection, int | None]:
    """`--from` as FROM_HELP says it (mdl.device.fleet.run's one grammar of connection URLs): the connection
    and the unit it names (None: not named); MdlError naming what is wrong."""
    try:
        return parse_connection(text.strip(), timeout=timeout, retries=retries)
    except ValueError as exc:
        raise error(f"--from {text!r}: {exc}") from None


def sim_source(resolved: ResolvedDevice, registers: simulator.Registers, fitted: Fit) -> Source:
    """What gives the roles' values from the simulated registers at the moment of each read (a register a
    scenario leaves without a value, or a value that cannot be computed: None)."""
    names = [b.function.name for b in fitted.bound.values()]
    evaluator = Evaluator(resolved)

    def raw(table: str, address: int) -> int | None:
        return None if (table, address) in registers.missing else registers.tables[table].get(address)

    def now() -> RoleValues:
        try:
            values = evaluator.values(names, raw)
        except (ValueError, ArithmeticError):
            return dict.fromkeys(fitted.bound)
        return role_values(fitted, values)

    return now


class Poller:
    """Polls the device on a thread of its own; `latest` is the last poll's role values (None while the
    device does not answer, or before it first did) and when that poll ended; `current()` is what may be
    served now."""

    def __init__(self, resolved: ResolvedDevice, fitted: Fit, connection: Connection, unit: int, interval: float):
        self.session = Session(resolved, connection, unit)
        self.fitted, self.interval = fitted, interval
        self.timeout = connection.timeout
        self.functions = [b.function.fn for b in fitted.bound.values()]
        # the last poll's values, when it ended and how long it took: one tuple, read whole by the server
        self.latest: tuple[RoleValues | None, float, float] = (None, 0.0, 0.0)
        self.answering: bool | None = None  # None: not polled yet
        self.refused: set[str] = set()  # functions the device refuses even alone (said once)
        self.polled = threading.Event()  # set once the first poll has ended
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="mdl serve poller", daemon=True)
        # what pymodbus logs while polling (a refused connection) is said once as the poll's failure
        logging.getLogger("pymodbus.logging").addFilter(self._not_polling)

    def _not_polling(self, record: logging.LogRecord) -> bool:
        return record.thread != self.thread.ident

    def _each(self) -> dict[str, Value]:
        """The functions read one by one after the device refused a register even alone: a refused one
        has no value (its role served as 'not implemented'), the others are served; said once each."""
        values: dict[str, Value] = {}
        for fn in self.functions:
            try:
                values.update(self.session.read([fn]))
            except ModbusExceptionError as exc:
                values[fn.name] = None
                if fn.name not in self.refused:
                    self.refused.add(fn.name)
                    _say(f"the device refuses {fn.name} ({exc.diagnostics[0].message}): served as 'not implemented'")
        return values

    def poll_once(self) -> None:
        started = time.monotonic()
        try:
            self.session.connect()
            try:
                values = self.session.read(self.functions)
            except ModbusExceptionError:
                values = self._each()
        except MdlError as exc:
            if not isinstance(exc, ModbusExceptionError):
                self.session.close()  # the next poll connects again
            self.latest = (None, time.monotonic(), 0.0)
            if self.answering is not False:
                reason = "; ".join(d.message for d in exc.diagnostics)
                _say(f"the device does not answer ({reason}): serving 'not implemented' until it does")
            self.answering = False
            return
        ended = time.monotonic()
        self.latest = (role_values(self.fitted, values), ended, ended - started)
        if self.answering is False:
            _say("the device answers again: serving its values")
        self.answering = True

    def current(self) -> RoleValues | None:
        """The last poll's values while they are fresh: until the next poll should have ended (the interval,
        or the last poll's own time where a poll takes longer: a slow line is no silent device) plus one
        request's time (`--timeout`); None after, while the next poll still waits for a device that may
        have gone silent."""
        values, ended, took = self.latest
        return None if time.monotonic() - ended > max(self.interval, took) + self.timeout else values

    def _run(self) -> None:
        try:
            next_start = time.monotonic() + self.interval
            self.poll_once()
            self.polled.set()
            while not self.stop.wait(max(0.0, next_start - time.monotonic())):
                next_start = time.monotonic() + self.interval
                self.poll_once()
        except Exception as exc:  # a fault of mdl's own: polling ends, and no value is served as if current
            self.latest = (None, time.monotonic(), 0.0)
            _say(f"polling stopped ({type(exc).__name__}: {exc}): serving 'not implemented' from now on")
        finally:
            self.polled.set()
            self.session.close()


def _say(message: str) -> None:
    sys.stderr.write(f"mdl serve: {one_line(message)}\n")
    sys.stderr.flush()


class _Renamed:
    """The sim's ready lines as `mdl serve`'s own (`mdl serve: serving ...`)."""

    def __init__(self, out: TextIO) -> None:
        self.out = out

    def write(self, text: str) -> int:
        return self.out.write(text.replace("mdl sim: ", "mdl serve: "))

    def flush(self) -> None:
        self.out.flush()


def facade_notes(facade: FacadeRegisters, path: Path, extra: list[Diagnostic]) -> None:
    """What the gateway chose (profile, model) and what it had to cut, on stderr."""
    where = str(path)
    notes = [*extra, Diagnostic(where, None, None, f"served as SunSpec models 1 and {facade.model}", "note")]
    notes += [Diagnostic(where, None, None, text, "note") for text in facade.identity_notes]
    for diag in notes:
        sys.stderr.write(f"{diag}\n")
    sys.stderr.flush()


def serve_facade(facade: FacadeRegisters, unit: int, connection: Connection, command: str) -> None:
    """Serve the chain at `unit` until SIGINT/SIGTERM, as `mdl sim` serves a device."""
    out: TextIO = sys.stdout if command == "sim" else _Renamed(sys.stdout)  # type: ignore[assignment]
    if command == "sim":
        simulator.run({unit: facade}, connection)
        return
    where = connection.serving_at(connection.port)
    try:
        asyncio.run(simulator.serve({unit: facade}, connection, out))
    except RuntimeError as exc:
        raise error(f"cannot serve on {where}: {exc}") from None
    except OSError as exc:
        raise error(f"cannot serve on {where}: {exc.strerror or exc}") from None


def run_sim(
    path: Path,
    resolved: ResolvedDevice,
    registers: simulator.Registers,
    profile: str | None,
    unit: int,
    connection: Connection,
) -> None:
    """`mdl sim DEVICE --as sunspec`: the simulated device's registers served as its profile's SunSpec models."""
    fitted, notes = choose(resolved, profile, path)
    facade = FacadeRegisters(fitted, sim_source(resolved, registers, fitted), resolved.device, unit)
    facade_notes(facade, path, notes)
    serve_facade(facade, unit, connection, "sim")


def run_serve(
    path: Path,
    resolved: ResolvedDevice,
    profile: str | None,
    polled: tuple[Connection, int, float],
    unit: int,
    connection: Connection,
) -> None:
    """`mdl serve DEVICE --from CONNECTION --as sunspec`: poll the device, serve the last poll."""
    fitted, notes = choose(resolved, profile, path)
    source, from_unit, interval = polled
    poller = Poller(resolved, fitted, source, from_unit, interval)
    facade = FacadeRegisters(fitted, poller.current, resolved.device, unit)
    facade_notes(facade, path, notes)
    poller.thread.start()
    poller.polled.wait()  # the first poll before serving: a client's first read has the device's values
    try:
        serve_facade(facade, unit, connection, "serve")
    finally:
        poller.stop.set()
        poller.thread.join(timeout=1.0)  # a poll waiting for a silent device ends with its timeout, unwaited
