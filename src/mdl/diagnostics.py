"""Errors for users: a Diagnostic names file, line, column and message; MdlError carries a list.

Exit codes follow SPEC section 1: 1 invalid input, 3 the device could not be reached or refused.
"""

from __future__ import annotations

import re
import unicodedata
import weakref
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from _typeshed import StrPath

EXIT_INVALID = 1
EXIT_DEVICE = 3
_LINE_BREAKING = ("Cc", "Zl", "Zp")  # control characters, line and paragraph separators


def one_line(text: str) -> str:
    """`text` with control characters and line separators escaped (`\\n`, `\\x00`): a cell's line
    break or a file name's NUL never splits or hides a message."""
    return "".join(repr(ch)[1:-1] if unicodedata.category(ch) in _LINE_BREAKING else ch for ch in text)


SHOWN_CHARS = 40  # of a cell or a field said back in a message: a longer one is cut, with its length


def said(text: str) -> str:
    """A field as a message says it: cut to its first SHOWN_CHARS characters and its length when
    longer, so that no message repeats a whole oversized field."""
    return text if len(text) <= SHOWN_CHARS else f"{text[:SHOWN_CHARS]}... ({len(text):,} characters)"


def shown(text: str) -> str:
    """A field quoted for a message (`said`): `'text'`, or `'first 40...' (N characters)`."""
    return f"'{text}'" if len(text) <= SHOWN_CHARS else f"'{text[:SHOWN_CHARS]}...' ({len(text):,} characters)"


@dataclass(frozen=True)
class Diagnostic:
    file: str | None
    line: int | None
    col: int | None
    message: str
    severity: str = "error"

    def __str__(self) -> str:
        where = ""
        if self.file:
            where = one_line(self.file)
            if self.line:
                where += f":{self.line}"
                if self.col:
                    where += f":{self.col}"
            where += ": "
        return f"{where}{self.severity}: {one_line(self.message)}"


class MdlError(Exception):
    """One or more problems with the user's input (or the device); never a bug."""

    def __init__(self, diagnostics: str | Diagnostic | Iterable[str | Diagnostic], exit_code: int = EXIT_INVALID):
        if isinstance(diagnostics, (str, Diagnostic)):
            diagnostics = [diagnostics]
        self.diagnostics = [d if isinstance(d, Diagnostic) else Diagnostic(None, None, None, d) for d in diagnostics]
        self.exit_code = exit_code
        super().__init__("\n".join(str(d) for d in self.diagnostics))


def error(message: str, file: StrPath | None = None, line: int | None = None, col: int | None = None) -> MdlError:
    return MdlError(Diagnostic(str(file) if file else None, line, col, message))


class DeviceError(MdlError):
    """The device could not be reached or answered with an error (exit 3)."""

    def __init__(self, message: str, code: int | None = None):
        super().__init__(message, exit_code=EXIT_DEVICE)
        self.code = code


SHOWN_EACH = 3  # messages of one kind said in full before the rest are summed up
SHOWN_LINES = 3  # lines a summary names
# a pattern's text, compiled where it is used (re.compile keeps it): no compiling at import (issue 40)
_VARYING = r"'[^']*'|[0-9]+"  # what differs between two messages of one kind


def message_kind(message: str) -> str:
    """A message's kind when its reader gives none: the text with each quoted word and each number as
    `#` (`[AI] 'x' on line 7` and `[AI] 'y' on line 9` are one kind)."""
    return re.compile(_VARYING).sub("#", message)


def line_order(d: Diagnostic) -> tuple[int, int]:
    return d.line or 0, d.col or 0


class _Kind:
    """Where one kind of message was seen: those said in full, how many in all, on how many rows (one
    line twice in a row counts once) and lines for the summary (see Collector)."""

    __slots__ = ("last_line", "lines", "rows", "said", "times")

    def __init__(self, said: list[Diagnostic] | None = None) -> None:
        self.said: list[Diagnostic] = said if said is not None else []
        self.times = 0
        self.rows = 0
        self.lines: list[int | None] = []
        self.last_line: int | None = None

    def add_row(self, line: int | None, shown_lines: int) -> None:
        self.times += 1
        if self.rows and line == self.last_line:
            return  # the same row again (two cells of one row count once)
        self.rows += 1
        self.last_line = line
        if line is not None and len(self.lines) < shown_lines:
            self.lines.append(line)

    def where(self) -> str:
        more = ", ..." if self.rows > len(self.lines) else ""
        return f"line{'s' * (len(self.lines) > 1)} {', '.join(map(str, self.lines))}{more}"


