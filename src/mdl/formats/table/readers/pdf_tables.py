"""The tables of one page of a PDF manual (readers/pdf.py reads the document): pdfplumber's table finder on
the page's characters and ruled lines (readers/pdf_layout.py), the bands of a table drawn without rules
and shaded every other row joined, and each table's grid made rows of cells (the rules are pdf.py's
docstring's: narrowest columns, titles across the table left out of the header, merged cells read on
each row they cover, wrapped rows joined, the header band).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mdl.diagnostics import error
from mdl.formats.table.cells import CellError, read_address_cell
from mdl.formats.table.readers.delimited import MAX_CELL_CHARS
from mdl.formats.table.readers.pdf_layout import Page

HEADER_ROWS = 4  # rows a header may run over
_ADDRESS = re.compile(r"^(0x)?[0-9a-f]{1,6}h?(\s*[-~～]\s*(0x)?[0-9a-f]{1,6}h?)?$", re.IGNORECASE)
_HYPHEN = re.compile(r"(?<=[a-z])-\n(?=[a-z])")


@dataclass
class Found:
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


def _titles(grid: list[list[tuple[Any, str, bool]]], spans: list[tuple[float, float]]) -> set[str]:
    """Texts of cells drawn over more than half of the table's columns (and two at least): a title over
    the table or a group (`Read Input Register`, `First group`, `P00 Product Information Area`), never
    one column's header (inverters: the title joined the header of the column under its middle)."""
    out = set()
    for row in grid:
        for box, text, spread in row:
            if text and not spread:
                over = sum(1 for left, right in spans if box[0] - 1 <= (left + right) / 2 <= box[2] + 1)
                if over >= 2 and over * 2 > len(spans):
                    out.add(text)
    return out


def _continued(rows: list[list[tuple[str, bool]]]) -> tuple[list[list[str]], int]:
    """Rows of texts: a row whose address-like cells all come from a cell merged over it from above (a
    description wrapped over several rows of the drawing) is not a row of its own: its own texts are
    joined to the row above. Also how many cells were read on rows below their own."""
    out: list[list[str]] = []
    spread = 0
    for cells in rows:
        texts = [text for text, _ in cells]
        addresses = [text for text in texts if is_data([text])]
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
    if len(own) != 1 or not is_data([cells[own[0]][0]]) or not is_data([above[own[0]]]):
        return False
    return all(text == above[k] for k, (text, s) in enumerate(cells) if text and s)


def is_data(cells: list[str]) -> bool:
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


def _banded(rows: list[list[str]], titles: frozenset[str] | set[str] = frozenset()) -> tuple[list[list[str]], bool]:
    """The first rows before the first holding an address-like cell, as one header row. A part that is
    one lower-case letter ends the word above it, broken without a hyphen in a narrow column
    (MENNEKES: 'Byte' / 's', 'Rang' / 'e' are 'Bytes', 'Range'). A title drawn over the table's
    columns (`titles`) is no column's header and is left out of it, where the header has cells besides."""
    n = 0
    while n < min(HEADER_ROWS, len(rows)) and not is_data(rows[n]):
        n += 1
    if n == 0:
        return rows, False
    if sum(1 for c in range(len(rows[0])) if any(row[c] and row[c] not in titles for row in rows[:n])) < 2:
        titles = frozenset()  # no header besides: the end of a row wrapped over the page break, say
    header = []
    for c in range(len(rows[0])):
        parts: list[str] = []
        for row in rows[:n]:
            if not row[c] or row[c] in titles:
                continue
            if parts and re.fullmatch(r"[a-z]", row[c]) and parts[-1][-1:].isalpha():
                parts[-1] += row[c]
            elif not parts or parts[-1] != row[c]:
                parts.append(row[c])
        header.append(re.sub(r"(?<=[a-z])- (?=[a-z])", "", " ".join(parts)))
    return [header, *rows[n:]], True


