"""The CSV records of a `.mod` file with where each cell starts (line and column), so that every
message points at the cell it is about. Excel's CSV: comma separated, `"` quotes (a doubled `"` inside
is one), a quoted cell may hold commas and line breaks; `\\r\\n`, `\\n` or `\\r` end a record, and the
last record needs no line break."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import NamedTuple


class RecordError(ValueError):
    """A quote that is never closed; `line` and `col` say where it opened."""

    def __init__(self, message: str, line: int, col: int):
        super().__init__(message)
        self.line, self.col = line, col


class Cell(NamedTuple):
    text: str  # as written, quotes removed; not stripped
    line: int
    col: int

    @property
    def value(self) -> str:
        return self.text.strip()


@dataclass(frozen=True)
class Record:
    cells: tuple[Cell, ...]

    @property
    def line(self) -> int:
        return self.cells[0].line

    @property
    def blank(self) -> bool:
        return not any(c.value for c in self.cells)

    def filled(self) -> tuple[Cell, ...]:
        """The cells up to the last one that holds something (Excel pads rows with empty cells)."""
        n = len(self.cells)
        while n and not self.cells[n - 1].value:
            n -= 1
        return self.cells[:n]


_PLAIN = re.compile(r"[^,\r\n]*")  # the rest of a cell: up to a comma or a line break


def records(text: str) -> Iterator[Record]:
    """Every record of `text`, in order; RecordError for a quote never closed."""
    i, line, col, n = 0, 1, 1, len(text)
    while i < n:
        cells: list[Cell] = []
        while True:
            start_line, start_col = line, col
            quoted = ""
            if text.startswith('"', i):
                quoted, i, line, col = _quoted(text, i, line, col)
            m = _PLAIN.match(text, i)  # an unquoted cell, or what follows a closing quote (kept, as Excel does)
            end = m.end() if m else i
            cells.append(Cell(quoted + text[i:end], start_line, start_col))
            col += end - i
            i = end
            if i < n and text[i] == ",":
                i, col = i + 1, col + 1
                continue
            break
        if i < n:  # a line break ends the record
            i += 2 if text.startswith("\r\n", i) else 1
            line, col = line + 1, 1
        yield Record(tuple(cells))


def _quoted(text: str, i: int, line: int, col: int) -> tuple[str, int, int, int]:
    """The text of the quoted cell opening at text[i], and the position after its closing quote."""
    start_line, start_col = line, col
    parts: list[str] = []
    i, col = i + 1, col + 1
    while True:
        j = text.find('"', i)
        if j < 0:
            raise RecordError("a quoted cell is never closed", start_line, start_col)
        chunk = text[i:j]
        parts.append(chunk)
        line, col = _advance(chunk, line, col)
        i, col = j + 1, col + 1
        if not text.startswith('"', i):
            return "".join(parts), i, line, col
        parts.append('"')  # a doubled quote stands for one
        i, col = i + 1, col + 1


def _advance(chunk: str, line: int, col: int) -> tuple[int, int]:
    """The position after `chunk` (text inside quotes, which may hold line breaks)."""
    breaks = chunk.count("\n") + chunk.count("\r") - chunk.count("\r\n")
    if not breaks:
        return line, col + len(chunk)
    last = max(chunk.rfind("\n"), chunk.rfind("\r"))
    return line + breaks, len(chunk) - last
