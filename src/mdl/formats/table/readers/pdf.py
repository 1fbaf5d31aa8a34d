"""Register tables inside PDF manuals (SPEC 4.2), read from the PDF's text layer: pdfium (pypdfium2)
reads each page's characters and ruled lines (readers/pdf_layout.py), pdfplumber's table finder finds
the tables they draw and each becomes rows of cells (readers/pdf_tables.py), and this module joins the
tables of the pages into the document's. Each table becomes rows of cells:
- columns are the narrowest cells with text of their own (a header cell over two columns does not
  merge them), and every cell goes to the column over its middle, so a table the drawing splits into
  slivers (a rule every third of a column) reads as the columns it shows;
- a header over several rows (`Register` / `Address`, `Resolu-` / `tion`, `Byte` / `s`) is one header
  row: the rows before the first holding an address csv2xml reads; a title drawn across most of the
  columns (`Read Input Register`, a section's name) is not part of it;
- a table drawn without rules, every other row on a shaded band, is one table: the rows between the
  bands are cut at the bands' columns;
- a cell's text over several lines is one text, lines joined with a space (a word hyphenated at a
  line's end is joined whole);
- a cell merged over several rows (a block label, a shared register type) is read on each row; a row
  whose address comes from such a cell, with fewer cells of its own, is a description wrapped over a
  row of the drawing and is joined to the row above; a row whose only cell of its own is the next
  address is the next register of the row above (`20, 21`);
- a table that goes on over the next page is one table, whether or not the page repeats its header,
  unless it starts again at its first address (a table of its own under the same header), also with
  a column fewer on the next page (a column with no text there) placed under its own; a row's end
  wrapped over a page break ends that row;
- a table of a few rows repeated on three or more pages at the same place (a running header or
  footer, a page number in a box) is not a table, nor is a table drawn inside another.

Rows are named `pPAGE:rROW` in messages (`manual.pdf:p14:r7`: the 7th table row of page 14); a page
without text (a scan) and an encrypted PDF are errors naming the pages or the file.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mdl.diagnostics import error
from mdl.fileio import read_bytes
from mdl.formats.table.readers.delimited import Row, normalize_header
from mdl.formats.table.readers.pdf_layout import Page
from mdl.formats.table.readers.pdf_tables import Found, is_data, tables_on_page

MAX_PDF_BYTES = 256_000_000  # a manual of a thousand pages has a few tens of MB
MAX_PAGES = 5_000
MAX_TABLE_ROWS = 200_000
RUNNING_ROWS = 3  # rows a running header or footer may have
FORK_PAGES = 40  # a manual this long is laid out in two halves at once (a page takes some 40 ms)


@dataclass
class PdfTable:
    """A table as read: its first and last pages, its rows (lines numbered from 1 over the whole
    document's table rows) and each row's place `pPAGE:rROW`."""

    first: int
    last: int
    columns: int
    rows: list[Row] = field(default_factory=list)
    places: dict[int, str] = field(default_factory=dict)
    header: list[str] = field(default_factory=list)
    spread: int = 0  # cells read on more rows than their own (merged over rows)
    spans: list[tuple[float, float]] = field(default_factory=list)  # its columns' edges where it starts

    @property
    def label(self) -> str:
        return f"p{self.first}" if self.first == self.last else f"pp{self.first}-{self.last}"


def page_range(spec: str, count: int, said: str) -> list[int]:
    """Pages `12-19`, `3`, `3,5-7` (1-based) of a document of `count` pages; MdlError naming `said`
    (`--pages 12-19`, `pages = 12-19 in the INI`) for what does not parse or lies past the end."""
    pages: list[int] = []
    for part in spec.split(","):
        m = re.fullmatch(r"\s*(\d{1,6})\s*(?:[-–]\s*(\d{1,6})\s*)?", part)
        if m is None:
            raise ValueError(f"{said}: {part.strip()!r} is not a page or a range of pages (12, 12-19)")
        first, last = int(m.group(1)), int(m.group(2) or m.group(1))
        if not 1 <= first <= last:
            raise ValueError(f"{said}: {part.strip()!r}: pages count from 1, the first before the last")
        if first > count:
            raise ValueError(f"{said}: the document has {count} pages")
        pages.extend(range(first, min(last, count) + 1))
    return sorted(set(pages))


@contextmanager
def _opening(path: Path) -> Iterator[Any]:
    """The PDF opened with pdfium (its bytes read once, within MAX_PDF_BYTES)."""
    import pypdfium2 as pdfium  # type: ignore[import-untyped]

    data = read_bytes(path, limit=MAX_PDF_BYTES)
    if not data.startswith(b"%PDF-") and b"%PDF-" not in data[:1024]:
        raise error("not a PDF: the file does not start with %PDF-", path)
    try:
        pdf = pdfium.PdfDocument(data)
    except pdfium.PdfiumError as exc:  # pdfium says what it could not do: a password, a damaged file
        if "password" in str(exc).lower():
            raise error("the PDF is encrypted and does not open without a password", path) from None
        said = str(exc).split("(PDFium: ", 1)[-1].rstrip(").") or "pdfium cannot open it"
        raise error(f"not a readable PDF: {said}", path) from None
    try:
        yield pdf
    finally:
        pdf.close()


def _goes_on(before: PdfTable, last: Found, found: Found) -> bool:
    """Whether `found`, the first table of its page, continues `before` (whose last part, on the page
    before, was that page's last table): its columns fit (_placing), the first ending low on its page
    and the second starting high on its own. Whether it repeats the header or not (the first rows of a
    page may be the end of a row wrapped over the page's end)."""
    placing = _placing(before, found)
    if found.page != last.page + 1 or placing is None:
        return False
    if len(placing) != before.columns and found.banded and sum(1 for c in found.rows[0] if c) > 1:
        # fewer columns under a header of its own: another table (Sungrow p35's appendix after the BMS
        # alarms), unless the header is the table's, repeated
        placed = _placed(found.rows[0], placing, before.columns)
        if [normalize_header(c) for c in placed] != [normalize_header(c) for c in before.header]:
            return False
    return last.bottom >= last.height * 0.6 and found.top <= found.height * 0.4


def _placing(before: PdfTable, found: Found) -> list[int] | None:
    """Where the columns of `found` go among those of `before`, the table it may continue: each to its
    own where both have as many; where `found` has fewer (a column with no text on its page: Growatt's
    Value column, or the rest of a cell merged down the page before, SolaX's function code), each to the
    column of `before` holding most of it, in their order, two never to one. None: they do not fit."""
    n = len(found.rows[0])
    if n == before.columns:
        return list(range(n))
    if n > before.columns or len(found.spans) != n or len(before.spans) != before.columns:
        return None
    out: list[int] = []
    for left, right in found.spans:  # a column over several (Senseair p7's names over its bits) fits none
        overlap = [min(right, b) - max(left, a) for a, b in before.spans]
        k = max(range(len(overlap)), key=overlap.__getitem__)
        if 2 * overlap[k] < right - left or (out and k <= out[-1]):
            return None
        out.append(k)
    return out


def _placed(cells: list[str], placing: list[int], width: int) -> list[str]:
    out = [""] * width
    for text, k in zip(cells, placing, strict=True):
        out[k] = text
    return out


def _wrapped_end(before: PdfTable, last: Found, found: Found) -> list[int] | None:
    """The columns of `before` under the cells of `found`, when `found` (the first table of its page)
    is the end of `before`'s last row wrapped over the page break with only its longest cell going on
    (MENNEKES p4: 'charge) 28 = C2 (charging) 29 = D2' ends p3's CP-State description): one row, no
    address, fewer columns than `before`, each under one column of `last` (its part on the page
    before). None when it is not. A table drawn whole after it on the page is a table of its own."""
    if found.page != last.page + 1 or len(found.rows) != 1 or is_data(found.rows[0]) or not before.rows:
        return None
    if not len(found.spans) == len(found.rows[0]) < before.columns == len(last.spans):
        return None
    if last.bottom < last.height * 0.6 or found.top > found.height * 0.4:
        return None
    under = []
    for left, right in found.spans:
        k = [i for i, (a, b) in enumerate(last.spans) if a - 2 <= (left + right) / 2 <= b + 2]
        if len(k) != 1:
            return None
        under.append(k[0])
    return under


def _lay_out(pdf: Any, numbers: tuple[int, ...], path: Path) -> tuple[dict[int, list[Found]], list[int]]:
    """The tables found on each of the pages, and the pages without text."""
    import pypdfium2 as pdfium

    found: dict[int, list[Found]] = {}
    blank: list[int] = []
    for number in numbers:
        try:
            raw = pdf[number - 1]
        except pdfium.PdfiumError:
            raise error(f"page {number} cannot be read: pdfium cannot load it", path) from None
        try:
            page = Page(raw)
            if not page.has_text():
                blank.append(number)
                continue
            found[number] = tables_on_page(page, number, path)
        finally:
            raw.close()
    return found, blank


def _running(found: Found, repeated: dict[tuple[object, ...], int]) -> bool:
    """Whether a table is a running header or footer (or a page number in a box): a few rows, the same
    text at the same place on three pages or more. A longer table printed again and again (the same
    bits for three status registers) is the manual's content."""
    return repeated[found.key] >= 3 and len(found.rows) <= RUNNING_ROWS


def _repeats_header(before: PdfTable, found: Found) -> bool:
    return found.banded and [normalize_header(c) for c in found.rows[0]] == [normalize_header(c) for c in before.header]


def _restarts(before: PdfTable, found: Found) -> bool:
    """Whether `found` repeats `before`'s header and then starts again at the address `before` started
    at: a table of its own that happens to begin at the top of the page after `before` ended low on its
    own (Lambda's heat pump manual: one table per module, each numbered from 00, the boiler's on the
    page after the heat pump's). The address column is the one whose address-like cells differ on every
    row of `before` (a block label or register type merged over the rows repeats)."""
    if not _repeats_header(before, found) or len(found.rows) < 2:
        return False
    data = [row.cells for row in before.rows if is_data(row.cells)]
    for c in range(before.columns):
        cells = [row[c] for row in data if c < len(row) and row[c] and is_data([row[c]])]
        if len(cells) >= 2 and len(set(cells)) == len(cells):
            return found.rows[1][c] == cells[0]
    return False


def page_count(path: Path) -> int:
    """How many pages the PDF has (opening it as read_tables does: its errors the same)."""
    with _opening(path) as pdf:
        return len(pdf)


def read_tables(path: Path, pages: list[int] | None = None) -> list[PdfTable]:
    """The tables of the PDF's pages (`pages`: 1-based, None: all). A long manual's pages are laid out
    in two halves at once where mdl.forks can (the same tables, the same errors)."""
    from mdl import forks

    with _opening(path) as pdf:
        count = len(pdf)
        if count > MAX_PAGES and pages is None:
            raise error(f"the PDF has {count:,} pages; mdl reads at most {MAX_PAGES:,} at once: give --pages", path)
        wanted = pages or list(range(1, count + 1))
        halves = [tuple(wanted)]
        if len(wanted) >= FORK_PAGES and forks.possible():
            halves = [tuple(wanted[: len(wanted) // 2]), tuple(wanted[len(wanted) // 2 :])]
        found: dict[int, list[Found]] = {}
        blank: list[int] = []
        for on_pages, blank_pages in forks.each(halves, lambda numbers: _lay_out(pdf, numbers, path)):
            found.update(on_pages)
            blank.extend(blank_pages)
    if blank and not any(found.values()) and len(blank) == len(wanted):
        raise error(
            f"{_pages(blank)} hold no text (a scanned manual?): mdl reads PDFs with a text layer, "
            "and recognising text in images (OCR) is not something it does",
            path,
        )
    repeated: dict[tuple[object, ...], int] = {}
    for on_page in found.values():
        for f in on_page:
            repeated[f.key] = repeated.get(f.key, 0) + 1
    tables: list[PdfTable] = []
    last: Found | None = None
    line = 0
    for number in sorted(found):
        row_on_page = 0
        for i, f in enumerate(t for t in found[number] if not _running(t, repeated)):
            first_of_page = i == 0
            rows = f.rows
            under = _wrapped_end(tables[-1], last, f) if first_of_page and last is not None and tables else None
            if under is not None:  # its texts end the last row's cells
                end = tables[-1].rows[-1].cells
                for k, text in zip(under, rows[0], strict=True):
                    end[k] = f"{end[k]} {text}" if end[k] and text else end[k] or text
                tables[-1].last, last = number, f
                row_on_page += 1  # a row of the page's drawing: the rows after it keep their places
                continue
            goes_on = first_of_page and last is not None and tables and _goes_on(tables[-1], last, f)
            if goes_on and not _restarts(tables[-1], f):
                current = tables[-1]
                placing = _placing(current, f) or []
                if len(placing) != current.columns:  # a column with no text on this page: left empty
                    rows = [_placed(cells, placing, current.columns) for cells in rows]
                if _repeats_header(current, f):
                    rows = rows[1:]  # the header repeated
                    row_on_page += 1
            else:
                current = PdfTable(number, number, len(rows[0]), header=rows[0] if f.banded else [], spans=f.spans)
                tables.append(current)
            for cells in rows:
                row_on_page += 1
                line += 1
                if len(current.rows) >= MAX_TABLE_ROWS:
                    raise error(f"a table of more than {MAX_TABLE_ROWS:,} rows", path)
                current.rows.append(Row(line, cells))
                current.places[line] = f"p{number}:r{row_on_page}"
            current.last, current.spread = number, current.spread + f.spread
            last = f
        if not found[number]:
            last = None
    return tables


def _pages(numbers: list[int]) -> str:
    runs: list[str] = []
    start = prev = numbers[0]
    for n in [*numbers[1:], None]:
        if n is not None and n == prev + 1:
            prev = n
            continue
        runs.append(str(start) if start == prev else f"{start}-{prev}")
        if n is not None:
            start = prev = n
    return ("page " if len(numbers) == 1 else "pages ") + ", ".join(runs)
