"""Errors for users: a Diagnostic names file, line, column and message; MdlError carries a list.

Exit codes follow SPEC section 1: 1 invalid input, 3 the device could not be reached or refused.
"""

from __future__ import annotations

import re
import unicodedata
import weakref
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
        self.diagnostics = [
            d if isinstance(d, Diagnostic) else Diagnostic(None, None, None, d) for d in diagnostics
        ]
        self.exit_code = exit_code
        super().__init__("\n".join(str(d) for d in self.diagnostics))


def error(message: str, file: StrPath | None = None, line: int | None = None, col: int | None = None) -> MdlError:
    return MdlError(Diagnostic(str(file) if file else None, line, col, message))


class DeviceError(MdlError):
    """The device could not be reached or answered with an error (exit 3)."""

    def __init__(self, message: str, code: int | None = None):
        super().__init__(message, exit_code=EXIT_DEVICE)
        self.code = code


TextStyle = Literal["xml", "plain", "single", "double"]  # how raw source text maps to the parsed text
_XML_REFERENCE = re.compile(r"&(?:#[0-9]+|#x[0-9a-fA-F]+|[A-Za-z_][\w.-]*);")
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
            for ch in raw[i:i + step]:
                line, col = (line + 1, 1) if ch == "\n" else (line, col + 1)
            i += step
            done += 1
        return line, col

    def _step(self, raw: str, i: int) -> int:
        """How many raw characters make the parsed character at raw[i]."""
        ch = raw[i]
        if ch == "\r" and raw[i + 1:i + 2] == "\n":
            return 2
        if self.style == "xml":
            if ch == "&":
                m = _XML_REFERENCE.match(raw, i)
                return len(m.group(0)) if m else 1
            return 1
        if ch == "\n":  # YAML: a folded line break: the break and the next line's indentation
            j = i + 1
            while j < len(raw) and raw[j] in " \t":
                j += 1
            return j - i
        if self.style == "double" and ch == "\\" and i + 1 < len(raw):
            return _YAML_ESCAPE.get(raw[i + 1], 2)
        if self.style == "single" and raw[i:i + 2] == "\'\'":
            return 2
        return 1


# Where each text of a model object came from: the sources record it, the checks of mdl.resolve read it.
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
