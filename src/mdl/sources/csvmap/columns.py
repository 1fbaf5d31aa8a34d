"""Which column holds what: the INI's indices or header texts, else header synonyms."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from mdl.diagnostics import Diagnostic, MdlError
from mdl.sources.csvmap.cells import CellError, parse_format, parse_int, parse_table
from mdl.sources.csvmap.ini import DeviceIni
from mdl.sources.csvmap.table import HEADER_SYNONYMS, Row, Table, normalize_header

# keys guessed from headers, in this order (addresses first, so it has first pick)
GUESS_ORDER = ("addresses", "description", "name", "format", "count", "length", "multiplier", "units",
               "access", "block_label", "register_type", "minimum", "maximum", "offset")
PREFIX_KEYS = ("addresses", "description", "format", "units", "multiplier", "count")
ADDRESS_FALLBACKS = ("offset", "index", "nr", "no", "number")  # headers taken for addresses if none says so


@dataclass
class Columns:
    index: dict[str, int] = field(default_factory=dict)
    names: list[int] = field(default_factory=list)  # extra text columns to match on (tags, keywords)
    headers: dict[int, str] = field(default_factory=dict)

    def header_of(self, key: str) -> str:
        i = self.index.get(key)
        return self.headers.get(i, "") if i is not None else ""


def _mostly(rows: list[Row], index: int, parse: Callable[[str], object]) -> bool:
    cells = [r.cell(index) for r in rows[:200] if r.cell(index)]
    if not cells:
        return False
    ok = 0
    for c in cells:
        try:
            parse(c)
            ok += 1
        except (CellError, ValueError):
            pass
    return ok >= 0.8 * len(cells)


def resolve(table: Table, header: Row | None, data: list[Row], ini: DeviceIni | None) -> Columns:
    cols = Columns()
    headers = [normalize_header(c) for c in header.cells] if header else []
    if header:
        cols.headers = {i: c.strip() for i, c in enumerate(header.cells)}
    where = str(ini.path) if ini and ini.path else None
    errors: list[Diagnostic] = []
    taken: set[int] = set()
    given = dict(ini.columns) if ini else {}
    for key, spec in given.items():
        if isinstance(spec, int):
            cols.index[key] = spec
        else:
            norm = normalize_header(spec)
            if norm in headers:
                cols.index[key] = headers.index(norm)
            else:
                line = f" (line {header.line})" if header else ""
                errors.append(Diagnostic(where, None, None, f"[Column/Field Indices] {key} = {spec}: "
                                         f"no such column in the header row{line} of {table.path}"))
    if errors:
        raise MdlError(errors)
    taken.update(cols.index.values())
    if ini:
        for c in ini.claimed:
            if isinstance(c, int):
                taken.add(c)
            elif normalize_header(c) in headers:
                taken.add(headers.index(normalize_header(c)))
    skip = set(given) | (ini.blank_columns if ini else set())
    for key in GUESS_ORDER:
        if key in skip and key != "name":
            continue
        found = [i for i, h in enumerate(headers) if h in HEADER_SYNONYMS[key] and i not in taken]
        if not found and key in PREFIX_KEYS:
            found = [i for i, h in enumerate(headers) if i not in taken and any(
                h.startswith(s + " ") for s in HEADER_SYNONYMS[key] if len(s) >= 4)]
        if not found and key == "addresses":  # some vendors call the address "Offset" or "No."
            found = [i for i, h in enumerate(headers) if h in ADDRESS_FALLBACKS and i not in taken]
        if not found:
            continue
        if key == "name":
            cols.names = [i for i in found if i not in cols.index.values()]
            taken.update(cols.names)
            continue
        i = found[0]
        if key == "length" and "count" not in cols.index and _mostly(data, i, parse_int):
            key = "count"
        if key == "format" and "register_type" not in cols.index and _mostly(data, i, parse_table) \
                and not _mostly(data, i, parse_format):
            key = "register_type"
        if key in cols.index:
            continue
        cols.index[key] = i
        taken.add(i)
    return cols
