"""OpenDocument spreadsheets (.ods: LibreOffice, OpenOffice), read as .xlsx ones are (readers/xlsx.py):
each sheet's cells as shown (a number's saved value without `.0`, a cell's paragraphs as lines), a
cell spanning rows read on each of them, rows named by their row numbers.

The sheet XML is streamed with lxml (no entities, no network) and its repeats are bounded: a file
saying `number-columns-repeated="16384"` on an empty cell or a million empty rows at the end (as
LibreOffice writes them) costs nothing; repeated cells with text count against the limit of cells."""

from __future__ import annotations

import zipfile
from pathlib import Path

from mdl.diagnostics import error
from mdl.formats.table.readers.delimited import MAX_CELL_CHARS, cell_too_long
from mdl.formats.table.readers.document import MAX_CELLS
from mdl.formats.table.readers.xlsx import MAX_UNZIPPED, Sheet, shown

MAX_COLUMNS = 16_384  # of a sheet, as LibreOffice and Excel have them
_TABLE = "urn:oasis:names:tc:opendocument:xmlns:table:1.0"
_OFFICE = "urn:oasis:names:tc:opendocument:xmlns:office:1.0"
_TEXT = "urn:oasis:names:tc:opendocument:xmlns:text:1.0"


def _t(name: str) -> str:
    return f"{{{_TABLE}}}{name}"


def _repeat(element: object, key: str, path: Path) -> int:
    raw = element.get(_t(key), "1")  # type: ignore[attr-defined]
    if not raw.isdigit() or len(raw) > 9:
        raise error(f"content.xml: table:{key}={raw!r} is not a count", path)
    return max(1, int(raw))


def _text(cell: object) -> str:
    """A cell's text: its paragraphs as lines; a float's saved value as Excel's General shows it."""
    kind = cell.get(f"{{{_OFFICE}}}value-type")  # type: ignore[attr-defined]
    if kind in ("float", "percentage", "currency"):
        value = cell.get(f"{{{_OFFICE}}}value")  # type: ignore[attr-defined]
        try:
            return shown(float(value))
        except (TypeError, ValueError):
            pass
    if kind == "boolean":
        return shown(cell.get(f"{{{_OFFICE}}}boolean-value") == "true")  # type: ignore[attr-defined]
    paragraphs = cell.findall(f"{{{_TEXT}}}p")  # type: ignore[attr-defined]
    return "\n".join("".join(p.itertext()) for p in paragraphs)


def read_ods(path: Path) -> list[Sheet]:
    from lxml import etree

    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise error(f"not a readable OpenDocument spreadsheet (.ods): {exc}", path) from None
    with archive:
        try:
            info = archive.getinfo("content.xml")
        except KeyError:
            raise error("not an OpenDocument spreadsheet: the file has no content.xml", path) from None
        if info.file_size > MAX_UNZIPPED:
            raise error(f"content.xml unzips to {info.file_size:,} bytes; mdl reads at most {MAX_UNZIPPED:,}", path)
        sheets: list[Sheet] = []
        cells = 0
        try:
            with archive.open(info) as source:
                events = etree.iterparse(
                    source, events=("end",), tag=_t("table"), resolve_entities=False, no_network=True, huge_tree=False
                )
                for _, table in events:
                    sheet, counted = _sheet(table, path, MAX_CELLS - cells)
                    cells += counted
                    sheets.append(sheet)
                    table.clear()
        except etree.XMLSyntaxError as exc:
            raise error(f"content.xml: {exc}", path) from None
    return sheets


def _sheet(table: object, path: Path, budget: int) -> tuple[Sheet, int]:
    """One table:table: (the sheet, the cells with text it holds, repeats counted)."""
    from openpyxl.utils import get_column_letter  # type: ignore[import-untyped]

    name = table.get(_t("name"), "")  # type: ignore[attr-defined]
    grid: dict[int, list[str]] = {}
    spans: list[tuple[int, int, int]] = []  # (row, column, rows spanned) of cells over several rows
    counted = 0
    number = 0
    for row in table.iter(_t("table-row")):  # type: ignore[attr-defined]
        times = _repeat(row, "number-rows-repeated", path)
        texts: list[str] = []
        empty = 0  # empty cells not yet placed: only those before a cell with text ever are
        for cell in row:
            if cell.tag not in (_t("table-cell"), _t("covered-table-cell")):
                continue
            text = _text(cell) if cell.tag == _t("table-cell") else ""
            repeat = _repeat(cell, "number-columns-repeated", path)
            if not text:
                empty += repeat
                continue
            if len(text) > MAX_CELL_CHARS:
                raise cell_too_long(path, number + 1, len(texts) + empty + 1, len(text))
            if len(texts) + empty + repeat > MAX_COLUMNS:
                raise error(f"row {number + 1} of sheet {name!r} has more than {MAX_COLUMNS:,} columns", path)
            counted += (empty + repeat) * times  # the empty cells before it are made too
            if counted > budget:
                raise error(f"the workbook's sheets hold more than {MAX_CELLS:,} cells with text", path)
            texts.extend([""] * empty)
            empty = 0
            rows_spanned = _repeat(cell, "number-rows-spanned", path)
            if rows_spanned > 1:
                counted += (rows_spanned - 1) * (len(texts) + 1)  # the rows below it hold its text
                if counted > budget:
                    raise error(f"the workbook's sheets hold more than {MAX_CELLS:,} cells with text", path)
                spans.append((number + 1, len(texts), rows_spanned))
            texts.extend([text] * repeat)
        for _ in range(times if texts else 0):
            number += 1
            grid[number] = list(texts)
        if not texts:
            number += times
    merged = []
    for top, column, rows_spanned in spans:
        text = grid[top][column]
        letters = get_column_letter(column + 1)
        merged.append(f"{letters}{top}:{letters}{top + rows_spanned - 1}")
        for r in range(top + 1, top + rows_spanned):
            line = grid.setdefault(r, [])
            line.extend([""] * max(0, column + 1 - len(line)))
            line[column] = line[column] or text
    return Sheet(name, sorted(grid.items()), merged), counted
