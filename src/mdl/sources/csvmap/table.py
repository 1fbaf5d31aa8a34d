"""Reading a vendor's CSV as exported: delimiters, BOM, quoted line breaks, title/blank/comment rows."""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

from mdl.diagnostics import error
from mdl.fileio import decode_text, read_bytes

DELIMITERS = (",", ";", "\t", "|")

# column key -> header texts (normalized: lowercase, single spaces, no punctuation)
HEADER_SYNONYMS = {
    "addresses": ["address", "addr", "register", "reg", "reg no", "register no", "register number",
                  "modbus address", "modbus register", "start address", "starting address", "offset address",
                  "register address", "reg addr", "reg address", "adr", "adresse", "registro", "data address",
                  "modbus addr", "pdu address", "address dec", "address decimal", "registre", "indirizzo",
                  "point address", "modbus register address"],
    "description": ["description", "register and description", "desc", "name and description",
                    "parameter", "parameter name", "function", "meaning", "beschreibung", "bezeichnung",
                    "descripcion", "description of register", "signal", "variable", "data point", "point",
                    "quantity", "measurement", "item", "object"],
    "name": ["name", "xml tag", "tag", "keyword", "keywords", "keyword list", "keyword list case insensitive",
             "symbol", "identifier", "id", "short name", "variable name", "point name", "field",
             "register name", "volttron point name", "reference name"],
    "format": ["format", "data type", "datatype", "type", "data format", "value type", "ints", "typ",
               "datentyp", "format type", "variable type"],
    "count": ["count", "bytes", "words", "length words", "no of registers", "number of registers",
              "registers", "size", "quantity of registers", "num registers", "reg count", "word count",
              "anzahl", "qty", "number of words", "length bytes", "byte count"],
    "length": ["length", "length info", "length info column", "byte", "bytes used", "part"],
    "multiplier": ["multiplier", "multipler", "scale", "scaling", "factor", "scale factor", "gain",
                   "resolution", "faktor", "skalierung", "multiply", "scaling factor", "transform"],
    "divisor": ["divisor", "divide by", "divided by", "div"],
    "units": ["units", "unit", "uom", "engineering units", "einheit", "unidad", "unite"],
    "access": ["access", "r w", "rw", "read write", "operation info", "operation", "mode", "permission",
               "zugriff", "attribute", "property", "access type", "writable", "writeable"],
    "block_label": ["block", "group", "category", "section", "block label", "gruppe", "module"],
    "register_type": ["register type", "table", "function code", "fc", "object type", "reg type", "area",
                      "modbus table", "register table", "function", "func", "function codes"],
    "minimum": ["min", "minimum", "min value", "range min", "low limit"],
    "maximum": ["max", "maximum", "max value", "range max", "high limit"],
    "offset": ["offset", "value offset", "add"],
    "word_order": ["mixed endian", "word swap", "swap words", "word order", "word swapped", "swap", "mixed",
                   "wordswap", "word swap enabled"],
}


def normalize_header(text: str) -> str:
    text = re.sub(r"\(.*?\)|\[.*?\]", lambda m: " " + m.group(0)[1:-1] + " ", text.lower())
    return " ".join(re.sub(r"[^a-z0-9]+", " ", text).split())


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


_RULE = re.compile(r"^\s*:?-{2,}:?\s*$")


def _records(text: str, delimiter: str, markdown: bool = False) -> list[Row]:
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter, quotechar='"', skipinitialspace=False)
    rows = []
    last = 0
    try:
        for cells in reader:
            first = last + 1
            last = reader.line_num
            if not any(c.strip() for c in cells):
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
        raise error(f"malformed CSV: {exc}", None, reader.line_num) from None
    return rows


def _pick_delimiter(text: str) -> str:
    sample = "\n".join(line for line in text.splitlines()[:200] if line.strip() and not line.lstrip().startswith("#"))
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
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    piped = [line for line in lines if line.startswith("|") and line.endswith("|") and len(line) > 1]
    return len(piped) >= 2 and len(piped) >= 0.5 * len(lines) and any(
        all(_RULE.match(c) or not c.strip() for c in line.strip("|").split("|")) for line in piped)


def read_table(path: Path, delimiter: str | None = None) -> Table:
    data = read_bytes(path)
    if b"\x00" in data:
        line = data[: data.index(b"\x00")].count(b"\n") + 1
        raise error("a NUL byte: this is not a text CSV file", path, line)
    text = decode_text(data, path, ("utf-8-sig", "cp1252"))
    text = text.lstrip("\ufeff")
    guessed = delimiter is None
    markdown = guessed and _is_markdown(text)
    if markdown:
        delimiter = "|"
    elif delimiter is None:
        delimiter = _pick_delimiter(text)
    try:
        rows = _records(text, delimiter, markdown)
    except Exception as exc:  # csv.Error re-raised as MdlError without the path
        if hasattr(exc, "diagnostics"):
            d = exc.diagnostics[0]
            raise error(d.message, path, d.line) from None
        raise
    if not rows:
        raise error("the table has no rows", path)
    return Table(path, delimiter, rows, delimiter_guessed=guessed, markdown=markdown)


def header_score(row: Row) -> tuple[int, bool]:
    """(number of cells that look like known column headers, has an address header)."""
    found = set()
    for cell in row.cells:
        norm = normalize_header(cell)
        for key, words in HEADER_SYNONYMS.items():
            if norm in words:
                found.add(key)
    return len(found), "addresses" in found


def find_header(table: Table, within: int | None = None, texts: list[str] | None = None) -> Row | None:
    """The header row: among the first `within` rows, the one holding the INI's header texts,
    or the one that looks most like a header (an address column and another known column)."""
    candidates = [r for r in table.rows if within is None or r.line <= within] if within else table.rows[:40]
    if texts:  # the row holding most of the INI's header texts; resolve() names any it lacks
        wanted = [normalize_header(t) for t in texts]
        best, best_n = None, 0
        for row in candidates:
            cells = [normalize_header(c) for c in row.cells]
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
