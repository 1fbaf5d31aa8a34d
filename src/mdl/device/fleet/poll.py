"""`mdl read --interval S [--count N]` (SPEC section 9): read with the read plan every S seconds and print
one record per poll, as a logger does.

Polls start every S seconds, measured from the start of one poll to the start of the next; a poll
that takes longer than S is followed at once by the next (no burst of polls to catch up). A poll
that fails prints the reason to stderr, closes the connection unless the device answered (a Modbus
exception), and polling goes on: the next poll connects again. SIGINT or SIGTERM ends polling
between records, never inside one: every record printed is whole and flushed. The exit status
follows the last poll that ended: 0 if it read, 3 (EXIT_DEVICE) if it failed.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime, timezone
from types import FrameType
from typing import TextIO

from mdl.device import output
from mdl.device.link import ModbusExceptionError
from mdl.device.runtime import Session
from mdl.diagnostics import EXIT_DEVICE, MdlError, error
from mdl.model import Function

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Stop(BaseException):
    """A stop signal arrived: end polling. A BaseException, as KeyboardInterrupt is: no `except Exception`
    in a library the poll calls swallows it."""


class Stopper:
    """Turns SIGINT/SIGTERM into Stop, except while a record is written: then it only asks to stop
    (`requested`), and polling ends once the record is out."""

    def __init__(self) -> None:
        self.requested = False
        self.holding = False
        self.wake = threading.Event()  # set by a signal: cuts the wait for the next poll short

    def handle(self, signum: int, frame: FrameType | None) -> None:
        self.requested = True
        self.wake.set()
        if not self.holding:
            raise Stop

    @contextmanager
    def installed(self) -> Iterator[None]:
        previous = {sig: signal.signal(sig, self.handle) for sig in STOP_SIGNALS}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)

    @contextmanager
    def held(self) -> Iterator[None]:
        """Within the block a signal only asks to stop."""
        self.holding = True
        try:
            yield
        finally:
            self.holding = False

    def sleep_until(self, deadline: float) -> None:
        self.wake.wait(max(0.0, deadline - time.monotonic()))
        if self.requested:
            raise Stop


def _refuse_time_clash(functions: list[Function], fmt: str) -> None:
    """A function named like the record's time column would hide it (json, csv): refused before polling."""
    if fmt in ("json", "csv") and any(fn.name == output.TIME_KEY for fn in functions):
        raise error(
            f"function '{output.TIME_KEY}' has the name of the poll record's time {fmt} "
            f"{'key' if fmt == 'json' else 'column'}; leave it out, or poll with --format table or senml"
        )


def poll(
    session: Session,
    functions: list[Function],
    fmt: str,
    interval: float,
    count: int | None,
    out: TextIO | None = None,
    err: TextIO | None = None,
) -> int:
    """Poll until `count` polls have ended (None: until a stop signal); the exit status of the last poll.
    Records go to `out`, failures to `err`: by default the sys.stdout and sys.stderr of the moment of the
    call (not of the import: a test runner that captures output replaces them)."""
    out = sys.stdout if out is None else out
    err = sys.stderr if err is None else err
    _refuse_time_clash(functions, fmt)
    stopper = Stopper()
    status, polls = 0, 0
    next_start = time.monotonic()
    with stopper.installed():
        try:
            with stopper.held():
                _emit(out, output.record_header(functions, fmt))
            while (count is None or polls < count) and not stopper.requested:
                if polls:
                    stopper.sleep_until(next_start)
                next_start = time.monotonic() + interval
                status = _poll_once(session, functions, fmt, stopper, out, err)
                polls += 1
        except Stop:
            pass
        except BrokenPipeError:  # the reader of stdout went away (`| head`): nothing more to say
            _silence(out)
        finally:
            session.close()
    return status


def _poll_once(
    session: Session, functions: list[Function], fmt: str, stopper: Stopper, out: TextIO, err: TextIO
) -> int:
    """One poll: its record on `out`, or the reason it failed on `err`; the poll's exit status."""
    when = datetime.now(timezone.utc)
    try:
        session.connect()
        values = session.read(functions)
    except MdlError as exc:
        if not isinstance(exc, ModbusExceptionError):
            session.close()  # the next poll connects again
        with stopper.held():
            for diag in exc.diagnostics:
                _emit(err, f"{output.iso_time(when)}: {diag}\n")
        return EXIT_DEVICE
    with stopper.held():
        _emit(out, output.record(functions, values, fmt, when, session.device.name))
    return 0


def _emit(stream: TextIO, text: str) -> None:
    if not text:
        return
    try:
        stream.write(text)
        stream.flush()
    except BrokenPipeError:
        raise
    except OSError as exc:  # a full disk: the reason, exit 1, never a traceback
        _silence(stream)
        raise error(f"cannot write the records: {exc.strerror or exc}") from None


def _silence(out: TextIO) -> None:
    """Point `out` at /dev/null, so that the interpreter's last flush of it does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:
        return
    try:
        os.dup2(devnull, out.fileno())
    except (OSError, ValueError):  # not a file (an in-memory stream): nothing to flush at exit
        pass
    finally:
        os.close(devnull)
