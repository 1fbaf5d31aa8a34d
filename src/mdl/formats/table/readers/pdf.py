"""Register tables inside PDF manuals (SPEC 4.2), read from the PDF's text layer: pdfium (pypdfium2)
reads each page's characters and ruled lines (readers/pdf_layout.py) and pdfplumber's table finder
finds the tables they draw. Each table becomes rows of cells:
- columns are the narrowest cells with text of their own (a header cell over two columns does not
  merge them), and every cell goes to the column over its middle, so a table the drawing splits into
  slivers (a rule every third of a column) reads as the columns it shows;
- a header over several rows (`Register` / `Address`, `Resolu-` / `tion`, `Byte` / `s`) is one header
  row: the rows before the first holding an address csv2xml reads;
- a cell's text over several lines is one text, lines joined with a space (a word hyphenated at a
  line's end is joined whole);
- a cell merged over several rows (a block label, a shared register type) is read on each row; a row
  whose address comes from such a cell, with fewer cells of its own, is a description wrapped over a
  row of the drawing and is joined to the row above; a row whose only cell of its own is the next
  address is the next register of the row above (`20, 21`);
- a table that goes on over the next page is one table, whether or not the page repeats its header,
  unless it starts again at its first address (a table of its own under the same header); a row's
  end wrapped over a page break ends that row;
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
from mdl.formats.table.cells import CellError, read_address_cell
from mdl.formats.table.readers.delimited import MAX_CELL_CHARS, Row, normalize_header
from mdl.formats.table.readers.pdf_layout import Page

MAX_PDF_BYTES = 256_000_000  # a manual of a thousand pages has a few tens of MB
MAX_PAGES = 5_000
MAX_TABLE_ROWS = 200_000
HEADER_ROWS = 4  # rows a header may run over
RUNNING_ROWS = 3  # rows a running header or footer may have
FORK_PAGES = 40  # a manual this long is laid out in two halves at once (a page takes some 40 ms)
_ADDRESS = re.compile(r"^(0x)?[0-9a-f]{1,6}h?(\s*[-~～]\s*(0x)?[0-9a-f]{1,6}h?)?$", re.IGNORECASE)
_HYPHEN = re.compile(r"(?<=[a-z])-\n(?=[a-z])")


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

    @property
    def label(self) -> str:
        return f"p{self.first}" if self.first == self.last else f"pp{self.first}-{self.last}"


@dataclass
class _Found:
    """One table on one page, before tables going on over pages are joined."""

    page: int
    top: float
    bottom: float
    height: float
    rows: list[list[str]]
    spread: int
    banded: bool  # its first row is a header (found in its first rows)
    key: tuple[object, ...]  # text and place: what a running header or footer repeats
    spans: list[tuple[float, float]] = field(default_factory=list)  # its columns, left to right


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


def _text(cell: str | None, path: Path, page: int) -> str:
    if not cell:
        return ""
    if len(cell) > MAX_CELL_CHARS:  # a PDF cell has no line and column: its page is its place
        raise error(f"page {page}: a cell of {len(cell):,} characters (at most {MAX_CELL_CHARS:,} are read)", path)
    return " ".join(_HYPHEN.sub("", cell).split())


def _grid(table: Any, texts: list[list[str | None]], path: Path, page: int) -> list[list[tuple[Any, str, bool]]]:
    """The table's cells by pdfplumber's grid: (box, text, spread) per position; a position no cell
    starts at, under a cell reaching down over it, gets that cell's text (spread)."""
    out: list[list[tuple[Any, str, bool]]] = []
    for r, row in enumerate(table.rows):
        line: list[tuple[Any, str, bool]] = []
        for c, box in enumerate(row.cells):
            if box is not None:
                line.append((box, _text(texts[r][c], path, page), False))
                continue
            above = next(
                (out[k][c] for k in range(r - 1, -1, -1) if out[k][c][0] is not None and not out[k][c][2]), None
            )
            if above is not None and above[1] and above[0][3] > row.bbox[1] + 1:
                line.append((above[0], above[1], True))
            else:
                line.append((None, "", False))
        out.append(line)
    return out


def _spans(grid: list[list[tuple[Any, str, bool]]]) -> list[tuple[float, float]]:
    """The table's columns, left to right: the narrowest cells with text of their own, those that
    overlap joined."""
    own = sorted(
        {(round(box[0], 1), round(box[2], 1)) for row in grid for box, text, spread in row if text and not spread}
    )
    narrow = [iv for iv in own if not any(o != iv and o[0] >= iv[0] - 1 and o[1] <= iv[1] + 1 for o in own)]
    spans: list[tuple[float, float]] = []
    for left, right in narrow:
        if spans and left < spans[-1][1] - 1:
            spans[-1] = (min(spans[-1][0], left), max(spans[-1][1], right))
        else:
            spans.append((left, right))
    return spans


