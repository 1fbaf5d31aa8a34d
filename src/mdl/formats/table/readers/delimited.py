"""Reading a vendor's CSV as exported: delimiters, BOM, quoted line breaks, title/blank/comment rows."""

from __future__ import annotations

import codecs
import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

from mdl.diagnostics import MdlError, error
from mdl.fileio import decode_text, read_bytes

DELIMITERS = (",", ";", "\t", "|")
DELIMITER_NAMES = {",": "comma", ";": "semicolon", "\t": "tab", "|": "pipe"}

# column key -> header texts (normalized: lowercase, single spaces, no punctuation)
HEADER_SYNONYMS = {
    "addresses": [
        "address",
        "addr",
        "register",
        "reg",
        "reg no",
        "register no",
        "register number",
        "modbus address",
        "modbus register",
        "start address",
        "starting address",
        "offset address",
        "register address",
        "reg addr",
        "reg address",
        "adr",
        "adresse",
        "registro",
        "data address",
        "modbus addr",
        "pdu address",
        "address dec",
        "address decimal",
        "registre",
        "indirizzo",
        "point address",
        "modbus register address",
    ],
    "description": [
        "description",
        "register and description",
        "desc",
        "name and description",
        "parameter",
        "parameter name",
        "function",
        "meaning",
        "beschreibung",
        "bezeichnung",
        "descripcion",
        "description of register",
        "signal",
        "variable",
        "data point",
        "point",
        "quantity",
        "measurement",
        "item",
        "object",
    ],
    "name": [
        "name",
        "xml tag",
        "tag",
        "keyword",
        "keywords",
        "keyword list",
        "keyword list case insensitive",
        "symbol",
        "identifier",
        "id",
        "short name",
        "variable name",
        "point name",
        "field",
        "register name",
        "volttron point name",
        "reference name",
    ],
    "format": [
        "format",
        "data type",
        "datatype",
        "type",
        "data format",
        "value type",
        "ints",
        "typ",
        "datentyp",
        "format type",
        "variable type",
    ],
    "count": [
        "count",
        "bytes",
        "words",
        "length words",
        "no of registers",
        "number of registers",
        "registers",
        "size",
        "quantity of registers",
        "num registers",
        "reg count",
        "word count",
        "anzahl",
        "qty",
        "number of words",
        "length bytes",
        "byte count",
    ],
    "length": ["length", "length info", "length info column", "byte", "bytes used", "part"],
    "multiplier": [
        "multiplier",
        "multipler",
        "scale",
        "scaling",
        "factor",
        "scale factor",
        "gain",
        "resolution",
        "faktor",
        "skalierung",
        "multiply",
        "scaling factor",
        "transform",
    ],
    "divisor": ["divisor", "divide by", "divided by", "div"],
    "units": ["units", "unit", "uom", "engineering units", "einheit", "unidad", "unite"],
    "access": [
        "access",
        "r w",
        "rw",
        "read write",
        "operation info",
        "operation",
        "mode",
        "permission",
        "zugriff",
        "attribute",
        "property",
        "access type",
        "writable",
        "writeable",
    ],
    "block_label": ["block", "group", "category", "section", "block label", "gruppe", "module"],
    "register_type": [
        "register type",
        "table",
        "function code",
        "fc",
        "object type",
        "reg type",
        "area",
        "modbus table",
        "register table",
        "function",
        "func",
        "function codes",
    ],
    "minimum": ["min", "minimum", "min value", "range min", "low limit"],
    "maximum": ["max", "maximum", "max value", "range max", "high limit"],
    "offset": ["offset", "value offset", "add"],
    "word_order": [
        "mixed endian",
        "word swap",
        "swap words",
        "word order",
        "word swapped",
        "swap",
        "mixed",
        "wordswap",
        "word swap enabled",
    ],
}


# words around a header that say how a column is written, not what it holds: 'Modbus Protocol Start
# Address Hex' is an address column (whose header says hex: see address_base.guess_address_base)
QUALIFIERS = frozenset(
    ("modbus", "protocol", "start", "starting", "hex", "hexadecimal", "dec", "decimal", "logic", "logical")
)  # words beside a header word that leave its meaning (Schneider's "Logic address" is the address)


