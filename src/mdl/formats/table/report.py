"""What `mdl csv2xml` tells the user on stderr: warnings as they happen (a row it cannot read, with
its line), notes on every guess it made (with the INI key that overrides it) and a summary line at
the end, and a progress bar on a terminal while a long table is matched."""

from __future__ import annotations

import re
import sys
import time
from typing import TextIO

from mdl.diagnostics import Collector, Diagnostic

_LINE = re.compile(r"\bline (\d+)\b")
_LINES = re.compile(r"\blines (\d+) and (\d+)\b")
_ROW = re.compile(r"`row = (\d+)`")


def _at(places: dict[int, str], line: str) -> str:
    return places.get(int(line), f"line {line}")


class Report(Collector):
    """csv2xml's diagnostics (a Collector): a warning is printed as it comes (a progress bar on the
    screen cleared first); a note is said once, and printed by `flush_notes` when the run gets that far.
    Quiet (--quiet): notes are counted but never printed, and no progress bar is drawn. Not `printing`
    (the library, mdl.api): every diagnostic is kept, to be read with `diagnostics()`, and none printed."""

    def __init__(self, quiet: bool = False, printing: bool = True) -> None:
        super().__init__(notes_once=True)
        self.quiet, self.printing = quiet or not printing, printing
        self.progress: Progress | None = None  # a bar on the screen, cleared before a warning prints
        self._notes: list[Diagnostic] = []  # said, not printed yet
        self._places: tuple[str, dict[int, str]] | None = None  # a PDF table's file and its rows' places

    def located(self, file: str, places: dict[int, str]) -> None:
        """From now on, the rows of `file` are named by their places (`p14:r7`), not by line numbers:
        a diagnostic at line N of it is at `FILE:p14:r7`, and `line N` in its message becomes `p14:r7`."""
        self._places = (file, places) if places else None

    def row_name(self, line: int) -> str:
        """How a message names the table's row on `line`: `line 12`, or a PDF's `p14:r7`."""
        return self._places[1].get(line, f"line {line}") if self._places else f"line {line}"

    def placed(self, diag: Diagnostic) -> Diagnostic:
        """The diagnostic with a PDF row's line named by its place (see `located`)."""
        if self._places is None or diag.file != self._places[0]:
            return diag
        places = self._places[1]

        def place(m: re.Match[str]) -> str:
            return places.get(int(m.group(1)), m.group(0))

        message = _ROW.sub(lambda m: f"`row = {place(m)}`", _LINE.sub(place, diag.message))
        message = _LINES.sub(lambda m: f"{_at(places, m.group(1))} and {_at(places, m.group(2))}", message)
        if diag.line in places:
            return Diagnostic(f"{diag.file}:{places[diag.line]}", None, None, message, diag.severity)
        return Diagnostic(diag.file, diag.line, diag.col, message, diag.severity)

    def bar(self, label: str, total: int, percent: bool = False) -> Progress | None:
        """A progress bar for a long step, or None when quiet."""
        return None if self.quiet else Progress(label, total, percent=percent)

    def add(self, diag: Diagnostic, *, kind: str | None = None, always: bool = False) -> bool:
        diag = self.placed(diag)
        said = super().add(diag, kind=kind, always=always)
        if not self.printing:
            return said
        if said and diag.severity == "note":
            if not self.quiet:
                self._notes.append(diag)
        elif said:
            if self.progress:
                self.progress.close()
            print(diag, file=sys.stderr, flush=True)
        return said

    def flush_notes(self) -> None:
        for diag in self._notes:
            print(diag, file=sys.stderr, flush=True)
        self._notes.clear()


class Progress:
    """`label [#####.....] n/total` (or `NN% Ts`, with percent: T seconds so far) on a terminal,
    redrawn at most ten times a second, only when it changes, and only once the work has taken half
    a second; nothing at all when stderr is not a terminal. Calling it with 0 advances nothing but
    redraws when due: a sign of life in a long step."""

    def __init__(self, label: str, total: int, stream: TextIO | None = None, percent: bool = False) -> None:
        self.label, self.total, self.done, self.percent = label, max(total, 1), 0, percent
        self.stream = stream or sys.stderr
        self.shown = False
        self.frame = ""  # what is on the screen
        self.enabled = _is_terminal(self.stream)
        self.start = self.last = time.monotonic()

    def __call__(self, n: int = 1) -> None:
        self.done += n
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self.start < 0.5 or (now - self.last < 0.1 and self.done < self.total):
            return
        self.last = now
        width = 30
        filled = min(width, width * self.done // self.total)
        count = (
            f"{min(100, 100 * self.done // self.total)}% {now - self.start:.0f}s"
            if self.percent
            else f"{self.done}/{self.total}"
        )
        frame = f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] {count}"
        if self.shown and frame == self.frame:
            return
        self.stream.write(frame)
        self.stream.flush()
        self.shown, self.frame = True, frame

    def close(self) -> None:
        if self.shown:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
            self.shown = False


def _is_terminal(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
