"""HTML tables as a browser shows them: every `<table>` of the page (nested ones apart from the table
around them), `<th>`/`<td>` cells with their line and column, `<br>` and block elements as line
breaks, other whitespace collapsed, tags, comments, scripts and styles dropped; a `colspan` cell fills
its first column, a `rowspan` cell's text is read on each row it spans.

The page is read by a tokenizer of its own, after the HTML standard's: each step moves on past what
it looked at (a tag, comment or quoted value left open runs to the end of the page, where it is
dropped), so reading takes time in proportion to the page, whatever it holds; Python's html.parser
looks again from every `<` a tag left open follows, which a few kilobytes make minutes."""

from __future__ import annotations

import html
import re
from collections.abc import Iterator
from dataclasses import dataclass, field

MAX_COLSPAN = 1000  # the HTML standard's own limits
MAX_ROWSPAN = 65534
_BLOCKS = frozenset(("p", "div", "li", "ul", "ol", "dl", "dt", "dd", "h1", "h2", "h3", "h4", "h5", "h6", "pre"))
_HIDDEN = frozenset(("script", "style"))  # their content is raw text up to their end tag, not shown


@dataclass
class Cell:
    line: int
    col: int
    colspan: int = 1
    rowspan: int = 1
    parts: list[str | None] = field(default_factory=list)  # text; None: a line break
    shown: str | None = None  # the text, once made

    def text(self) -> str:
        if self.shown is None:
            self.shown = self._text()
        return self.shown

    def _text(self) -> str:
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


_SPACE = "\t\n\f\r "
_NAME = re.compile(r"[A-Za-z][^\t\n\f\r />]*")
_SKIP = re.compile(r"[\t\n\f\r /]*")
_ATTRIBUTE = re.compile(r"[^\t\n\f\r />][^\t\n\f\r /=>]*")
_EQUALS = re.compile(r"[\t\n\f\r ]*=[\t\n\f\r ]*")
_BARE = re.compile(r"[^\t\n\f\r >]*")
_COMMENT_END = re.compile(r"--!?>")
_RAW_END = {tag: re.compile(rf"</{tag}(?=[\t\n\f\r />])", re.I) for tag in _HIDDEN}


@dataclass
class _Tag:
    name: str
    end: bool  # an end tag
    at: int  # the offset of its `<`
    attrs: dict[str, str | None]
    closes_itself: bool = False  # `<br/>`: a start tag and its end


def _tag(text: str, at: int, end: bool) -> tuple[_Tag, int] | None:
    """The tag whose `<` is at `at` and the offset after its `>`; None when the page ends first (the
    standard drops such a tag). Attribute values in quotes may hold `>`."""
    name = _NAME.match(text, at + (2 if end else 1))
    assert name is not None, "a tag's name starts with a letter"
    tag = _Tag(name.group().lower(), end, at, {})
    i = name.end()
    while True:
        skipped = i
        i = _SKIP.match(text, i).end()  # type: ignore[union-attr]
        if i >= len(text):
            return None
        if text[i] == ">":
            tag.closes_itself = i > skipped and text[i - 1] == "/"
            return tag, i + 1
        key = _ATTRIBUTE.match(text, i)
        assert key is not None, "_SKIP stops at an attribute's first character"
        i, value = key.end(), None
        equals = _EQUALS.match(text, i)
        if equals:
            i = equals.end()
            quote = text[i : i + 1]
            if quote in ("'", '"'):
                close = text.find(quote, i + 1)
                if close < 0:
                    return None
                value, i = html.unescape(text[i + 1 : close]), close + 1
            else:
                bare = _BARE.match(text, i)
                assert bare is not None, "_BARE matches the empty string"
                value, i = html.unescape(bare.group()), bare.end()
        tag.attrs.setdefault(key.group().lower(), value)