def normalize_header(text: str) -> str:
    """Lowercase words of a header, single spaces: brackets, like all punctuation, only part words
    ('Value (raw)' is 'value raw'). One linear pass, whatever the cell holds."""
    return " ".join(_NOT_WORD.sub(" ", text.lower()).split())


_NOT_WORD = re.compile(r"[^a-z0-9]+")


def header_key(text: str) -> str:
    """A header as the INI's text for it is compared with it: normalize_header without its spaces, so
    that a word a PDF's cell wraps mid-word (`Magnif` / `ication`, `Registe` / `rNO.`, read with a space
    between the lines) is still the word the page shows (`Magnification`, `Register NO.`)."""
    return normalize_header(text).replace(" ", "")


def synonym_rank(key: str, norm: str) -> int | None:
    """How well a normalized header names the column `key` (0 best), None if it does not: one of the
    key's synonyms, else one once the QUALIFIERS are dropped (ranked after every plain synonym)."""
    words = HEADER_SYNONYMS[key]
    if norm in words:
        return words.index(norm)
    core = " ".join(w for w in norm.split() if w not in QUALIFIERS)
    if core and core != norm and core in words:
        return len(words) + words.index(core)
    return None


# the longest cell any table reader accepts (docs/limits.md): a register table's longest cells are
# descriptions of a few hundred characters; a longer one is refused with its position, before any pass
# (or the XML writer, whose own limit is 10 MB a text node) works on it
MAX_CELL_CHARS = 65_536


def cell_too_long(path: Path, line: int | None, column: int | None, length: int) -> MdlError:
    """The one refusal of an over-long cell, for every reader (CSV, Markdown, HTML, workbooks)."""
    return error(
        f"a cell of {length:,} characters: the limit is {MAX_CELL_CHARS:,} (is this a register table?)",
        path,
        line,
        column,
    )


@dataclass
class Row:
    line: int
    cells: list[str]

    def cell(self, index: int | None) -> str:
        if index is None or index >= len(self.cells):
            return ""
        return self.cells[index].strip()


@dataclass
class Table:
    path: Path
    delimiter: str
    rows: list[Row]  # every non-blank, non-comment row, with its first line number
    header: Row | None = None
    data: list[Row] = field(default_factory=list)
    delimiter_guessed: bool = True
    markdown: bool = False  # a Markdown table: | at both ends of each row, a |---| rule under the header
    encoding_guess: EncodingGuess | None = None  # how the bytes were read, when no one said and not UTF-8
    notes: list[str] = field(default_factory=list)  # what reading it decided (which table of a document)
    places: dict[int, str] = field(default_factory=dict)  # a PDF's rows: line -> `p14:r7`, how messages name them

    def name_of(self, line: int) -> str:
        """How messages name the row on `line`: `line 12`, or a PDF's `p14:r7`."""
        return self.places.get(line, f"line {line}")


_RULE = re.compile(r"^\s*:?-{2,}:?\s*$")


def _records(text: str, delimiter: str, path: Path, markdown: bool = False) -> list[Row]:
    """The rows of CSV text: each non-blank, non-comment row with its first line. A cell longer than
    MAX_CELL_CHARS is refused (`_long_cell` says where), as is a cell past the csv module's own limit."""
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter, quotechar='"', skipinitialspace=False)
    rows = []
    last = 0
    try:
        for cells in reader:
            first = last + 1
            last = reader.line_num
            if not cells:
                continue
            if max(map(len, cells)) > MAX_CELL_CHARS:
                raise _long_cell(text, first, delimiter, path)
            if not "".join(cells).strip():  # every cell blank
                continue
            if cells[0].lstrip().startswith("#"):
                continue
            if markdown:
                if cells and not cells[0].strip():
                    cells = cells[1:]
                if cells and not cells[-1].strip():
                    cells = cells[:-1]
                if all(_RULE.match(c) or not c.strip() for c in cells):
                    continue  # the |---|---| rule under a Markdown header
            rows.append(Row(first, cells))
    except csv.Error as exc:
        if "field limit" in str(exc):  # a cell of more than 131,072 characters: the csv module's own bound
            raise _long_cell(text, last + 1, delimiter, path) from None
        raise error(f"malformed CSV: {exc}", path, reader.line_num) from None
    return rows