def _within(inner: tuple[float, ...], outer: tuple[float, ...]) -> bool:
    return inner != outer and all(
        (a >= b - 1) if i < 2 else (a <= b + 1) for i, (a, b) in enumerate(zip(inner, outer, strict=True))
    )


def tables_on_page(page: Page, number: int, path: Path) -> list[Found]:
    """The page's tables from top to bottom; a table drawn inside another (a header cell's own box, which
    pdfplumber also finds as a table) is part of it, not a table; a table drawn as shaded bands (_striped)
    is one table with the rows between its bands."""
    from pdfplumber.table import TableFinder

    out = []
    tables = TableFinder(page).tables  # type: ignore[arg-type]  # it reads chars, edges, bbox: Page has them
    boxes = [tuple(float(x) for x in t.bbox) for t in tables]
    kept = [t for t in tables if not any(_within(tuple(float(x) for x in t.bbox), box) for box in boxes)]
    for table in _striped(page, sorted(kept, key=lambda t: (t.bbox[1], t.bbox[0]))):
        grid = _grid(table, page.texts(table), path, number)
        spans = _spans(grid)
        rows, spread = _continued([r for r in _columns(grid) if any(text for text, _ in r)])
        if not rows:
            continue
        rows, banded = _banded(rows, _titles(grid, spans))
        top, bottom = float(table.bbox[1]), float(table.bbox[3])
        key = (round(top), round(bottom), tuple(tuple(r) for r in rows))
        out.append(Found(number, top, bottom, float(page.height), rows, spread, banded, key, spans))
    return out


def _edges(*tables: Any) -> list[float]:
    """The x of the tables' column rules: their cells' left and right edges, those within 1.5 pt one."""
    out: list[float] = []
    for x in sorted({float(c[0]) for t in tables for c in t.cells} | {float(c[2]) for t in tables for c in t.cells}):
        if not out or x - out[-1] > 1.5:
            out.append(x)
    return out


def _same_columns(a: Any, b: Any) -> bool:
    """Whether two tables are drawn on the same column rules: four at least, the first the same, and every
    rule of the one with fewer on a rule of the other (a band may leave out a column whose cell is drawn
    over several rows, as SRNE's remarks over a week's registers)."""
    few, many = sorted((_edges(a), _edges(b)), key=len)
    return len(few) >= 4 and abs(few[0] - many[0]) <= 1.5 and all(any(abs(x - y) <= 1.5 for y in many) for x in few)


def _striped(page: Any, tables: list[Any]) -> list[Any]:
    """Tables (top to bottom) with the bands of a striped table made one: a table drawn with no rules,
    every other row on a shaded band (SRNE's inverter manual), is found as one table per band, and the
    rows between the bands are no table at all. Tables one under another on the same column rules, two
    of them a band of one row with an address in its first cell at least (not the header bands of two
    tables one under the other: Sungrow's appendices), are one table: its cells are theirs, and the
    rows in each gap between two of them (_gap_rows) are rows of it, cut at the same column rules."""
    from pdfplumber.table import Table

    out: list[Any] = []
    run: list[Any] = []

    def close() -> None:
        if len(run) >= 2 and sum(1 for t in run if len(t.rows) == 1 and _first_cell_address(page, t)) >= 2:
            out.append(_one_table(page, run, Table))
        else:
            out.extend(run)
        run.clear()

    for table in tables:
        if run and not (_same_columns(table, run[-1]) and float(table.bbox[1]) >= float(run[-1].bbox[3]) - 1):
            close()
        run.append(table)
    close()
    return out


def _first_cell_address(page: Any, table: Any) -> bool:
    """Whether the first cell of a table's first row holds an address (its characters, left to right)."""
    x0, top, x1, bottom = min(table.rows[0].cells, key=lambda c: c[0] if c else float("inf")) or table.bbox
    inside = [
        ch
        for ch in page.chars
        if x0 <= (ch["x0"] + ch["x1"]) / 2 < x1 and top <= (ch["top"] + ch["bottom"]) / 2 < bottom
    ]
    text = "".join(ch["text"] for ch in sorted(inside, key=lambda ch: ch["x0"])).strip()
    return is_data([text])


