"""Excel 97-2003 workbooks (.xls) with xlrd, read as .xlsx ones are (readers/xlsx.py): each sheet's
cells as Excel's General format shows them, rows named by their row numbers; a merged cell is read in
its first row only (xlrd reads merges only with the formatting, which a few KB can inflate to GB).
xlrd reads the whole file: the file's size is bounded first, and each sheet's
extent before its cells are read."""

from __future__ import annotations

import io
from pathlib import Path

from mdl.diagnostics import error
from mdl.fileio import read_bytes
from mdl.formats.table.readers.delimited import MAX_CELL_CHARS, cell_too_long
from mdl.formats.table.readers.document import MAX_CELLS
from mdl.formats.table.readers.xlsx import Sheet, shown

MAX_XLS_BYTES = 64_000_000  # a register workbook has a few MB


def read_xls(path: Path) -> list[Sheet]:
    """Every sheet of the workbook, in order."""
    import xlrd  # type: ignore[import-untyped]

    data = read_bytes(path, limit=MAX_XLS_BYTES)
    try:
        # formatting_info off: with it xlrd pads every row to the widest merge a file claims (a 6 KB
        # bomb); merged cells of an .xls are then read in their first row only. Its warnings go nowhere.
        book = xlrd.open_workbook(file_contents=data, formatting_info=False, on_demand=True, logfile=io.StringIO())
    except Exception as exc:  # xlrd's own errors, whatever the damage: the file is not a readable .xls
        raise error(f"not a readable Excel 97-2003 workbook (.xls): {exc}", path) from None
    sheets = []
    cells = 0
    try:
        for index in range(book.nsheets):
            ws = book.sheet_by_index(index)
            cells += ws.nrows * ws.ncols
            if cells > MAX_CELLS:
                raise error(f"the workbook's sheets span more than {MAX_CELLS:,} cells", path)
            grid: dict[int, list[str]] = {}
            for r in range(ws.nrows):
                texts = []
                for c in range(ws.ncols):
                    text = _shown(ws.cell(r, c), book.datemode)
                    if len(text) > MAX_CELL_CHARS:
                        raise cell_too_long(path, r + 1, c + 1, len(text))
                    texts.append(text)
                if any(texts):
                    grid[r + 1] = texts
            sheets.append(Sheet(ws.name, sorted(grid.items()), []))
            book.unload_sheet(index)
    finally:
        book.release_resources()
    return sheets


def _shown(cell: object, datemode: int) -> str:
    import xlrd

    kind, value = cell.ctype, cell.value  # type: ignore[attr-defined]
    if kind == xlrd.XL_CELL_BOOLEAN:
        return shown(bool(value))
    if kind == xlrd.XL_CELL_DATE:
        try:
            return shown(xlrd.xldate_as_datetime(value, datemode))
        except (ValueError, OverflowError, xlrd.xldate.XLDateError):
            return shown(value)
    if kind in (xlrd.XL_CELL_EMPTY, xlrd.XL_CELL_BLANK, xlrd.XL_CELL_ERROR):
        return ""
    return shown(value)