def _long_cell(text: str, line: int, delimiter: str, path: Path) -> MdlError:
    """The refusal of the first over-long cell of the row starting on `line`: the line and column where
    the cell starts and its length as the csv module reads it (quotes, doubled quotes, quoted line
    breaks), found by one pass over the row."""
    lines = io.StringIO(text, newline="")
    row = sum(len(lines.readline()) for _ in range(line - 1))
    other = re.compile(f'({re.escape(delimiter)})|(\r\n|\r|\n)|[^{re.escape(delimiter)}"\r\n]+|"')
    cell = at = row
    length = 0
    while at < len(text):
        if at == cell and text.startswith('"', at):
            quoted = _QUOTED.match(text, at)
            assert quoted is not None, "a quote starts a quoted cell"
            body = quoted.group()[1:]
            body = body.removesuffix('"')
            length, at = len(body) - body.count('""'), quoted.end()
            continue
        token = other.match(text, at)
        assert token is not None, "every character is a token"
        if token.group(1) or token.group(2):  # the cell ends
            if length > MAX_CELL_CHARS or token.group(2):
                break
            cell = at = token.end()
            length = 0
            continue
        length += len(token.group())
        at = token.end()
    breaks = list(_LINE_END.finditer(text, row, cell))
    return cell_too_long(path, line + len(breaks), cell - (breaks[-1].end() if breaks else row) + 1, length)


_QUOTED = re.compile(r'"[^"]*(?:""[^"]*)*"?')  # a quoted cell: a doubled quote is one quote in it
_LINE_END = re.compile(r"\r\n|\r|\n")


def _sample(text: str) -> str:
    return "\n".join(line for line in text.splitlines()[:200] if line.strip() and not line.lstrip().startswith("#"))


def table_delimiter(text: str) -> str | None:
    """The delimiter read_table would pick, if it splits at least half of the first lines into the
    same two or more cells; None for text that is no table."""
    if _is_markdown(text):
        return "|"
    d = _pick_delimiter(text)
    try:
        widths = [len(r) for r in csv.reader(io.StringIO(_sample(text), newline=""), delimiter=d)]
    except csv.Error:
        return None
    common = max(set(widths), key=widths.count, default=0)
    return d if common > 1 and 2 * widths.count(common) >= len(widths) else None


def _pick_delimiter(text: str) -> str:
    sample = _sample(text)
    best, best_score = ",", (-1, 0)
    for d in DELIMITERS:
        try:
            rows = list(csv.reader(io.StringIO(sample, newline=""), delimiter=d))
        except csv.Error:
            continue
        counts: dict[int, int] = {}
        for r in rows:
            if len(r) > 1:
                counts[len(r)] = counts.get(len(r), 0) + 1
        if not counts:
            continue
        width, freq = max(counts.items(), key=lambda kv: (kv[1], kv[0]))
        score = (freq, width)
        if score > best_score:
            best, best_score = d, score
    return best


def _is_markdown(text: str) -> bool:
    if "|" not in text:  # most CSV files: no line starts with one
        return False
    lines = [line for line in map(str.strip, text.splitlines()) if line]
    piped = [line for line in lines if line.startswith("|") and line.endswith("|") and len(line) > 1]
    return (
        len(piped) >= 2
        and len(piped) >= 0.5 * len(lines)
        and any(all(_RULE.match(c) or not c.strip() for c in line.strip("|").split("|")) for line in piped)
    )


FALLBACK = "cp1252"  # Windows-1252, the Latin-1 of Windows exports (Excel's "CSV" on a Western locale)
_UTF16_BOMS = (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)  # Excel's "Unicode Text" export


@dataclass(frozen=True)
class EncodingGuess:
    encoding: str  # the codec the text was read with
    why: str  # what made it the guess, and what a byte became

    def note(self, ini: bool) -> str:
        where = "[Input/Output]" if ini else "[Input/Output] of a device INI (--ini)"
        return (
            f"{self.why}; set encoding = {self.encoding} in {where} to say so, or encoding = NAME for "
            "another (latin-1, cp1250, utf-16 ...)"
        )


