"""Errors for users: a Diagnostic names file, line, column and message; MdlError carries a list.

Exit codes follow SPEC section 1: 1 invalid input, 3 the device could not be reached or refused.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

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