class Collector:
    """The diagnostics of reading one input, bounded whatever the input holds: `error`, `warn` and
    `note` (or `add` for a Diagnostic made elsewhere), then `diagnostics()` in file order.

    A message may have a kind (a fixed text saying what happened, without the input's own words; or,
    with `kind_of`, one derived from every message). Messages of one kind and severity seen up to
    `shown_each` times are said each time; past that, either (the default) the kind is one message
    `KIND on N rows (first at lines a, b, c, ...)` at its first place, or (`fold`) the first
    `shown_each` are said and the next one ends with `; and N more like it (lines a, b, ...)`. Errors
    past `max_errors` (None: no cap) are counted in one last error; one given `always` (why a reader
    stopped) is said even then. With `notes_once`, a note whose text was said is not said again."""

    def __init__(
        self,
        file: StrPath | None = None,
        *,
        shown_each: int = SHOWN_EACH,
        shown_lines: int = SHOWN_LINES,
        fold: bool = False,
        max_errors: int | None = None,
        kind_of: Callable[[str], str] | None = None,
        notes_once: bool = False,
    ) -> None:
        self.file = str(file) if file else None
        self.shown_each, self.shown_lines, self.fold = shown_each, shown_lines, fold
        self.max_errors, self.kind_of, self.notes_once = max_errors, kind_of, notes_once
        self.counts: Counter[str] = Counter()  # severity -> how many were reported (said or summed up)
        self._said: list[tuple[tuple[str, str] | None, Diagnostic]] = []  # in order, with their kind
        self._kinds: dict[tuple[str, str], _Kind] = {}  # (severity, kind) -> where it was seen
        self._folded: list[tuple[str, str]] = []  # with fold: kinds in the order their last said one came
        self._errors_said = 0
        self._more_errors: _Kind | None = None  # the errors past max_errors
        self._noted: set[str] = set()

    @property
    def failed(self) -> bool:
        return self.counts["error"] > 0

    def error(
        self,
        message: str,
        line: int | None = None,
        col: int | None = None,
        *,
        kind: str | None = None,
        always: bool = False,
        file: str | None = None,
    ) -> None:
        self.add(Diagnostic(file or self.file, line, col, message), kind=kind, always=always)

    def warn(
        self,
        message: str,
        line: int | None = None,
        col: int | None = None,
        *,
        kind: str | None = None,
        file: str | None = None,
    ) -> None:
        self.add(Diagnostic(file or self.file, line, col, message, "warning"), kind=kind)

    def note(
        self,
        message: str,
        line: int | None = None,
        col: int | None = None,
        *,
        kind: str | None = None,
        file: str | None = None,
    ) -> None:
        self.add(Diagnostic(file or self.file, line, col, message, "note"), kind=kind)

    def add(self, diag: Diagnostic, *, kind: str | None = None, always: bool = False) -> bool:
        """Record `diag`; whether it is, so far, one said in full (not dropped, capped or summed up)."""
        if self.notes_once and diag.severity == "note":
            if diag.message in self._noted:
                return False
            self._noted.add(diag.message)
        self.counts[diag.severity] += 1
        if (
            diag.severity == "error"
            and not always
            and self.max_errors is not None
            and self._errors_said >= self.max_errors
        ):
            if self._more_errors is None:
                self._more_errors = _Kind([diag])
            self._more_errors.add_row(diag.line, self.shown_lines)
            return False
        self._errors_said += diag.severity == "error"
        if kind is None and self.kind_of is not None:
            kind = self.kind_of(diag.message)
        if kind is None:
            self._said.append((None, diag))
            return True
        key = (diag.severity, kind)
        seen = self._kinds.setdefault(key, _Kind())
        if not self.fold:
            if len(seen.said) < self.shown_each:
                seen.said.append(diag)
            seen.add_row(diag.line, self.shown_lines)
            return seen.times <= self.shown_each
        seen.times += 1
        if len(seen.said) < self.shown_each:
            seen.said.append(diag)
            self._said.append((key, diag))
        elif len(seen.said) == self.shown_each:  # said, with the count of those after it if there are any
            seen.said.append(diag)
            self._folded.append(key)
        else:
            if len(seen.lines) < self.shown_lines:
                seen.lines.append(diag.line)
            return False
        return True

    def diagnostics(self, severity: str | None = None) -> list[Diagnostic]:
        """Every message (of `severity`, if given) in file order, repeated kinds summed up as the class says."""
        if self.fold:
            out = [d for _, d in self._said] + [self._folded_one(self._kinds[key]) for key in self._folded]
        else:
            out = [d for key, d in self._said if key is None]
            for (_, kind), seen in self._kinds.items():
                out += seen.said if seen.times <= self.shown_each else [self._summary(kind, seen)]
        out.sort(key=line_order)
        more = self._more_errors
        if more is not None:
            first, n = more.said[0], more.times
            out.append(
                Diagnostic(
                    first.file,
                    first.line,
                    first.col,
                    f"{n:,} more error{'s' * (n > 1)} not shown (first at {more.where()}): "
                    f"only the first {self.max_errors} are",
                )
            )
        return out if severity is None else [d for d in out if d.severity == severity]

    @staticmethod
    def _summary(kind: str, seen: _Kind) -> Diagnostic:
        first = seen.said[0]
        rows = f"{seen.rows:,} row{'s' * (seen.rows > 1)}"
        return Diagnostic(
            first.file, first.line, first.col, f"{kind} on {rows} (first at {seen.where()})", first.severity
        )

    def _folded_one(self, seen: _Kind) -> Diagnostic:
        last = seen.said[-1]
        more = seen.times - len(seen.said)
        if not more:
            return last
        lines = ", ".join(str(line) for line in seen.lines if line)
        etc = ", ..." if more > self.shown_lines else ""
        where = f" (lines {lines}{etc})" if lines else ""
        return Diagnostic(
            last.file, last.line, last.col, f"{last.message}; and {more:,} more like it{where}", last.severity
        )


