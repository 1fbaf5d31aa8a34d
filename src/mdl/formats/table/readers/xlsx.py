"""Excel workbooks (.xlsx) with openpyxl: each worksheet's cells as Excel shows them in the General
format (a whole number without `.0`, `0.1` not `0.1000000000000000055`, TRUE/FALSE, dates in ISO
form), line breaks inside a cell kept, a merged cell read on each row it covers, a formula read as
the value Excel saved with it (and refused, naming its cell, when there is none).

A few kilobytes of zip can claim gigabytes, a million cells or a merge over the whole sheet: the
archive's parts, the shared strings and each sheet's extent and merges are measured by streaming
their XML before openpyxl reads anything (in its read-only mode, which streams the sheet too), so
what the limits refuse never costs the memory it asks for."""

from __future__ import annotations

import datetime
import re
import warnings
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mdl.diagnostics import MdlError, error
from mdl.formats.table.readers.delimited import MAX_CELL_CHARS, cell_too_long
from mdl.formats.table.readers.document import MAX_CELLS

MAX_UNZIPPED = 256_000_000  # bytes of all the archive's parts unzipped: a register workbook has a few MB
MAX_ELEMENTS = 500_000  # XML elements of a part openpyxl reads whole (styles, workbook, relationships)
EXCEL_ROWS, EXCEL_COLUMNS = 1_048_576, 16_384
_MAIN = "http://schemas.openxmlformats.org/spreadsheetml/2006/main "  # expat names an element `NAMESPACE NAME`
_REF = re.compile(r"\$?([A-Za-z]{1,3})\$?([0-9]{1,7})")


def cell_ref(sheet: str, coordinate: str) -> str:
    """`Sheet1!B7`, or `'My sheet'!B7` where the name needs quotes (as Excel writes it)."""
    plain = sheet.replace("_", "").isalnum() and not sheet[:1].isdigit()
    return f"{sheet}!{coordinate}" if plain else "'" + sheet.replace("'", "''") + f"'!{coordinate}"


