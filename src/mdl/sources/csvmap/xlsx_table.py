"""Excel workbooks (.xlsx) with openpyxl: each worksheet's cells as Excel shows them in the General
format (a whole number without `.0`, `0.1` not `0.1000000000000000055`, TRUE/FALSE, dates in ISO
form), line breaks inside a cell kept, a merged cell read on each row it covers, a formula read as
the value Excel saved with it (and refused, naming its cell, when there is none)."""

from __future__ import annotations

import datetime
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mdl.diagnostics import error
from mdl.sources.csvmap.documents import MAX_CELLS


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


def _load(path: Path, data_only: bool) -> Any:
    import openpyxl  # type: ignore[import-untyped]

    try:
        with warnings.catch_warnings():  # openpyxl warns of what it does not read (data validation, ...)
            warnings.simplefilter("ignore")
            return openpyxl.load_workbook(path, data_only=data_only)
    except (zipfile.BadZipFile, OSError) as exc:
        raise error(f"not an Excel workbook (.xlsx is a zip archive): {exc}", path) from None
    except Exception as exc:  # openpyxl's own errors for a damaged workbook are of many kinds
        raise error(f"cannot read the workbook: {type(exc).__name__}: {exc}", path) from None


def sheet_names(book: Any) -> list[str]:
    return [ws.title for ws in book.worksheets]


def open_book(path: Path) -> Any:
    if path.suffix.lower() == ".xls":
        raise error("an Excel 97-2003 workbook (.xls): save it as .xlsx (or CSV) to read it", path)
    return _load(path, data_only=False)


def read_sheet(path: Path, book: Any, name: str) -> Sheet:
    ws = book[name]  # a sheet claiming more than MAX_CELLS is refused before its grid is built
    width, height = ws.max_column or 0, ws.max_row or 0
    if width * height > MAX_CELLS:
        raise error(f"sheet '{name}' spans {width:,} columns by {height:,} rows, more than {MAX_CELLS:,} cells", path)
    formulas: list[tuple[int, int, str]] = []
    grid: dict[int, list[str]] = {}
    for row in ws.iter_rows():
        texts = []
        for cell in row:
            if cell.data_type == "f":
                formulas.append((cell.row, cell.column, str(cell.value)))
                texts.append("")
            else:
                texts.append(shown(cell.value))
        if row and (any(texts) or (formulas and formulas[-1][0] == row[0].row)):
            grid[row[0].row] = texts
    if formulas:
        _saved_values(path, name, formulas, grid)
    merged = []
    for rng in sorted(ws.merged_cells.ranges, key=lambda r: (r.min_row, r.min_col)):  # the first is said
        if rng.max_row > rng.min_row and rng.min_row in grid:
            text = grid[rng.min_row][rng.min_col - 1] if rng.min_col - 1 < len(grid[rng.min_row]) else ""
            if text:
                merged.append(str(rng))
            for r in range(rng.min_row + 1, rng.max_row + 1):
                cells = grid.setdefault(r, [""] * rng.min_col)
                cells.extend([""] * (rng.min_col - len(cells)))
                cells[rng.min_col - 1] = text
    rows = [(r, cells) for r, cells in sorted(grid.items()) if any(c.strip() for c in cells)]
    return Sheet(name, rows, merged)


def _saved_values(path: Path, name: str, formulas: list[tuple[int, int, str]], grid: dict[int, list[str]]) -> None:
    """Each formula cell's value as Excel saved it; a formula without one (a workbook written by a
    program that does not calculate, never opened in Excel since) is refused."""
    from openpyxl.utils import get_column_letter  # type: ignore[import-untyped]

    ws = _load(path, data_only=True)[name]
    for r, c, formula in formulas:
        value = ws.cell(row=r, column=c).value
        if value is None:
            raise error(
                f"{cell_ref(name, get_column_letter(c) + str(r))}: the formula {formula} has no saved value "
                "(the workbook was written by a program that does not calculate); open and save it in Excel "
                "or LibreOffice, or type the value",
                path,
            )
        grid[r][c - 1] = shown(value)
