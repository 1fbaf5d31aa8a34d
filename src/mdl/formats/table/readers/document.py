"""Tables as vendors publish them beside CSV: Markdown pipe tables (.md), HTML tables (.html, .htm),
Excel workbooks (.xlsx) and PDF manuals (.pdf). A document may hold several tables (or sheets): the one
read is the one `--table N` / `--sheet NAME` names, else the first whose header holds every column the
INI names by its header text, else the first whose header holds an address column, and a note says
which. Each becomes a `Table` of rows with the lines messages name: the file's lines (Markdown, HTML),
the sheet's row numbers (Excel), or a PDF's pages and rows (`p14:r7`)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from pathlib import Path

from mdl.diagnostics import MdlError, error
from mdl.fileio import read_bytes
from mdl.formats.table.readers.delimited import (
    MAX_CELL_CHARS,
    Row,
    Table,
    cell_too_long,
    decode_table,
    find_header,
    header_key,
)

MARKDOWN = (".md", ".markdown")
HTML = (".html", ".htm", ".xhtml")
EXCEL = (".xlsx", ".xlsm", ".xls", ".ods")
PDF = (".pdf",)
LISTED = 8  # tables an error lists with their first cells
MAX_CELLS = 1_000_000  # of one table, or of a workbook's sheets together: a register table has thousands
MAX_PAGE_BYTES = 32_000_000  # of a Markdown or HTML file: a vendor's page of register tables has a few MB


@dataclass(frozen=True)
class Choice:
    """--table N (1-based) or --sheet NAME as the command line gave them, or the INI's `table`/`sheet`
    keys of [Input/Output] (`where`: the INI and the key's line, where a refusal points)."""

    table: int | None = None
    sheet: str | None = None
    where: tuple[Path, int | None] | None = None
    pages: str | None = None  # --pages 12-19, or the INI's pages = (a PDF's pages to read)
    pages_where: tuple[Path, int | None] | None = None  # the INI and the line of its pages = key
    columns: tuple[str, ...] = ()  # the header texts the INI names columns by: they choose the table

    def said(self, option: str) -> str:
        """How messages name the choice: `--table 2`, or `table = 2 in the INI`."""
        value = self.table if option == "--table" else repr(self.sheet)
        return f"{option} {value}" if self.where is None else f"{option[2:]} = {value} in the INI"

    def fail(self, message: str, path: Path) -> MdlError:
        """An error at the INI line that chose, else about the table's file."""
        return error(message, *self.where) if self.where is not None else error(message, path)

    def pages_said(self, in_ini: str = "") -> str:
        """How messages name the pages chosen: `--pages 12-19`, or `pages = 12-19` (and `in_ini`)."""
        return f"--pages {self.pages}" if self.pages_where is None else f"pages = {self.pages}{in_ini}"

    def pages_fail(self, message: str, path: Path) -> MdlError:
        """An error at the INI's pages = line, else about the file."""
        return error(message, *self.pages_where) if self.pages_where is not None else error(message, path)


_CHOICE: ContextVar[Choice | None] = ContextVar("table_choice", default=None)


@contextmanager
def chosen(table: int | None, sheet: str | None, pages: str | None = None) -> Iterator[None]:
    """While converting, read the table or sheet (and a PDF's pages) the command line chose."""
    token = _CHOICE.set(Choice(table, sheet, pages=pages))
    try:
        yield
    finally:
        _CHOICE.reset(token)


@contextmanager
def ini_choice(
    table: int | None,
    sheet: str | None,
    where: tuple[Path, int | None],
    pages: tuple[str, tuple[Path, int | None]] | None = None,
    columns: tuple[str, ...] = (),
) -> Iterator[list[str]]:
    """While reading the table, the INI's `table`/`sheet` and `pages` (its value and where it stands)
    choose unless the command line chose, and the header texts its [Column/Field Indices] names choose
    among tables; yields a note for each choice of the INI that the command line overrides."""
    given = _CHOICE.get() or Choice()
    notes = []
    choice = Choice(given.table, given.sheet, given.where, given.pages, None, columns)
    if table is not None or sheet is not None:
        if given.table is not None or given.sheet is not None:
            option, value = ("--table", given.table) if given.table is not None else ("--sheet", repr(given.sheet))
            key, kept = ("table", table) if table is not None else ("sheet", repr(sheet))
            notes.append(f"{option} {value} is read instead of the INI's {key} = {kept}")
        else:
            choice = replace(choice, table=table, sheet=sheet, where=where)
    if pages is not None:
        if given.pages is not None:
            notes.append(f"--pages {given.pages} is read instead of the INI's pages = {pages[0]}")
        else:
            choice = replace(choice, pages=pages[0], pages_where=pages[1])
    token = _CHOICE.set(choice)
    try:
        yield notes
    finally:
        _CHOICE.reset(token)


def is_document(path: Path, delimiter: str | None = None) -> bool:
    """Whether read_document reads the file: a .md with a delimiter given in the INI is read as a CSV."""
    suffix = path.suffix.lower()
    return suffix in HTML + EXCEL + PDF or (suffix in MARKDOWN and delimiter is None)


def refuse_choice(path: Path) -> None:
    """A CSV holds one table: a table or sheet chosen for one is a mistake, not something to ignore."""
    choice = _CHOICE.get() or Choice()
    if choice.table is not None or choice.sheet is not None:
        option = "--table" if choice.table is not None else "--sheet"
        raise choice.fail(
            f"{choice.said(option)} chooses among the tables of a .md, .html, .xlsx or .pdf file; "
            f"{path.name} is read as one CSV table",
            path,
        )
    refuse_pages(path)


def refuse_pages(path: Path) -> None:
    """Pages are a PDF's: --pages (or pages =) for another kind of file is a mistake, not something to ignore."""
    choice = _CHOICE.get() or Choice()
    if choice.pages is not None:
        raise choice.pages_fail(
            f"{choice.pages_said(' in the INI')} chooses pages of a PDF manual; {path.name} has no pages", path
        )


@dataclass
class Candidate:
    label: str  # how notes name it: "table 2 (line 14, column 3)", "sheet 'Registers'"
    name: str  # how --table/--sheet name it
    rows: list[Row]
    notes: list[str] = field(default_factory=list)  # said if it is the one read
    places: dict[int, str] = field(default_factory=dict)  # a PDF's rows: line -> `p14:r7`


def _header_of(path: Path, c: Candidate) -> Row | None:
    return find_header(Table(path, "", c.rows))


def _holds(path: Path, c: Candidate, texts: tuple[str, ...]) -> bool:
    """Whether a row among the candidate's first holds every one of the INI's header texts."""
    header = find_header(Table(path, "", c.rows), None, list(texts))
    wanted = {header_key(t) for t in texts}
    return header is not None and wanted <= {header_key(x) for x in header.cells}


def _first_texts(c: Candidate) -> str:
    cells = [" ".join(x.split()) for x in c.rows[0].cells if x.strip()][:4] if c.rows else []
    return ", ".join(repr(x[:30]) for x in cells) or "no cells"


def pick(path: Path, candidates: list[Candidate], what: str, option: str) -> Candidate:
    """The candidate the command line names, else the first whose header holds an address column."""
    choice = _CHOICE.get() or Choice()
    if not candidates:
        raise error(f"no {what} with cells in the file", path)
    listing = "; ".join(f"{c.label}: {_first_texts(c)}" for c in candidates[:LISTED])
    listing += f"; and {len(candidates) - LISTED} more" if len(candidates) > LISTED else ""
    wanted = choice.sheet if option == "--sheet" and choice.sheet is not None else None
    if option == "--table" and choice.sheet is not None:
        raise choice.fail(
            f"{choice.said('--sheet')} chooses a sheet of an Excel workbook; choose a table of this file by "
            "its number (--table N, or table = N in [Input/Output])",
            path,
        )
    if wanted is not None:
        found = [c for c in candidates if c.name == wanted] or [
            c for c in candidates if c.name.casefold() == wanted.casefold()
        ]
        if not found:
            names = ", ".join(repr(c.name) for c in candidates)
            raise choice.fail(f"{choice.said('--sheet')}: the workbook has no such sheet (its sheets: {names})", path)
        return _said(found[0], f"the one {choice.said('--sheet')} names")
    if choice.table is not None:
        if not 1 <= choice.table <= len(candidates):
            raise choice.fail(
                f"{choice.said('--table')}: the file has {len(candidates)} {what}s with cells ({listing})", path
            )
        return _said(candidates[choice.table - 1], f"the one {choice.said('--table')} names")
    if choice.columns and len(candidates) > 1:
        holding = [c for c in candidates if _holds(path, c, choice.columns)]
        if holding:
            others = len(holding) - 1
            more = f" ({others} more hold them)" if others else ""
            return _said(
                holding[0], f"the first whose header holds the INI's column names{more}; {option} chooses another"
            )
    with_address = [c for c in candidates if _header_of(path, c) is not None]
    if with_address:
        first = with_address[0]
        why = "the only one" if len(candidates) == 1 else "the first whose header holds an address column"
        others = len(with_address) - 1
        more = f" ({others} more hold one)" if others else ""
        return _said(first, f"{why}{more}; {option} chooses another" if len(candidates) > 1 else why)
    if len(candidates) == 1:
        return _said(candidates[0], "the only one, though no header of it looks like an address column")
    raise error(
        f"no {what} has a header with an address column ('Address', 'Register', 'Reg No' ...); "
        f"choose one with {option} ({listing})",
        path,
    )


def _said(c: Candidate, why: str) -> Candidate:
    c.notes.insert(0, f"read {c.label}: {why}")
    return c


def read_document(path: Path, encoding: str | None) -> Table:
    """The chosen table of a Markdown, HTML or Excel file."""
    suffix = path.suffix.lower()
    places: dict[int, str] = {}
    if suffix in PDF:
        chosen_one = pick(path, _pdf_candidates(path), "PDF table", "--table")
        places = chosen_one.places
        guess = None
    elif suffix in EXCEL:
        refuse_pages(path)
        chosen_one = pick(path, _excel_candidates(path), "sheet", "--sheet")
        guess = None
    else:
        refuse_pages(path)
        text, guess = decode_table(read_bytes(path, MAX_PAGE_BYTES), path, encoding)
        if suffix in MARKDOWN:
            chosen_one = pick(path, _markdown_candidates(path, text), "Markdown table", "--table")
        else:
            chosen_one = pick(path, _html_candidates(path, text), "HTML table", "--table")
    table = Table(
        path,
        "|" if suffix in MARKDOWN else "",
        chosen_one.rows,
        delimiter_guessed=False,
        markdown=suffix in MARKDOWN,
        encoding_guess=guess,
    )
    table.notes = chosen_one.notes
    table.places = places
    return table


def _markdown_candidates(path: Path, text: str) -> list[Candidate]:
    from mdl.formats.table.readers.markdown import markdown_tables

    tables = enumerate(markdown_tables(text, path), 1)
    return [Candidate(f"table {n} (line {line})", str(n), rows) for n, (line, rows) in tables]


def _html_candidates(path: Path, text: str) -> list[Candidate]:
    from mdl.formats.table.readers.html import grid, html_tables, size

    out = []
    for n, table in enumerate(html_tables(text), 1):
        if size(table) > MAX_CELLS:
            raise error(f"the table has more than {MAX_CELLS:,} cells (colspan and rowspan counted)", path, table.line)
        for cell in (cell for cells in table.rows for cell in cells):
            if len(cell.text()) > MAX_CELL_CHARS:
                raise cell_too_long(path, cell.line, cell.col, len(cell.text()))
        g = grid(table)
        label = f"table {n} (line {table.line}, column {table.col})"
        lines = g.lines
        notes = []
        # rows sharing a line (a minified page): messages name its rows by number instead
        if any(b <= a for a, b in zip(lines, lines[1:], strict=False)):
            lines = list(range(1, len(lines) + 1))
            notes.append(
                f"rows of {label} share lines of the file: messages name its rows by number "
                f"(row 1 starts at line {table.rows[0][0].line}, column {table.rows[0][0].col})"
            )
        for cell in g.spanned[:1]:
            notes.append(
                f"the cell at line {cell.line}, column {cell.col} spans {cell.rowspan} rows (rowspan): "
                "its text is read on each of them, as is every such cell's"
            )
        rows = [Row(line, cells) for line, cells in zip(lines, g.rows, strict=True) if any(c.strip() for c in cells)]
        out.append(Candidate(label, str(n), rows, notes))
    return out


def _excel_candidates(path: Path) -> list[Candidate]:
    """The sheets of a workbook: .xlsx/.xlsm with openpyxl, .xls with xlrd, .ods (OpenDocument) alike."""
    from mdl.formats.table.readers.xlsx import cell_ref, open_book, read_sheet, sheet_names

    suffix = path.suffix.lower()
    if suffix == ".xls":
        from mdl.formats.table.readers.xls import read_xls

        sheets = read_xls(path)
    elif suffix == ".ods":
        from mdl.formats.table.readers.ods import read_ods

        sheets = read_ods(path)
    else:
        with open_book(path) as book:
            sheets = [read_sheet(path, book, name) for name in sheet_names(book)]
    out = []
    for sheet in sheets:
        name = sheet.name
        notes = [f"lines in messages are the sheet's row numbers (line 7 is row 7: {cell_ref(name, 'A7')}, B7 ...)"]
        if sheet.merged:
            notes.append(
                f"merged cell {cell_ref(name, sheet.merged[0])} covers several rows: its text is read on each "
                "of them, as is every such cell's"
            )
        rows = [Row(line, cells) for line, cells in sheet.rows]
        out.append(Candidate(f"sheet {name!r}", name, rows, notes))
    return [c for c in out if c.rows]


def _pdf_candidates(path: Path) -> list[Candidate]:
    from mdl.formats.table.readers.pdf import page_count, page_range, read_tables

    choice = _CHOICE.get() or Choice()
    pages = None
    if choice.pages is not None:
        try:
            pages = page_range(choice.pages, page_count(path), choice.pages_said())
        except ValueError as exc:
            raise choice.pages_fail(str(exc), path) from None
    out = []
    for n, table in enumerate(read_tables(path, pages), 1):
        notes = ["rows in messages are named by page and row: p14:r7 is the 7th table row on page 14"]
        if table.spread:
            notes.append(
                f"cells merged over several rows in table {n} are read on each row they cover ({table.spread} cells)"
            )
        out.append(Candidate(f"table {n} ({table.label})", str(n), table.rows, notes, table.places))
    return out