TextStyle = Literal["xml", "plain", "single", "double"]  # how raw source text maps to the parsed text
_XML_REFERENCE = r"&(?:#[0-9]+|#x[0-9a-fA-F]+|[A-Za-z_][\w.-]*);"
_YAML_ESCAPE = {"x": 4, "u": 6, "U": 10}  # raw length of \xHH, \uHHHH, \UHHHHHHHH; other escapes: 2


@dataclass(frozen=True)
class TextSpan:
    """Where a text of the model (an element's text, a YAML scalar) starts in its source file, and the
    raw source from there on, so that an offset inside the parsed text (an expression's column) maps
    to the file's line and column: character references, `\r\n`, YAML quotes, escapes and folded
    lines all taken into account."""

    line: int
    col: int
    raw: str = ""
    style: TextStyle = "xml"
    label: str | None = None  # how messages name the thing this text belongs to, where the source has its own words

    def at(self, offset: int) -> tuple[int, int]:
        """(line, column) in the file of the parsed text's character number `offset` (0-based)."""
        line, col, i, raw = self.line, self.col, 0, self.raw
        if self.style in ("single", "double") and raw[:1] in ("'", '"'):
            i, col = 1, col + 1
        done = 0
        while done < max(offset, 0) and i < len(raw):
            step = self._step(raw, i)
            for ch in raw[i : i + step]:
                line, col = (line + 1, 1) if ch == "\n" else (line, col + 1)
            i += step
            done += 1
        return line, col

    def _step(self, raw: str, i: int) -> int:
        """How many raw characters make the parsed character at raw[i]."""
        ch = raw[i]
        if ch == "\r" and raw[i + 1 : i + 2] == "\n":
            return 2
        if self.style == "xml":
            if ch == "&":
                m = re.compile(_XML_REFERENCE).match(raw, i)
                return len(m.group(0)) if m else 1
            return 1
        if ch == "\n":  # YAML: a folded line break: the break and the next line's indentation
            j = i + 1
            while j < len(raw) and raw[j] in " \t":
                j += 1
            return j - i
        if self.style == "double" and ch == "\\" and i + 1 < len(raw):
            return _YAML_ESCAPE.get(raw[i + 1], 2)
        if self.style == "single" and raw[i : i + 2] == "''":
            return 2
        return 1


# Where each text of a model object came from: the sources record it, the checks of mdl.resolver read it.
# Keyed by the object's identity (model objects are mutable dataclasses, so not hashable); an entry
# goes when its object does.
_SPANS: dict[int, tuple[weakref.ref[object], dict[str, TextSpan]]] = {}


def record_span(owner: object, key: str, span: TextSpan) -> None:
    """Remember where `owner`'s text `key` (an element name, or "" for the owner itself) starts."""
    key_of = id(owner)
    entry = _SPANS.get(key_of)
    if entry is None or entry[0]() is not owner:
        entry = (weakref.ref(owner, partial(_SPANS.pop, key_of)), {})  # pop(key, the dead ref as default)
        _SPANS[key_of] = entry
    entry[1][key] = span


# Owners whose spans a source records only when one is asked for (finding every position in a large
# file costs more than reading it, and only a message needs one): id -> (the owner, what records them).
_DEFERRED: dict[int, tuple[weakref.ref[object], Callable[[], None]]] = {}


def defer_spans(owner: object, record: Callable[[], None]) -> None:
    """`record()` records `owner`'s spans (with record_span; it may record other owners' too): it is
    called the first time span_of asks for one of them."""
    key_of = id(owner)
    # the callback is bound to the dict itself: at interpreter exit the module's names may be gone
    _DEFERRED[key_of] = (weakref.ref(owner, partial(_DEFERRED.pop, key_of)), record)


def span_of(owner: object, key: str) -> TextSpan | None:
    entry = _SPANS.get(id(owner))
    if entry is None or entry[0]() is not owner:
        pending = _DEFERRED.pop(id(owner), None)
        if pending is None or pending[0]() is not owner:
            return None
        pending[1]()
        entry = _SPANS.get(id(owner))
        if entry is None or entry[0]() is not owner:
            return None
    return entry[1].get(key)