def decode_table(data: bytes, path: Path, encoding: str | None = None) -> tuple[str, EncodingGuess | None]:
    """The text, and the guess made when its encoding was not given: UTF-8 (with or without a BOM) is
    no guess; UTF-16 with a BOM, else Windows-1252, is, with the first byte that is not UTF-8."""
    if encoding is not None:
        return decode_text(data, path, (encoding,)).lstrip("\ufeff"), None
    if data.startswith(_UTF16_BOMS):
        return decode_text(data, path, ("utf-16",)), EncodingGuess(
            "utf-16", "read as UTF-16 (the file starts with its byte order mark)"
        )
    try:
        return decode_text(data, path, ("utf-8-sig",)).lstrip("\ufeff"), None
    except MdlError as exc:
        bad = exc.diagnostics[0]
    try:
        text = data.decode(FALLBACK)
    except UnicodeDecodeError:
        raise error(
            f"{bad.message}, nor as {FALLBACK}: save the file as UTF-8, or, for a table, say how it is "
            "written with encoding = NAME in [Input/Output] of its device INI (a Python codec name: "
            "latin-1, utf-16, cp1250 ...)",
            path,
            bad.line,
            bad.col,
        ) from None
    assert bad.line is not None and bad.col is not None, "decode_text names the byte's line and column"
    byte = data.split(b"\n", bad.line)[bad.line - 1][bad.col - 1 : bad.col]
    return text, EncodingGuess(
        FALLBACK,
        f"not UTF-8 (byte 0x{byte.hex()} on line {bad.line}, column {bad.col}): "
        f"read as Windows-1252 ({FALLBACK}, the Latin-1 of Windows exports), "
        f"where that byte is '{byte.decode(FALLBACK)}'",
    )


def read_table(path: Path, delimiter: str | None = None, encoding: str | None = None) -> Table:
    """The table of a CSV/TSV file, or (with no delimiter given) the chosen table of a Markdown, HTML or
    Excel file (mdl.formats.table.readers.document)."""
    from mdl.formats.table.readers import document as documents

    if documents.is_document(path, delimiter):
        table = documents.read_document(path, encoding)
        if not table.rows:
            raise error("the table has no rows", path)
        return table
    documents.refuse_choice(path)
    data = read_bytes(path)
    if _is_mdl(data):
        raise error(
            "this is already an MDL description: there is no register table to convert (`mdl validate` "
            "checks it; gen, sim, read and export read it as it is)",
            path,
        )
    text, guess = decode_table(data, path, encoding)
    if "\x00" in text:
        line = text[: text.index("\x00")].count("\n") + 1
        raise error(
            "a NUL byte: this is not a text CSV file (if it is UTF-16 without a byte order mark, set "
            "encoding = utf-16-le in [Input/Output])",
            path,
            line,
        )
    guessed = delimiter is None
    markdown = guessed and _is_markdown(text)
    if markdown:
        delimiter = "|"
    elif delimiter is None:
        delimiter = _pick_delimiter(text)
    rows = _records(text, delimiter, path, markdown)
    if not rows:
        raise error("the table has no rows", path)
    return Table(path, delimiter, rows, delimiter_guessed=guessed, markdown=markdown, encoding_guess=guess)


def _is_mdl(data: bytes) -> bool:
    """Whether the bytes are an MDL document: markup whose first element is ORNL's `device`."""
    from mdl.formats.sniff import starts_with_markup

    if not starts_with_markup(data):
        return False
    head = data[:4096].decode("utf-8", errors="replace")
    return re.search(r"<(\w+:)?device[\s>]", head) is not None and ("ModbusXMLSchema" in head or "<function" in head)


def header_score(row: Row) -> tuple[int, bool]:
    """(number of cells that look like known column headers, has an address header)."""
    found = set()
    for cell in row.cells:
        norm = normalize_header(cell)
        for key in HEADER_SYNONYMS:
            if synonym_rank(key, norm) is not None:
                found.add(key)
    return len(found), "addresses" in found


def find_header(table: Table, within: int | None = None, texts: list[str] | None = None) -> Row | None:
    """The header row: among the first `within` rows, the one holding the INI's header texts,
    or the one that looks most like a header (an address column and another known column)."""
    candidates = [r for r in table.rows if within is None or r.line <= within] if within else table.rows[:40]
    if texts:  # the row holding most of the INI's header texts; resolve() names any it lacks
        wanted = [header_key(t) for t in texts]
        best, best_n = None, 0
        for row in candidates:
            cells = [header_key(c) for c in row.cells]
            n = sum(w in cells for w in wanted)
            if n > best_n:
                best, best_n = row, n
        return best
    best, best_n = None, 1
    for row in candidates:
        n, has_address = header_score(row)
        if has_address and n > best_n:
            best, best_n = row, n
    return best