def _columns(grid: list[list[tuple[Any, str, bool]]]) -> list[list[tuple[str, bool]]]:
    """Rows of (text, spread) cells in the table's columns: the narrowest cells with text of their own
    (a cell spanning two columns is not one), those that overlap joined; each cell goes to the column
    over its middle (cells in one column joined; a text the cell holds already is not repeated: two
    cells that overlap both hold the characters they share, MENNEKES p7's 'Type')."""
    spans = _spans(grid)
    bounds = [(a[1] + b[0]) / 2 for a, b in zip(spans, spans[1:], strict=False)]
    rows = []
    for row in grid:
        cells: list[tuple[str, bool]] = [("", False)] * len(spans)
        seen: set[int] = set()
        for box, text, spread in row:
            if not text or id(box) in seen:
                continue
            seen.add(id(box))
            k = sum(1 for x in bounds if (box[0] + box[2]) / 2 > x)
            before, _ = cells[k]
            if before == text:
                continue
            cells[k] = (f"{before} {text}" if before else text, spread)
        rows.append(cells)
    return rows


def _continued(rows: list[list[tuple[str, bool]]]) -> tuple[list[list[str]], int]:
    """Rows of texts: a row whose address-like cells all come from a cell merged over it from above (a
    description wrapped over several rows of the drawing) is not a row of its own: its own texts are
    joined to the row above. Also how many cells were read on rows below their own."""
    out: list[list[str]] = []
    spread = 0
    for cells in rows:
        texts = [text for text, _ in cells]
        addresses = [text for text in texts if _is_data([text])]
        own = sum(1 for text, s in cells if text and not s)
        merged = sum(1 for text, s in cells if text and s)
        # a wrapped description: every cell but one or two comes from above; bits of one register
        # under a merged address cell: the address alone comes from above
        if out and addresses and own < merged and all(s for (text, s) in cells if text in addresses):
            for k, (text, s) in enumerate(cells):
                if text and not s:
                    out[-1][k] = f"{out[-1][k]} {text}" if out[-1][k] else text
            continue
        # the next register of one value drawn over two rows (Lambda's INT32: numbers `20` / `21` beside
        # one name, type and unit merged over both): its address is its only cell of its own and every
        # other text is the row above's. Read as two rows, one register per row, the same text named
        # two rows and the function took the first with a warning (`--strict` refused it); one row
        # listing both addresses is what the drawing says.
        if out and own == 1 and merged >= 2 and _next_register(cells, out[-1]):
            k = next(k for k, (text, s) in enumerate(cells) if text and not s)
            out[-1][k] = f"{out[-1][k]}, {cells[k][0]}"
            continue
        spread += sum(1 for text, s in cells if text and s)
        out.append(texts)
    return out, spread


def _next_register(cells: list[tuple[str, bool]], above: list[str]) -> bool:
    """Whether a row's one cell of its own is an address below an address of the row above, and all its
    other texts are the row above's own (cells merged over both)."""
    own = [k for k, (text, s) in enumerate(cells) if text and not s]
    if len(own) != 1 or not _is_data([cells[own[0]][0]]) or not _is_data([above[own[0]]]):
        return False
    return all(text == above[k] for k, (text, s) in enumerate(cells) if text and s)


def _is_data(cells: list[str]) -> bool:
    """Whether a cell of the row is an address as csv2xml reads one (`0x0103`, `4000h`, `40001.3`,
    `0x0103.b8`, `hr:101`, `5017～5018`, `30101 (100)`)."""
    return any(c and any(ch.isdigit() for ch in c) and _an_address(c) for c in cells)


def _an_address(text: str) -> bool:
    if _ADDRESS.match(text):
        return True
    try:
        read_address_cell(text if len(text) < 40 else text[:40])
    except (CellError, ValueError):
        return False
    return True


def _banded(rows: list[list[str]]) -> tuple[list[list[str]], bool]:
    """The first rows before the first holding an address-like cell, as one header row. A part that is
    one lower-case letter ends the word above it, broken without a hyphen in a narrow column
    (MENNEKES: 'Byte' / 's', 'Rang' / 'e' are 'Bytes', 'Range')."""
    n = 0
    while n < min(HEADER_ROWS, len(rows)) and not _is_data(rows[n]):
        n += 1
    if n == 0:
        return rows, False
    header = []
    for c in range(len(rows[0])):
        parts: list[str] = []
        for row in rows[:n]:
            if row[c] and parts and re.fullmatch(r"[a-z]", row[c]) and parts[-1][-1:].isalpha():
                parts[-1] += row[c]
            elif row[c] and (not parts or parts[-1] != row[c]):
                parts.append(row[c])
        header.append(re.sub(r"(?<=[a-z])- (?=[a-z])", "", " ".join(parts)))
    return [header, *rows[n:]], True


