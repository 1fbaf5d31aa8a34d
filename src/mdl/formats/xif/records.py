"""The CSV records of a `.mod` file with where each cell starts (line and column), so that every
message points at the cell it is about. Excel's CSV: comma separated, `"` quotes (a doubled `"` inside
is one), a quoted cell may hold commas and line breaks; `\\r\\n`, `\\n` or `\\r` end a record, and the
last record needs no line break. A record of more than MAX_CELLS cells is refused (Excel's limit): no
row makes the reader hold more than that many cells."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import accumulate, repeat
from typing import NamedTuple

MAX_CELLS = 16_384  # cells of one record: Excel's column limit


class RecordError(ValueError):
    """A quote that is never closed (`line` and `col` say where it opened), or a record of too many cells."""

    def __init__(self, message: str, line: int, col: int):
        super().__init__(message)
        self.line, self.col = line, col


class Cell(NamedTuple):
    text: str  # as written, quotes removed; not stripped
    line: int
    col: int
    quoted: bool = False  # written between quotes (a quoted `#` in a datapoint row is data, not a product line)

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
_LINE = re.compile(r"[^\r\n]*")  # a line, up to its line break
_QUOTED = re.compile(r'"([^"]*(?:""[^"]*)*)"')  # a quoted cell: a doubled quote inside stands for one
_BLANKS = re.compile(r"[ \t,\r\n]+")  # the start of lines that hold nothing (Excel's padding)
_TOO_MANY = f"more than {MAX_CELLS:,} cells in one row (Excel's limit); is this a .mod file?"


def records(text: str) -> Iterator[Record]:
    """Every record of `text` that holds something, in order (blank lines are skipped at once);
    RecordError for a quote never closed. A line without quotes is split at once."""
    i, line, n = 0, 1, len(text)
    while i < n:
        blanks = _BLANKS.match(text, i)
        if blanks is not None:  # up to the last line break in it (or the end of the text): blank lines
            run = blanks.group()
            k = len(run) if blanks.end() == n else max(run.rfind("\n"), run.rfind("\r")) + 1
            if k:
                line += run.count("\n", 0, k) + run.count("\r", 0, k) - run.count("\r\n", 0, k)
                i += k
                continue
        end = _LINE.match(text, i).end()  # type: ignore[union-attr]  # matches everywhere
        if text.find('"', i, end) >= 0:
            record, i, line = _record(text, i, line)
            yield record
            continue
        yield Record(_split(text[i:end], line))
        i = end + 2 if text.startswith("\r\n", end) else end + 1
        line += 1


def _split(text: str, line: int) -> tuple[Cell, ...]:
    """The cells of a line without quotes."""
    parts = text.split(",", MAX_CELLS)
    if len(parts) > MAX_CELLS:
        raise RecordError(_TOO_MANY, line, len(text) - len(parts[-1]) + 1)
    cols = accumulate((len(part) + 1 for part in parts[:-1]), initial=1)
    return tuple(map(Cell, parts, repeat(line), cols))


def _record(text: str, i: int, line: int) -> tuple[Record, int, int]:
    """The record starting at text[i] (on `line`), which holds quotes: it, and where the next starts."""
    n, col = len(text), 1
    cells: list[Cell] = []
    while True:
        start_line, start_col, start = line, col, i
        quoted = ""
        if text.startswith('"', i):
            quoted, i, line, col = _quoted(text, i, line, col)
        m = _PLAIN.match(text, i)  # an unquoted cell, or what follows a closing quote (kept, as Excel does)
        end = m.end() if m else i
        if len(cells) == MAX_CELLS:
            raise RecordError(_TOO_MANY, start_line, start_col)
        cells.append(Cell(quoted + text[i:end], start_line, start_col, text.startswith('"', start)))
        col += end - i
        i = end
        if i < n and text[i] == ",":
            i, col = i + 1, col + 1
            continue
        break
    if i < n:  # a line break ends the record
        i += 2 if text.startswith("\r\n", i) else 1
        line += 1
    return Record(tuple(cells)), i, line


def _quoted(text: str, i: int, line: int, col: int) -> tuple[str, int, int, int]:
    """The text of the quoted cell opening at text[i], and the position after its closing quote."""
    m = _QUOTED.match(text, i)
    if m is None or text.startswith('"', m.end()):  # a quote right after the last one: no closing quote
        raise RecordError("a quoted cell is never closed", line, col)
    raw = m.group(1)
    line, col = _advance(raw, line, col + 1)
    return raw.replace('""', '"'), m.end(), line, col + 1


def _advance(chunk: str, line: int, col: int) -> tuple[int, int]:
    """The position after `chunk` (text inside quotes, which may hold line breaks)."""
    breaks = chunk.count("\n") + chunk.count("\r") - chunk.count("\r\n")
    if not breaks:
        return line, col + len(chunk)
    last = max(chunk.rfind("\n"), chunk.rfind("\r"))
    return line + breaks, len(chunk) - last
