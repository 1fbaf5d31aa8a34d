"""HTML tables as a browser shows them, with Python's html.parser: every `<table>` of the page (nested
ones apart from the table around them), `<th>`/`<td>` cells with their line and column, `<br>` and
block elements as line breaks, other whitespace collapsed, tags, scripts and styles dropped; a
`colspan` cell fills its first column, a `rowspan` cell's text is read on each row it spans."""

from __future__ import annotations

from dataclasses import dataclass, field
from html.parser import HTMLParser

MAX_COLSPAN = 1000  # the HTML standard's own limits
MAX_ROWSPAN = 65534
_BLOCKS = frozenset(("p", "div", "li", "ul", "ol", "dl", "dt", "dd", "h1", "h2", "h3", "h4", "h5", "h6", "pre"))
_HIDDEN = frozenset(("script", "style"))  # html.parser reads their content as raw text up to the end tag


@dataclass
class Cell:
    line: int
    col: int
    colspan: int = 1
    rowspan: int = 1
    parts: list[str | None] = field(default_factory=list)  # text; None: a line break

    def text(self) -> str:
        lines: list[str] = []
        current: list[str] = []
        for part in [*self.parts, None]:
            if part is None:
                lines.append(" ".join("".join(current).split()))
                current = []
            else:
                current.append(part)
        return "\n".join(line for line in lines if line)


@dataclass
class HtmlTable:
    line: int
    col: int
    rows: list[list[Cell]] = field(default_factory=list)
    open_row: list[Cell] | None = None
    open_cell: Cell | None = None

    def close_cell(self) -> None:
        if self.open_cell is not None:
            if self.open_row is None:
                self.open_row = []
            self.open_row.append(self.open_cell)
            self.open_cell = None

    def close_row(self) -> None:
        self.close_cell()
        if self.open_row:
            self.rows.append(self.open_row)
        self.open_row = None


def _span(value: str | None, limit: int) -> int:
    try:
        n = int((value or "1").strip())
    except ValueError:
        return 1
    if n == 0 and limit == MAX_ROWSPAN:
        return limit  # rowspan=0: to the end of the table
    return min(max(n, 1), limit)


class _Parser(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tables: list[HtmlTable] = []
        self.open: list[HtmlTable] = []
        self.hidden = 0

    def _cell(self) -> Cell | None:
        return self.open[-1].open_cell if self.open else None

    def _break(self) -> None:
        cell = self._cell()
        if cell is not None:
            cell.parts.append(None)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag in _HIDDEN:
            self.hidden += 1
            return
        line, offset = self.getpos()
        if tag == "table":
            self._break()  # a table inside a cell is apart from the cell's text
            table = HtmlTable(line, offset + 1)
            self.tables.append(table)
            self.open.append(table)
        elif not self.open:
            return
        elif tag == "tr":
            self.open[-1].close_row()
            self.open[-1].open_row = []
        elif tag in ("td", "th"):
            table = self.open[-1]
            table.close_cell()
            given = dict(attrs)
            colspan, rowspan = _span(given.get("colspan"), MAX_COLSPAN), _span(given.get("rowspan"), MAX_ROWSPAN)
            table.open_cell = Cell(line, offset + 1, colspan, rowspan)
        elif tag == "br" or tag in _BLOCKS:
            self._break()

    def handle_endtag(self, tag: str) -> None:
        if tag in _HIDDEN:
            self.hidden = max(self.hidden - 1, 0)
            return
        if not self.open:
            return
        if tag == "table":
            self.open.pop().close_row()
            self._break()
        elif tag == "tr":
            self.open[-1].close_row()
        elif tag in ("td", "th"):
            self.open[-1].close_cell()
        elif tag in _BLOCKS:
            self._break()

    def handle_data(self, data: str) -> None:
        cell = self._cell()
        if cell is not None and not self.hidden:
            cell.parts.append(data)


def html_tables(text: str) -> list[HtmlTable]:
    """Every table of the page, in the order they start."""
    parser = _Parser()
    parser.feed(text)
    parser.close()
    for table in parser.open:
        table.close_row()
    return [t for t in parser.tables if t.rows]


@dataclass
class Grid:
    """A table's rows as text, with the rowspan cells read again on the rows they span."""

    rows: list[list[str]]
    spanned: list[Cell]  # the rowspan cells with text
    lines: list[int]  # each row's line: that of its first own cell (not of a rowspan cell from above)


def _fill(texts: list[str], pending: dict[int, tuple[str, int]]) -> None:
    """Put the rowspan cells from above that stand at the row's next columns."""
    while len(texts) in pending:
        text, left = pending.pop(len(texts))
        if left > 1:
            pending[len(texts)] = (text, left - 1)
        texts.append(text)


def size(table: HtmlTable) -> int:
    """At least as many cells as grid(table) lays out (each spanning cell counted for every place it
    covers), found without laying them out: a few bytes of colspan/rowspan could ask for millions."""
    n = len(table.rows)
    return sum(cell.colspan * min(cell.rowspan, n - i) for i, cells in enumerate(table.rows) for cell in cells)


def grid(table: HtmlTable) -> Grid:
    rows: list[list[str]] = []
    spanned: list[Cell] = []
    pending: dict[int, tuple[str, int]] = {}  # column -> the text of a rowspan cell over it, rows it still covers
    for cells in table.rows:
        texts: list[str] = []
        for cell in cells:
            _fill(texts, pending)
            for k in range(cell.colspan):
                text = cell.text() if k == 0 else ""
                if cell.rowspan > 1:
                    pending[len(texts)] = (text, cell.rowspan - 1)
                    if text and k == 0:
                        spanned.append(cell)
                texts.append(text)
        while pending and max(pending) >= len(texts):
            _fill(texts, pending)
            if len(texts) not in pending and max(pending, default=-1) >= len(texts):
                texts.append("")
        rows.append(texts)
    return Grid(rows, spanned, [cells[0].line for cells in table.rows])