def _tokens(text: str) -> Iterator[_Tag | str]:
    """The page's tags and text (character references read), comments and the content of scripts and
    styles left out, each found by one scan forward."""
    i, n = 0, len(text)
    while i < n:
        at = text.find("<", i)
        if at < 0:
            yield html.unescape(text[i:])
            return
        if at > i:
            yield html.unescape(text[i:at])
        after = text[at + 1 : at + 3]
        first, second = after[:1], after[1:]
        if first.isascii() and first.isalpha() or first == "/" and second.isascii() and second.isalpha():
            found = _tag(text, at, first == "/")
            if found is None:
                return
            tag, i = found
            yield tag
            if tag.name in _RAW_END and not tag.end and not tag.closes_itself:
                raw_end = _RAW_END[tag.name].search(text, i)
                i = raw_end.start() if raw_end else n
        elif text.startswith("<!--", at):
            if text.startswith(">", at + 4) or text.startswith("->", at + 4):
                i = text.index(">", at + 4) + 1
            else:
                comment_end = _COMMENT_END.search(text, at + 4)
                i = comment_end.end() if comment_end else n
        elif first in ("!", "?") or first == "/" and second not in ("", ">"):
            close = text.find(">", at + 2)  # a declaration, a processing instruction: shown as nothing
            i = close + 1 if close >= 0 else n
        elif after == "/>":
            i = at + 3
        else:
            yield "<"  # a `<` that starts no tag is text
            i = at + 1


class _Builder:
    """The tables of the page from its tokens, as a browser builds them."""

    def __init__(self, text: str) -> None:
        self.tables: list[HtmlTable] = []
        self.open: list[HtmlTable] = []
        self.text = text
        self.seen, self.line, self.line_start = 0, 1, 0  # offset counted up to, its line, where that line starts

    def position(self, at: int) -> tuple[int, int]:
        """The line and column (both from 1) of an offset of the page (at or after the one asked before):
        each stretch of the page is looked at once, a one-line (minified) page too."""
        breaks = self.text.count("\n", self.seen, at)
        if breaks:
            self.line += breaks
            self.line_start = self.text.rfind("\n", self.seen, at) + 1
        self.seen = at
        return self.line, at - self.line_start + 1

    def _cell(self) -> Cell | None:
        return self.open[-1].open_cell if self.open else None

    def _break(self) -> None:
        cell = self._cell()
        if cell is not None:
            cell.parts.append(None)

    def start(self, tag: _Tag) -> None:
        name = tag.name
        if name in _HIDDEN:
            return
        if name == "table":
            self._break()  # a table inside a cell is apart from the cell's text
            table = HtmlTable(*self.position(tag.at))
            self.tables.append(table)
            self.open.append(table)
        elif not self.open:
            return
        elif name == "tr":
            self.open[-1].close_row()
            self.open[-1].open_row = []
        elif name in ("td", "th"):
            table = self.open[-1]
            table.close_cell()
            colspan, rowspan = (
                _span(tag.attrs.get("colspan"), MAX_COLSPAN),
                _span(tag.attrs.get("rowspan"), MAX_ROWSPAN),
            )
            table.open_cell = Cell(*self.position(tag.at), colspan, rowspan)
        elif name == "br" or name in _BLOCKS:
            self._break()

    def end(self, name: str) -> None:
        if not self.open or name in _HIDDEN:
            return
        if name == "table":
            self.open.pop().close_row()
            self._break()
        elif name == "tr":
            self.open[-1].close_row()
        elif name in ("td", "th"):
            self.open[-1].close_cell()
        elif name in _BLOCKS:
            self._break()

    def data(self, data: str) -> None:
        cell = self._cell()
        if cell is not None:
            cell.parts.append(data)


def html_tables(text: str) -> list[HtmlTable]:
    """Every table of the page, in the order they start."""
    builder = _Builder(text)
    for token in _tokens(text):
        if isinstance(token, str):
            builder.data(token)
        elif token.end:
            builder.end(token.name)
        else:
            builder.start(token)
            if token.closes_itself:
                builder.end(token.name)
    for table in builder.open:
        table.close_row()
    return [t for t in builder.tables if t.rows]


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
        for column in sorted(c for c in pending if c >= len(texts)):  # rowspan cells past the row's own
            if column >= len(texts):
                texts.extend([""] * (column - len(texts)))
                _fill(texts, pending)
        rows.append(texts)
    return Grid(rows, spanned, [cells[0].line for cells in table.rows])