def _within(inner: tuple[float, ...], outer: tuple[float, ...]) -> bool:
    return inner != outer and all(
        (a >= b - 1) if i < 2 else (a <= b + 1) for i, (a, b) in enumerate(zip(inner, outer, strict=True))
    )


def _found(page: Page, number: int, path: Path) -> list[_Found]:
    """The page's tables from top to bottom; a table drawn inside another (a header cell's own box, which
    pdfplumber also finds as a table) is part of it, not a table."""
    from pdfplumber.table import TableFinder

    out = []
    tables = TableFinder(page).tables  # type: ignore[arg-type]  # it reads chars, edges, bbox: Page has them
    boxes = [tuple(float(x) for x in t.bbox) for t in tables]
    for table in sorted(tables, key=lambda t: (t.bbox[1], t.bbox[0])):
        if any(_within(tuple(float(x) for x in table.bbox), box) for box in boxes):
            continue
        grid = _grid(table, page.texts(table), path, number)
        rows, spread = _continued([r for r in _columns(grid) if any(text for text, _ in r)])
        if not rows:
            continue
        rows, banded = _banded(rows)
        top, bottom = float(table.bbox[1]), float(table.bbox[3])
        key = (round(top), round(bottom), tuple(tuple(r) for r in rows))
        out.append(_Found(number, top, bottom, float(page.height), rows, spread, banded, key, _spans(grid)))
    return out


def _goes_on(before: PdfTable, last: _Found, found: _Found) -> bool:
    """Whether `found`, the first table of its page, continues `before` (whose last part, on the page
    before, was that page's last table): as many columns, the first ending low on its page and the
    second starting high on its own. Whether it repeats the header or not (the first rows of a page
    may be the end of a row wrapped over the page's end)."""
    if found.page != last.page + 1 or len(found.rows[0]) != before.columns:
        return False
    return last.bottom >= last.height * 0.6 and found.top <= found.height * 0.4


def _wrapped_end(before: PdfTable, last: _Found, found: _Found) -> list[int] | None:
    """The columns of `before` under the cells of `found`, when `found` (the first table of its page)
    is the end of `before`'s last row wrapped over the page break with only its longest cell going on
    (MENNEKES p4: 'charge) 28 = C2 (charging) 29 = D2' ends p3's CP-State description): one row, no
    address, fewer columns than `before`, each under one column of `last` (its part on the page
    before). None when it is not. A table drawn whole after it on the page is a table of its own."""
    if found.page != last.page + 1 or len(found.rows) != 1 or _is_data(found.rows[0]) or not before.rows:
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


def _lay_out(pdf: Any, numbers: tuple[int, ...], path: Path) -> tuple[dict[int, list[_Found]], list[int]]:
    """The tables found on each of the pages, and the pages without text."""
    import pypdfium2 as pdfium

    found: dict[int, list[_Found]] = {}
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
            found[number] = _found(page, number, path)
        finally:
            raw.close()
    return found, blank


def _running(found: _Found, repeated: dict[tuple[object, ...], int]) -> bool:
    """Whether a table is a running header or footer (or a page number in a box): a few rows, the same
    text at the same place on three pages or more. A longer table printed again and again (the same
    bits for three status registers) is the manual's content."""
    return repeated[found.key] >= 3 and len(found.rows) <= RUNNING_ROWS


def _repeats_header(before: PdfTable, found: _Found) -> bool:
    return found.banded and [normalize_header(c) for c in found.rows[0]] == [normalize_header(c) for c in before.header]


def _restarts(before: PdfTable, found: _Found) -> bool:
    """Whether `found` repeats `before`'s header and then starts again at the address `before` started
    at: a table of its own that happens to begin at the top of the page after `before` ended low on its
    own (Lambda's heat pump manual: one table per module, each numbered from 00, the boiler's on the
    page after the heat pump's). The address column is the one whose address-like cells differ on every
    row of `before` (a block label or register type merged over the rows repeats)."""
    if not _repeats_header(before, found) or len(found.rows) < 2:
        return False
    data = [row.cells for row in before.rows if _is_data(row.cells)]
    for c in range(before.columns):
        cells = [row[c] for row in data if c < len(row) and row[c] and _is_data([row[c]])]
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
        found: dict[int, list[_Found]] = {}
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
    last: _Found | None = None
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
                if _repeats_header(current, f):
                    rows = rows[1:]  # the header repeated
                    row_on_page += 1
            else:
                current = PdfTable(number, number, len(rows[0]), header=rows[0] if f.banded else [])
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