def shown(value: object) -> str:
    """A cell's value as Excel's General format shows it."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "TRUE" if value else "FALSE"
    if isinstance(value, float):
        if value.is_integer() and abs(value) < 1e15:
            return str(int(value))
        return format(value, ".15g")
    if isinstance(value, (datetime.datetime, datetime.date, datetime.time)):
        return value.isoformat()
    return str(value)


@dataclass
class Sheet:
    name: str
    rows: list[tuple[int, list[str]]]  # (row number, cells from column A), rows with a cell only
    merged: list[str]  # the merged ranges over several rows whose text is read on each (e.g. 'A5:A9')


@dataclass
class Book:
    """An open workbook (openpyxl's, read-only) and what was measured of it before."""

    path: Path
    archive: zipfile.ZipFile
    book: Any
    cells: int = 0  # of the sheets read so far, counted as their extents (columns by rows)
    values: Any = None  # the workbook again with the values Excel saved for formulas, once needed

    def close(self) -> None:
        for book in (self.book, self.values):
            if book is not None:
                book.close()
        self.archive.close()

    def __enter__(self) -> Book:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass
class _Extent:
    """What streaming a sheet's XML found: its extent and its merges over several rows."""

    width: int = 0
    height: int = 0
    merges: list[tuple[int, int, int, int]] = field(default_factory=list)  # (min_row, min_col, max_row, max_col)


def _column(letters: str) -> int:
    n = 0
    for ch in letters.upper():
        n = n * 26 + ord(ch) - 64
    return n


def _range(ref: str) -> tuple[int, int, int, int] | None:
    """A merge's `A5:B9` as (min_row, min_col, max_row, max_col); None for what is not a range."""
    ends = [_REF.fullmatch(part) for part in ref.split(":")]
    if len(ends) not in (1, 2) or not all(ends):
        return None
    (c1, r1), (c2, r2) = ((m.group(1), m.group(2)) for m in (ends[0], ends[-1]) if m)
    rows, cols = sorted((int(r1), int(r2))), sorted((_column(c1), _column(c2)))
    return rows[0], cols[0], rows[1], cols[1]


def _scan(path: Path, source: IO[bytes], on_start: Callable[[str, dict[str, str]], None]) -> None:
    """Call on_start with each element's name (`NAMESPACE NAME`) and attributes as expat reads the
    part, keeping nothing: memory stays the same whatever the part holds. A part declaring entities
    (which no workbook does: what entity bombs are made of) is refused."""
    from xml.parsers import expat

    def no_entities(name: str, *_: object) -> None:
        raise error(f"a part of the workbook declares the XML entity {name!r}: not a workbook Excel writes", path)

    parser = expat.ParserCreate(namespace_separator=" ")
    parser.EntityDeclHandler = no_entities
    parser.StartElementHandler = on_start
    parser.ParseFile(source)


# parts read-only openpyxl never parses (a pivot table's cache can hold every row of its data: a
# workbook with one is read, not refused), and the sheets, streamed and measured by _measure
UNREAD_PARTS = (
    "xl/worksheets/",
    "xl/pivotCache/",
    "xl/pivotTables/",
    "xl/comments",
    "xl/threadedComments/",
    "xl/persons/",
    "xl/queryTables/",
    "xl/tables/",
    "customXml/",
)


def _refuse_archive(path: Path, archive: zipfile.ZipFile) -> None:
    """The archive's limits, before openpyxl reads any part whole: the bytes it unzips to (zipfile
    reads no more than a part declares), the elements of the parts read whole, the shared strings."""
    unzipped = sum(info.file_size for info in archive.infolist())
    if unzipped > MAX_UNZIPPED:
        raise error(
            f"the workbook unzips to {unzipped:,} bytes, more than the {MAX_UNZIPPED:,} a workbook may hold", path
        )
    for info in archive.infolist():
        name = info.filename
        if not name.endswith((".xml", ".rels")) or name.startswith(UNREAD_PARTS):
            continue  # not XML, XML that read-only openpyxl never opens, or a sheet (streamed: _measure)
        with archive.open(info) as source:
            _count(path, source, name)


def _count(path: Path, source: IO[bytes], name: str) -> None:
    """A part openpyxl reads whole is refused past MAX_ELEMENTS elements (shared strings: MAX_CELLS)."""
    strings = name.endswith("sharedStrings.xml")
    limit, what = (MAX_CELLS, "shared strings") if strings else (MAX_ELEMENTS, "XML elements")
    count = 0

    def counted(tag: str, _: dict[str, str]) -> None:
        nonlocal count
        if not strings or tag == _MAIN + "si":
            count += 1
            if count > limit:
                raise error(f"the workbook's part {name} holds more than {limit:,} {what}", path)

    _scan(path, source, counted)


def _measure(path: Path, archive: zipfile.ZipFile, part: str, name: str, before: int) -> _Extent:
    """The sheet's extent (the last row and column a cell or a merge over several rows reaches) and
    merges, streamed from its XML and refused as soon as it passes the limits (`before`: the cells
    of the sheets read before it, which count too)."""
    extent = _Extent()
    row = column = 0  # where openpyxl puts a row or cell written without its `r`
    merged_area = 0

    def on_start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal row, column, merged_area
        if tag == _MAIN + "row":
            given = attrs.get("r", "")
            last, row, column = row, int(given) if given.isdigit() else row + 1, 0
            if row <= last or row > EXCEL_ROWS:
                raise error(_misplaced(name, row, last), path)
            return
        if tag == _MAIN + "c":
            where = _REF.fullmatch(attrs.get("r", ""))
            column = _column(where.group(1)) if where else column + 1
            if column > EXCEL_COLUMNS:
                raise error(f"sheet '{name}': a cell in column {column:,}, past Excel's {EXCEL_COLUMNS:,}", path)
            extent.width, extent.height = max(extent.width, column), max(extent.height, row)
        elif tag == _MAIN + "mergeCell":
            span = _range(attrs.get("ref", ""))
            if span is None:
                return
            merged_area += (span[2] - span[0] + 1) * (span[3] - span[1] + 1)
            if merged_area > MAX_CELLS:
                raise error(f"the merged cells of sheet '{name}' cover more than {MAX_CELLS:,} cells", path)
            if span[2] > span[0]:
                extent.merges.append(span)
                extent.width, extent.height = max(extent.width, span[1]), max(extent.height, span[2])
        else:
            return
        if before + extent.width * extent.height > MAX_CELLS:
            with_others = " with the sheets before it" if before else ""
            raise error(
                f"sheet '{name}' spans {extent.width:,} columns by {extent.height:,} rows, more than "
                f"{MAX_CELLS:,} cells{with_others}",
                path,
            )

    with archive.open(part) as source:
        _scan(path, source, on_start)
    return extent


def _misplaced(name: str, row: int, last: int) -> str:
    if row > EXCEL_ROWS:
        return f"sheet '{name}': row {row:,}, past Excel's {EXCEL_ROWS:,} rows"
    return f"sheet '{name}': row {row:,} is written after row {last:,} (rows out of order: a damaged workbook)"


@contextmanager
def _reading(path: Path) -> Iterator[None]:
    """openpyxl and the zip quiet (openpyxl warns of what it does not read: data validation, ...), and
    their errors for a damaged workbook, of many kinds, as one error naming the file."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    except MdlError:
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError) as exc:
        raise error(f"not an Excel workbook (.xlsx is a zip archive): {exc}", path) from None
    except Exception as exc:
        raise error(f"cannot read the workbook: {type(exc).__name__}: {exc}", path) from None


def _load(path: Path, data_only: bool) -> Any:
    import openpyxl  # type: ignore[import-untyped]

    with _reading(path):
        return openpyxl.load_workbook(path, read_only=True, data_only=data_only)


def open_book(path: Path) -> Book:
    """The workbook, its limits checked first (then close() it, or use it in a `with`)."""
    with _reading(path):
        archive = zipfile.ZipFile(path)
    try:
        with _reading(path):
            _refuse_archive(path, archive)
        return Book(path, archive, _load(path, data_only=False))
    except BaseException:
        archive.close()
        raise


def sheet_names(book: Book) -> list[str]:
    return [ws.title for ws in book.book.worksheets]


def read_sheet(path: Path, book: Book, name: str) -> Sheet:
    """The sheet's rows, measured first: a sheet (with the sheets read before it) spanning more than
    MAX_CELLS cells, or with merges covering more, is refused before its cells are read."""
    from openpyxl.utils import get_column_letter  # type: ignore[import-untyped]

    ws = book.book[name]
    with _reading(path):
        extent = _measure(path, book.archive, ws._worksheet_path, name, book.cells)
    book.cells += extent.width * extent.height
    ws.reset_dimensions()  # the sheet's own <dimension> may claim anything: the cells read say
    formulas: list[tuple[int, int, str]] = []
    grid: dict[int, list[str]] = {}
    with _reading(path):
        for number, row in enumerate(ws.iter_rows(max_col=extent.width or None), 1):
            texts = []
            for column, cell in enumerate(row, 1):
                if cell.data_type == "f":
                    formulas.append((number, column, str(cell.value)))
                    texts.append("")
                    continue
                text = shown(cell.value)
                if len(text) > MAX_CELL_CHARS:
                    raise cell_too_long(path, number, column, len(text))
                texts.append(text)
            if any(texts) or (formulas and formulas[-1][0] == number):
                grid[number] = texts
    if formulas:
        _saved_values(path, book, name, formulas, grid)
    merged = []
    for top, left, bottom, right in sorted(extent.merges):  # the first is said
        if top in grid:
            text = grid[top][left - 1] if left - 1 < len(grid[top]) else ""
            if text:
                merged.append(f"{get_column_letter(left)}{top}:{get_column_letter(right)}{bottom}")
            for r in range(top + 1, bottom + 1):
                cells = grid.setdefault(r, [""] * left)
                cells.extend([""] * (left - len(cells)))
                cells[left - 1] = text
    rows = [(r, cells) for r, cells in sorted(grid.items()) if any(c.strip() for c in cells)]
    return Sheet(name, rows, merged)


def _saved_values(
    path: Path, book: Book, name: str, formulas: list[tuple[int, int, str]], grid: dict[int, list[str]]
) -> None:
    """Each formula cell's value as Excel saved it; a formula without one (a workbook written by a
    program that does not calculate, never opened in Excel since) is refused."""
    from openpyxl.utils import get_column_letter

    if book.values is None:
        book.values = _load(path, data_only=True)
    wanted = {(r, c): formula for r, c, formula in formulas}
    width, height = max(c for _, c, _ in formulas), formulas[-1][0]
    with _reading(path):
        rows = book.values[name].iter_rows(max_row=height, max_col=width)
        saved = {
            (r, c): row[c - 1].value for r, row in enumerate(rows, 1) for c in range(1, width + 1) if (r, c) in wanted
        }
    for (r, c), formula in wanted.items():
        value = saved.get((r, c))
        if value is None:
            said = formula if len(formula) <= 80 else formula[:77] + "..."
            raise error(
                f"{cell_ref(name, get_column_letter(c) + str(r))}: the formula {said} has no saved value "
                "(the workbook was written by a program that does not calculate); open and save it in Excel "
                "or LibreOffice, or type the value",
                path,
            )
        text = shown(value)
        if len(text) > MAX_CELL_CHARS:
            raise cell_too_long(path, r, c, len(text))
        grid[r][c - 1] = text
