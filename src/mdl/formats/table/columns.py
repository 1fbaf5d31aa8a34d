"""Which column holds what: the INI's indices or header texts, else header synonyms checked against
the column's cells (a `Function` column of function codes is a register type, never a description)."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field

from mdl.diagnostics import Diagnostic, MdlError
from mdl.formats.table.cells import (
    CellError,
    parse_access,
    parse_format,
    parse_length,
    parse_table,
    parse_word_order,
)
from mdl.formats.table.ini import DeviceIni
from mdl.formats.table.lazy import lazy
from mdl.formats.table.numbers import parse_int, parse_number, unit_alone
from mdl.formats.table.readers.delimited import (
    HEADER_SYNONYMS,
    Row,
    Table,
    header_key,
    normalize_header,
    synonym_rank,
)
from mdl.formats.table.vocabulary import mapped

# keys guessed from headers, in this order (addresses first, so it has first pick)
GUESS_ORDER = (
    "addresses",
    "description",
    "name",
    "format",
    "count",
    "length",
    "multiplier",
    "divisor",
    "units",
    "access",
    "block_label",
    "register_type",
    "minimum",
    "maximum",
    "offset",
    "word_order",
)
PREFIX_KEYS = ("addresses", "description", "format", "units", "multiplier", "count")
ADDRESS_FALLBACKS = ("offset", "index", "nr", "no", "number")  # headers taken for addresses if none says so
# a column whose header names one field but whose cells hold another: the fields it may hold instead
ALTERNATIVES = {
    "addresses": ("format", "register_type"),
    "description": ("register_type", "format"),
    "name": ("register_type", "format"),
    "format": ("register_type",),
    "length": ("count",),
    "access": ("register_type",),
}
SAMPLE = 200  # cells looked at to check a guess
# the share of them that must fit: half, so that a few bad cells (mod10k(True) in a column of scales,
# int99 among formats) are reported on their rows rather than every row read without the column
HALF = 0.5
MOSTLY = 0.8  # a text column whose cells are this much register types is a register-type column


_NAMED_PREFIX = lazy(r"(?i)\b(?:coil|c|discrete[-_]input|di|input[-_]register|ir|holding[-_]register|hr)\s*:")
_ADDRESS_SHAPE = lazy(r"(?i)^(?=.*\d)[\s0-9a-fx:#,;/&.()\-\u2013\u2014]+$")


def _fits_address(cell: str) -> None:
    """An address in one of the forms parse_addresses reads (whether in range or not is the row's business)."""
    text = re.sub(r"(?i)\b(?:to|and)\b|(?<=\d)to(?=\d)", " ", _NAMED_PREFIX().sub(" ", cell))
    if not _ADDRESS_SHAPE().match(text):
        raise CellError("not an address")


def _fits_text(cell: str) -> None:
    if not any(ch.isalpha() for ch in cell):
        raise CellError("no letters")


def _fits_count(cell: str) -> None:
    if parse_int(cell) < 1:
        raise CellError("not a count")


def _fits_scale(cell: str) -> None:
    parse_number(cell, "auto", scale=True)


def _fits_number(cell: str) -> None:
    parse_number(cell, "auto")


def _anything(cell: str) -> None:
    pass


CHECKS: dict[str, Callable[[str], None]] = {
    "addresses": _fits_address,
    "description": _fits_text,
    "name": _fits_text,
    "format": lambda c: None if parse_format(c) else None,
    "count": _fits_count,
    "length": lambda c: None if parse_length(c) else None,
    "multiplier": _fits_scale,
    "divisor": _fits_scale,
    "units": _anything,
    "access": lambda c: None if parse_access(c) else None,
    "block_label": _anything,
    "register_type": lambda c: None if parse_table(c) else None,
    "minimum": _fits_number,
    "maximum": _fits_number,
    "offset": _fits_number,
    "word_order": lambda c: None if parse_word_order(c) else None,
}


@dataclass
class Columns:
    index: dict[str, int] = field(default_factory=dict)
    names: list[int] = field(default_factory=list)  # text columns matched along with the description (tags, names)
    headers: dict[int, str] = field(default_factory=dict)
    guessed: dict[str, int] = field(default_factory=dict)  # keys found by their header, not named in the INI
    notes: list[str] = field(default_factory=list)  # what was decided, for the user
    scale_has_units: bool = False  # the units column is the scale column: its cells give number and unit

    def header_of(self, key: str) -> str:
        i = self.index.get(key)
        return self.headers.get(i, "") if i is not None else ""

    def describe(self, i: int) -> str:
        header = self.headers.get(i, "").strip()
        return f"column {i} '{header}'" if header else f"column {i}"


def _share(rows: list[Row], index: int, check: Callable[[str], None]) -> tuple[float, str | None]:
    """(share of the column's first non-empty cells that pass `check`, the first that does not)."""
    cells = []
    for r in rows:
        c = r.cell(index)
        if c:
            cells.append(c)
            if len(cells) == SAMPLE:
                break
    if not cells:
        return 1.0, None
    ok, bad = 0, None
    for c in cells:
        try:
            check(c)
            ok += 1
        except (CellError, ValueError):
            bad = bad or c
    return ok / len(cells), bad


def _fits(key: str, rows: list[Row], index: int, maps: dict[str, dict[str, str]]) -> tuple[bool, str | None]:
    """Whether the column's cells read as `key` (or the INI's [<key> cells] maps them), and the first that does not."""

    def check(cell: str) -> None:
        if mapped(maps, key, cell) is None:
            CHECKS[key](cell)

    share, bad = _share(rows, index, check)
    if share < HALF or key not in ("description", "name"):
        return share >= HALF, bad
    tables, _ = _share(rows, index, CHECKS["register_type"])  # text, but not a column of register types
    first = next((r.cell(index) for r in rows if r.cell(index)), None)
    return first is None or tables < MOSTLY, first


def _short(text: str) -> str:
    text = " ".join(text.split())
    return text if len(text) <= 30 else text[:30] + "..."


def resolve(table: Table, header: Row | None, data: list[Row], ini: DeviceIni | None) -> Columns:
    cols = Columns()
    headers = [normalize_header(c) for c in header.cells] if header else []
    keys = [header_key(c) for c in header.cells] if header else []  # the INI's header texts are compared so
    if header:
        cols.headers = {i: c.strip() for i, c in enumerate(header.cells)}
    where = str(ini.path) if ini and ini.path else None
    errors: list[Diagnostic] = []
    taken: set[int] = set()
    given = dict(ini.columns) if ini else {}
    width = max((len(r.cells) for r in ([header] if header else []) + data), default=0)
    for key, spec in given.items():
        if isinstance(spec, int):
            if spec >= width:  # no row has the column: every cell of it would read as empty
                errors.append(
                    Diagnostic(
                        where,
                        ini.line("columns", key) if ini else None,
                        None,
                        f"[Column/Field Indices] {key} = {spec}: no row of {table.path} has a "
                        f"column {spec} (columns count from 0; the widest row has {width})",
                    )
                )
            cols.index[key] = spec
        else:
            if header_key(spec) in keys:
                cols.index[key] = keys.index(header_key(spec))
            else:
                line = f" (line {header.line})" if header else ""
                errors.append(
                    Diagnostic(
                        where,
                        ini.line("columns", key) if ini else None,
                        None,
                        f"[Column/Field Indices] {key} = {spec}: "
                        f"no such column in the header row{line} of {table.path}",
                    )
                )
    if errors:
        raise MdlError(errors)
    if "multiplier" in cols.index and "divisor" in cols.index and cols.index["multiplier"] == cols.index["divisor"]:
        raise MdlError(
            Diagnostic(
                where,
                ini.line("columns", "divisor") if ini else None,
                None,
                "[Column/Field Indices] multiplier and divisor name the same "
                "column: a scale either multiplies or divides",
            )
        )
    if "name" in cols.index:
        cols.names = [cols.index["name"]]
    taken.update(cols.index.values())
    if ini:
        for c in ini.claimed:
            if isinstance(c, int):
                taken.add(c)
            elif header_key(c) in keys:
                taken.add(keys.index(header_key(c)))
    skip = set(given) | (ini.blank_columns if ini else set())
    _guess(cols, headers, data, taken, skip, ini.cells if ini else {})
    _scale_in_units(cols, data, skip)
    for key in ("multiplier", "divisor"):
        if key in cols.index and cols.index[key] == cols.index.get("units"):
            cols.scale_has_units = True
    _say_guesses(cols, ini, data)
    return cols


def _candidates(key: str, headers: list[str], taken: set[int]) -> list[int]:
    words = HEADER_SYNONYMS[key]
    ranks = [(synonym_rank(key, h), i) for i, h in enumerate(headers) if i not in taken]
    out = [i for _, i in sorted((r, i) for r, i in ranks if r is not None)]
    if key in PREFIX_KEYS:
        out += [
            i
            for i, h in enumerate(headers)
            if i not in taken and i not in out and any(h.startswith(s + " ") for s in words if len(s) >= 4)
        ]
    if key == "addresses":  # some vendors call the address "Offset" or "No."
        out += [i for i, h in enumerate(headers) if h in ADDRESS_FALLBACKS and i not in taken and i not in out]
    return out


def _guess(
    cols: Columns, headers: list[str], data: list[Row], taken: set[int], skip: set[str], maps: dict[str, dict[str, str]]
) -> None:
    for key in GUESS_ORDER:
        if key in skip or (key in cols.index and key != "name"):
            continue
        for i in _candidates(key, headers, taken):
            if i in taken:
                continue
            ok, bad = _fits(key, data, i, maps)
            chosen = key if ok else None
            if not ok:
                for other in ALTERNATIVES.get(key, ()):
                    if other not in cols.index and other not in skip and _fits(other, data, i, maps)[0]:
                        chosen = other
                        break
                line = next((r.line for r in data if r.cell(i) == bad), None)
                where = f" ('{_short(bad)}' on line {line})" if bad is not None and line else ""
                what = f"read as {chosen}" if chosen else "ignored"
                cols.notes.append(f"{cols.describe(i)} has a header like {key} but its cells are not{where}: {what}")
            if chosen is None:
                continue
            taken.add(i)
            cols.guessed[chosen] = i
            if chosen == "name":
                cols.names.append(i)
                continue
            cols.index[chosen] = i
            if chosen == key:
                break


def _scale_in_units(cols: Columns, data: list[Row], skip: set[str]) -> None:
    """A units column of `0.01V` cells (a scale written before its unit) with no scale column: it is the
    multiplier too. Its cells are read one by one: a cell that is not a scale (`1:PV`, `0.1?`) does not
    turn the reading off for the column (its row gets multiplier 1 and a warning naming the cell)."""
    i = cols.index.get("units")
    if i is None or {"multiplier", "divisor"} & (set(cols.index) | skip):
        return
    numbers = []
    unread: list[Row] = []
    for r in data:
        c = r.cell(i)
        if c:
            try:
                numbers.append(parse_number(c, "auto", scale=True))
            except CellError:
                if any(ch.isdigit() for ch in c) and unit_alone(c) is None:
                    unread.append(r)
                # a unit alone (V, kWh, ja/nein): scale 1 in that unit, if the column holds scales
    if any(n is not None and n.value != 1 for n in numbers) and any(n is not None and n.unit for n in numbers):
        cols.index["multiplier"] = i
        cols.guessed["multiplier"] = i
        but = ""
        if unread:
            first = unread[0]
            but = (
                f"; {len(unread)} of its cells {'is' if len(unread) == 1 else 'are'} not a scale (e.g. "
                f"'{_short(first.cell(i))}' on line {first.line}): each such row is read with multiplier 1 and "
                "a warning"
            )
        cols.notes.append(
            f"{cols.describe(i)} holds scales written before their units (e.g. 0.1V): read as "
            f"multiplier and units{but}; set multiplier = (blank) in [Column/Field Indices] to read "
            "it as units only, or divisor = to divide by it"
        )


def _whole_scales(data: list[Row], index: int) -> bool:
    """Whether a scale column holds only whole numbers, some above 1 (10, 100): multiplied or divided?"""
    values = []
    for r in data:
        try:
            n = parse_number(r.cell(index), "auto", scale=True)
        except CellError:
            continue
        if n is not None:
            values.append(abs(n.value))
    return bool(values) and all(v.is_integer() for v in values) and any(v > 1 for v in values)


def _say_guesses(cols: Columns, ini: DeviceIni | None, data: list[Row]) -> None:
    found = sorted((i, key) for key, i in cols.guessed.items())
    if not found:
        return
    parts = [f"{key} = {cols.describe(i)}" for i, key in found]
    how = "name them in [Column/Field Indices] of the INI" if ini else "give a device INI (--ini) naming them"
    cols.notes.insert(
        0,
        f"columns found by their headers: {', '.join(parts)}; to choose others, {how} "
        "(a 0-based number or a header text; blank for none)",
    )
    scale = cols.guessed.get("multiplier")
    if scale is not None and scale != cols.index.get("units") and _whole_scales(data, scale):
        cols.notes.append(
            f"{cols.describe(scale)} is read as a multiplier (the raw value times the cell); if the "
            f"table divides by it (a scale factor of 10 meaning tenths), set divisor = "
            f"{cols.headers.get(scale) or scale} and multiplier = (blank) in [Column/Field Indices]"
        )