def _one_table(page: Any, run: list[Any], table_type: Any) -> Any:
    """The tables of `run` (bands of one striped table, top to bottom) as one table: every cell's edges
    put on the run's column rules, and the rows in each gap between two bands (_gap_rows) cut at them
    (a title across the columns: one cell over them all)."""
    edges = _edges(*run)

    def snap(x: float) -> float:
        return min(edges, key=lambda e: abs(e - float(x)))

    cells: list[tuple[float, float, float, float]] = []
    for k, table in enumerate(run):
        cells.extend((snap(c[0]), float(c[1]), snap(c[2]), float(c[3])) for c in table.cells)
        if k + 1 < len(run):
            for top, bottom, title in _gap_rows(page, float(table.bbox[3]), float(run[k + 1].bbox[1]), edges):
                if title:
                    cells.append((edges[0], top, edges[-1], bottom))
                else:
                    cells.extend((a, top, b, bottom) for a, b in zip(edges, edges[1:], strict=False))
    return table_type(page, cells)


def _gap_rows(page: Any, top: float, bottom: float, edges: list[float]) -> list[tuple[float, float, bool]]:
    """The rows of a striped table between two of its bands, (top, bottom, whether a title) of each: one
    row, unless the gap holds a title drawn across the columns on a band of its own (a line with a word
    over a column rule: `P08 Setting Area for ...`), which is a row of its own between the rows above and
    below it, or more than one address in the first column, cut half way between them. No text: no row."""
    inner = edges[1:-1]
    chars = sorted(
        (
            ch
            for ch in page.chars
            if ch["text"].strip()
            and edges[0] <= (ch["x0"] + ch["x1"]) / 2 < edges[-1]
            and top <= (ch["top"] + ch["bottom"]) / 2 < bottom
        ),
        key=lambda ch: ((ch["top"] + ch["bottom"]) / 2, ch["x0"]),
    )
    lines: list[list[Any]] = []
    for ch in chars:
        middle = (ch["top"] + ch["bottom"]) / 2
        if lines and middle - (lines[-1][0]["top"] + lines[-1][0]["bottom"]) / 2 < 2:
            lines[-1].append(ch)
        else:
            lines.append([ch])

    def over_a_rule(line: list[Any]) -> bool:
        xs = sorted(line, key=lambda ch: ch["x0"])
        return any(
            a["x0"] + 0.5 < e < a["x1"] - 0.5 or (b["x0"] - a["x1"] < 0.5 and a["x1"] - 0.5 <= e <= b["x0"] + 0.5)
            for a, b in zip(xs, xs[1:], strict=False)
            for e in inner
        )

    rows: list[tuple[float, float, bool]] = []
    segment: list[list[Any]] = []
    start = top

    def close(until: float) -> None:
        nonlocal start
        addresses = [ln for ln in segment if any((ch["x0"] + ch["x1"]) / 2 < edges[1] for ch in ln)]
        for a, b in zip(addresses, addresses[1:], strict=False):
            cut = (max(ch["bottom"] for ch in a) + min(ch["top"] for ch in b)) / 2
            rows.append((start, cut, False))
            start = cut
        if segment:
            rows.append((start, until, False))
            start = until
        segment.clear()

    for line in lines:
        if over_a_rule(line):
            high, low = min(ch["top"] for ch in line) - 0.5, max(ch["bottom"] for ch in line) + 0.5
            close(high)
            rows.append((start, low, True))
            start = low
        else:
            segment.append(line)
    close(bottom)
    if rows and rows[-1][1] < bottom:
        rows[-1] = (rows[-1][0], bottom, rows[-1][2])
    return [r for r in rows if r[1] - r[0] > 0.5]
