"""One table row -> one MDL function (named later, by the matcher or by --all)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import TypeVar

from mdl.diagnostics import shown
from mdl.dsl.cfrag import FragmentError, check
from mdl.exchange.text import unwritable
from mdl.formats.table.cells import (
    AddressCell,
    CellError,
    MappedFormat,
    TypeCell,
    hexify,
    is_digits,
    parse_access,
    parse_bit_cell,
    parse_length,
    parse_table,
    parse_word_order,
    read_address_cell,
    read_mapped_format,
    read_type,
)
from mdl.formats.table.columns import Columns
from mdl.formats.table.numbers import NO_VALUE, Number, parse_int, parse_number, unit_alone
from mdl.formats.table.readers.delimited import Row
from mdl.formats.table.vocabulary import function_problems, mapped
from mdl.model import BIT_TABLES, Function
from mdl.model.layout import LayoutError, layout

T = TypeVar("T")


@dataclass
class RowSettings:
    address_base: str  # 0 | 1 | modicon | hex
    count_unit: str  # words | bytes
    register_type: str | None
    byte_order: str | None
    word_order: str | None
    decimal: str = "auto"  # auto | point | comma (numbers.parse_number)
    w_alone: str = "write"  # what an access cell `W` means in this table (cells.access_words)
    base_guessed: bool = False  # the address base was guessed (a refused cell says how to set it)
    cells: dict[str, dict[str, str]] = field(default_factory=dict)  # the INI's [<field> cells] maps
    raw_limits: bool | None = None  # minimum/maximum cells are raw values (True), scaled (False), unsaid (None)


# what a row may have had to guess, said once per table with the first cell read so (convert.py)
COMMA, UNIT_ALONE, WIDTHLESS, NATIVE = "comma", "unit alone", "widthless", "native"
SCALED_LIMITS, NO_RANGE = "scaled limits", "no range"


@dataclass
class ParsedRow:
    row: Row
    function: Function
    texts: list[str]  # description and name cells, for matching
    label: str  # what --all names it by
    guesses: dict[str, str]  # COMMA, UNIT_ALONE ... -> the cell read so
    notes: list[tuple[str, str]] = field(default_factory=list)  # (said once per table by this, the note)
    problems: list[tuple[str, str]] = field(default_factory=list)  # (field, warning): a cell left at its default
    ok: set[str] = field(default_factory=set)  # fields whose cell was read


def row_texts(row: Row, cols: Columns) -> list[str]:
    """The row's description and name cells, for matching (also of a row that cannot be read)."""
    return [row.cell(cols.index.get("description"))] + [row.cell(i) for i in cols.names if row.cell(i)]


def _check_writable(fn: Function) -> None:
    """CellError for a text no MDL document can hold (a control character in a description)."""
    every = "".join(filter(None, (fn.description, fn.units, fn.read_function_code, fn.write_function_code)))
    if every.isascii() and every.isprintable() and not fn.block_labels:  # most rows: XML takes all of it
        return
    texts = [(key, getattr(fn, key)) for key in ("description", "units", "read_function_code", "write_function_code")]
    for what, text in texts + [("block label", label) for label in fn.block_labels]:
        bad = unwritable(text) if text else None
        if bad:
            raise CellError(f"the {what} holds the character {bad}, which MDL (XML) cannot carry")


ESSENTIAL = ("addresses", "register_type", "format", "count")  # a cell of these that cannot be read skips the row


class FieldError(CellError):
    """A cell of one field that cannot be read: the message names the column and the cell."""

    def __init__(self, message: str, key: str) -> None:
        super().__init__(message)
        self.key = key


class _Cells:
    """A row's cells by field, as the INI's `[<field> cells]` maps them; what could not be read."""

    def __init__(self, row: Row, cols: Columns, st: RowSettings) -> None:
        self.row, self.cols, self.st = row, cols, st
        cells, n = row.cells, len(row.cells)
        # each field's cell as Row.cell gives it, read once (a row asks for each several times)
        self.raws = {key: cells[i].strip() if i < n else "" for key, i in cols.index.items()}
        self.notes: list[tuple[str, str]] = []  # (what it is about, said once per table; the message)
        self.problems: list[tuple[str, str]] = []  # (field, warning): cells kept at their field's default
        self.mapped: set[str] = set()  # fields whose cell the INI mapped
        self.ok: set[str] = set()  # fields whose cell was read

    def raw(self, key: str) -> str:
        return self.raws.get(key, "")

    def text(self, key: str) -> str:
        raw = self.raws.get(key, "")
        return self._mapped(key, raw) if raw and self.st.cells else raw

    def _mapped(self, key: str, raw: str) -> str:
        """The cell as the INI's `[<key> cells]` maps it (with the note that says so), else as it is."""
        found = mapped(self.st.cells, key, raw)
        if found is None:
            return raw
        self.mapped.add(key)
        self.notes.append(
            (
                f"cells {key} {raw.strip().lower()}",
                f"{key} cell {shown(raw.strip())} on line {self.row.line} (and any like it) "
                f"read as {shown(found)}, as [{key} cells] in the INI says",
            )
        )
        return found

    def read(self, key: str, reader: Callable[[str], T]) -> T | None:
        """The field read from its cell (None for an empty one); an unreadable essential cell of a named
        column raises FieldError, any other is a problem and None."""
        text = self.raws.get(key)
        if text and self.st.cells:
            text = self._mapped(key, text)
        if not text:
            return None
        try:
            value = reader(text)
        except CellError as exc:
            message = f"{self.cols.describe(self.cols.index[key])} {key} cell {shown(self.raw(key).strip())}: {exc}"
            if key in ESSENTIAL and key not in self.cols.guessed:
                raise FieldError(message, key) from None
            self.problems.append((key, f"{message}; {key} left at its default (the row is kept)"))
            return None
        self.ok.add(key)
        return value


def _bits(cells: _Cells, typed: TypeCell | None, mapped_format: MappedFormat | None, at: AddressCell) -> str | None:
    """The bits the row says (a bits column, the address cell, the format cell); CellError where two disagree."""
    said = (
        ("bits column", cells.read("bits", parse_bit_cell) if "bits" in cells.raws else None),
        ("address", at.bits),
        ("format", (mapped_format.bits if mapped_format else None) or (typed.bits if typed else None)),
    )
    found = {k: v for k, v in said if v is not None}
    if not found:  # most rows
        return None
    if len(set(found.values())) > 1:
        raise FieldError(f"the {' and the '.join(found)} name different bits ({', '.join(found.values())})", "bits")
    return next(iter(found.values()), None)


FIXED_WIDTH = {"INT16": 1, "UINT16": 1, "INT32": 2, "UINT32": 2, "FLOAT32": 2, "INT64": 4, "UINT64": 4, "FLOAT64": 4}


def _listed_width(
    cells: _Cells,
    row: Row,
    address_text: str,
    listed: int,
    fmt: str | None,
    typed: TypeCell | None,
    mapped_format: MappedFormat | None,
    counted: int | None,
    st: RowSettings,
    unit_bits: int,
) -> None:
    """An address cell that lists its registers decides the value's width; where the row's format or
    count column says another width, the row says two things (three phases in one row, a text cut
    short): the row is skipped, never read at a width it does not say."""
    cell = " ".join(address_text.split())
    said = []
    width = FIXED_WIDTH.get(fmt or "") if typed is not None and not typed.widthless and unit_bits == 16 else None
    if width is not None and listed != width:
        said.append(f"format {shown(cells.raw('format'))} is {width} register{'s' * (width > 1)}")
    if mapped_format and mapped_format.count and mapped_format.count != listed:
        said.append(f"format {shown(cells.raw('format'))} is {mapped_format.count} registers as [format cells] says")
    if counted is not None:
        count = -(-counted * 8 // unit_bits) if st.count_unit == "bytes" else counted
        if count != listed:
            said.append(f"the count column says {count}")
    if said:
        raise FieldError(
            f"the address cell {shown(cell[:60])} lists {listed} registers but {' and '.join(said)}: "
            "the row says two widths (several values in one row, or a list cut short); "
            "give the function its own addresses in [function NAME] (addresses, format)",
            "addresses",
        )


def parse_row(row: Row, cols: Columns, st: RowSettings) -> ParsedRow | None:
    """None for rows without an address (section titles, notes); CellError for bad rows."""
    cells = _Cells(row, cols, st)
    ix, raws = cols.index, cells.raws  # `key in raws`: the table has that column (else read gives None)
    address_text = cells.text("addresses")
    if not address_text:
        return None
    base = st.address_base
    if base == "hex":
        address_text, base = hexify(address_text), "0"
    column_table = cells.read("register_type", parse_table) if "register_type" in raws else None
    if base == "modicon" and column_table == "coil" and is_digits(address_text) and len(address_text) <= 4:
        address_text = address_text.zfill(5)  # coil number 1 is 00001 without its zeros (VOLTTRON's maps)
    try:
        at = read_address_cell(address_text, base)
    except CellError as exc:
        if base == "modicon" and st.base_guessed:
            raise FieldError(
                f"{exc}, though the column's other addresses are (read as Modicon numbers: "
                "set address_base = 0 or 1 in [Modbus Device] if they are not)",
                "addresses",
            ) from None
        raise FieldError(str(exc), "addresses") from None
    cells.ok.add("addresses")
    if at.said:
        cells.notes.append(("address bit", f"{at.said} (line {row.line}, and any like it)"))
    addresses, table = at.addresses, at.table
    if column_table is not None:
        if table and column_table != table:
            raise FieldError(
                f"address {shown(address_text)} is a {table} but the register type column says {column_table}",
                "register_type",
            )
        table = column_table
    table = table or st.register_type or "holding"

    raw_format = cells.raw("format")
    if "format" in cells.mapped or (st.cells and raw_format and mapped(st.cells, "format", raw_format)):
        mapped_format = cells.read("format", read_mapped_format)
        typed = mapped_format.typed if mapped_format else None
    else:
        mapped_format, typed = None, cells.read("format", read_type)
    fmt, strlen = (typed.format, typed.strlen) if typed else (None, None)
    bits = _bits(cells, typed, mapped_format, at)
    if at.bits is not None and fmt == "BIT" and table not in BIT_TABLES:
        fmt = "UINT16"  # `0x0103.b8` typed `bit`: one bit of a register, not a coil
    if table in BIT_TABLES:
        fmt = "BIT" if fmt is not None else None
        bits = None
    length = cells.read("length", parse_length) if "length" in raws else None
    if typed and typed.length:
        if length not in (None, typed.length):
            raise FieldError(
                f"format {shown(cells.raw('format'))} is the {typed.length.lower()} but the length column "
                f"says {length}",
                "format",
            )
        length = typed.length
    if at.bits in ("0", "8") and bits == at.bits and fmt in ("INT8", "UINT8") and length in (None, "Full word"):
        length = "Lower byte" if at.bits == "0" else "Upper byte"  # `0x0103.b8` typed UINT8: the upper byte
        bits = None
    unit_bits = 16 if (length or "Full word") == "Full word" else 8
    counted = cells.read("count", parse_int) if "count" in raws else None
    if counted is not None and counted < 1:
        raise FieldError(f"count {shown(cells.raw('count'))} must be 1 or more", "count")
    count = None
    if len(addresses) > 1:
        count = len(addresses)
        _listed_width(cells, row, address_text, count, fmt, typed, mapped_format, counted, st, unit_bits)
    elif mapped_format and mapped_format.count:
        count = mapped_format.count
    elif counted is not None:
        count = -(-counted * 8 // unit_bits) if st.count_unit == "bytes" else counted
        if strlen and count != -(-strlen * 8 // unit_bits):
            cells.notes.append(
                (
                    "count over width",
                    f"format {shown(cells.raw('format'))} on line {row.line} (and any like it) is "
                    f"{-(-strlen * 8 // unit_bits)} registers wide but the count column says {count}: the count wins",
                )
            )
    elif strlen:
        count = -(-strlen * 8 // unit_bits)
    if fmt is None and table not in BIT_TABLES and unit_bits == 16:
        fmt = {1: "UINT16", 2: "UINT32", 4: "UINT64"}.get(count or 1)
    elif typed and typed.widthless and unit_bits == 16 and count in (2, 4) and fmt in ("INT16", "UINT16"):
        wide = fmt.replace("16", str(16 * count))  # `Unsigned` over 2 registers is a UINT32, not two UINT16
        cells.notes.append(
            (
                "widthless over count",
                f"format {shown(cells.raw('format'))} on line {row.line} (and any like it) says no width and the "
                f"row is {count} registers: read as {wide}",
            )
        )
        fmt = wide
    # row_texts, with the description cell as the INI may map it
    texts = [cells.text("description") if "description" in ix else ""]
    if cols.names:
        texts += [row.cell(i) for i in cols.names if row.cell(i)]
    description, names = texts[0], texts[1:]
    byte_order, word_order, own_order = _orders(cells, st, typed)
    fn = Function(
        name="",
        description=description or (names[0] if names else address_text),
        addresses=addresses,
        length=length if length and length != "Full word" and table not in BIT_TABLES else None,
        count=count if count and count > 1 else None,
        format=fmt,
        register_type=table if table != "holding" else None,
        byte_order=byte_order if byte_order == "little" else None,
        word_order=word_order if word_order == "little" else None,
        bits=bits,
        line=row.line,
    )
    label = cells.read("block_label", str) if "block_label" in raws else None
    if label:
        fn.block_labels = [label]
    guesses = _numbers(cells, st, fn)
    access = cells.read("access", lambda t: parse_access(t, st.w_alone)) if "access" in raws else None
    if access is not None:
        default = "read" if table in ("input", "discrete") else "read_write"
        if access != default:
            if table in ("input", "discrete"):
                cells.problems.append(
                    (
                        "",
                        f"{cols.describe(ix['access'])} access {shown(cells.raw('access'))} is impossible for a "
                        f"{table}: "
                        "read only (the row is kept)",
                    )
                )
            else:
                fn.access = access
    try:
        lay = layout(fn)
    except LayoutError as exc:
        raise FieldError(str(exc), "format") from None
    if own_order and table in BIT_TABLES:  # a bit has no order: a Mixed Endian cell on a coil row says nothing
        fn.byte_order = fn.word_order = None
    if len(lay.addresses) == 1:
        if own_order:
            fn.word_order = None  # nor has one register a word order
        if typed and typed.widthless and lay.unit == "word":
            guesses[WIDTHLESS] = cells.raw("format")
    if typed and typed.native:
        guesses[NATIVE] = cells.raw("format")
    for problem in function_problems(fn, {}, lay):
        raise FieldError(problem, "bits" if fn.bits else "format")
    for key in ("read_function_code", "write_function_code"):  # C fragments (docs/fragments.md), not codes
        code = cells.text(key) if key in raws else ""
        if code:
            try:
                check(code, len(lay.addresses))
            except FragmentError as exc:
                where = cells.cols.describe(cells.cols.index[key])
                cells.problems.append(
                    (
                        key,
                        f"{where} {key} cell {shown(code.strip()[:40])}: not a C fragment ({exc}); the row is kept "
                        f"without it ({key} holds C code, docs/fragments.md; a column of Modbus function "
                        "codes is register_type)",
                    )
                )
                continue
            cells.ok.add(key)
            setattr(fn, key, code)
    _check_writable(fn)
    named = names[0] if names else description or address_text
    return ParsedRow(row, fn, texts, named, guesses, cells.notes, cells.problems, cells.ok)


def _limits(fn: Function, st: RowSettings, guesses: dict[str, str], cells: _Cells) -> None:
    """A minimum equal to its maximum (NIBE's 0/0) is no range: no limits. With `limits = raw`, the
    cells are register values, scaled here as the value is; unsaid, they are taken as engineering units,
    a guess said once where a row's scale makes the two differ."""
    if fn.minimum is None or fn.maximum is None:
        if fn.minimum is None and fn.maximum is None:
            return
    elif fn.minimum == fn.maximum:
        guesses.setdefault(NO_RANGE, f"{cells.raw('minimum').strip()}/{cells.raw('maximum').strip()}")
        fn.minimum = fn.maximum = None
        return
    if (fn.multiplier is None or fn.multiplier == 1.0) and not fn.offset:
        return
    if st.raw_limits is None:  # raw ones are scaled once the INI's [function NAME] fields are on (convert.py)
        guesses.setdefault(SCALED_LIMITS, f"{cells.raw('minimum').strip()}/{cells.raw('maximum').strip()}")


def scale_raw_limits(fn: Function, multiplier: float | None, offset: float | None) -> None:
    """`limits = raw`: the limits read from the table are register values; as MDL keeps them, in
    engineering units: raw * multiplier + offset (the two swapped under a negative multiplier)."""
    m, o = (multiplier if multiplier is not None else 1.0), (offset or 0.0)
    low, high = (None if v is None else v * m + o for v in (fn.minimum, fn.maximum))
    fn.minimum, fn.maximum = (high, low) if m < 0 else (low, high)


def _flip(order: str) -> str:
    return "big" if order == "little" else "little"


def _orders(cells: _Cells, st: RowSettings, typed: TypeCell | None) -> tuple[str | None, str | None, bool]:
    """(byte order, word order, whether the row itself said the word order). A struct type's prefix
    gives both orders of its row (`<` reverses every byte); a word-order column (`Mixed Endian`)
    reverses the registers from the type's own order (TRUE), keeps it (FALSE), or names the order;
    otherwise the INI's [Modbus Device] orders."""
    byte_order = typed.order if typed and typed.order else st.byte_order
    word_order = typed.order if typed and typed.order else st.word_order
    own = bool(typed and typed.order)
    text = cells.text("word_order") if "word_order" in cells.raws else ""
    said = cells.read("word_order", parse_word_order) if text and text.strip().lower() not in NO_VALUE else None
    if said is not None:
        if said.swapped is not None:
            type_order = typed.order if typed and typed.order else "big"
            word_order = _flip(type_order) if said.swapped else type_order
        else:
            word_order = said.word_order
            byte_order = said.byte_order or byte_order
        own = True
    return byte_order, word_order, own


def _numbers(cells: _Cells, st: RowSettings, fn: Function) -> dict[str, str]:
    """Offset, limits, scale and units onto `fn`; what was guessed (a decimal comma, a unit alone in a
    scale column) with the cell. A cell that cannot be read leaves its field at the default (a problem)."""
    cols = cells.cols
    guesses: dict[str, str] = {}
    for key in ("offset", "minimum", "maximum"):
        if key not in cells.raws:  # no such column (read would give None)
            continue
        number = cells.read(key, partial(_number_or_none, decimal=st.decimal, what=key))
        if number is not None:
            if number.comma:
                guesses.setdefault(COMMA, cells.raw(key))
            setattr(fn, key, None if key == "offset" and number.value == 0 else number.value)
    scale, scale_cell = _scale(cells, st)
    if scale is not None:
        if scale.comma:
            guesses.setdefault(COMMA, scale_cell)
        if scale.alone:
            guesses[UNIT_ALONE] = scale_cell
        fn.multiplier = None if scale.value == 1 else scale.value
    if fn.minimum is not None or fn.maximum is not None:
        _limits(fn, st, guesses, cells)
    units = cells.text("units") if "units" in cols.index else ""
    if cols.scale_has_units:
        fn.units = scale.unit if scale is not None else None
    elif units and units.strip().lower() not in NO_VALUE:
        fn.units = units
    return guesses


def _number_or_none(text: str, decimal: str, what: str) -> Number | None:
    return parse_number(text, decimal, what)


def _scale_of(cells: _Cells, st: RowSettings, key: str) -> Number | None:
    """One scale cell (multiplier or divisor); `x10` read as 10 with a warning unless the INI maps it."""
    cols = cells.cols

    def read(text: str) -> Number | None:
        try:
            return parse_number(text, st.decimal, key, scale=True)
        except CellError:
            if not (cols.scale_has_units and cols.index[key] == cols.index.get("units")):
                raise
            unit = unit_alone(text)
            if unit is None and any(ch.isdigit() for ch in text):
                raise
            return Number(1.0, unit or " ".join(text.split()), alone=True)  # `W`, `ja/nein`: scale 1

    n = cells.read(key, read)
    if n is not None and n.times and key not in cells.mapped:
        cells.problems.append(
            (
                "",
                f"{cols.describe(cols.index[key])} {key} cell {shown(cells.raw(key).strip())} may mean multiply by "
                f"{n.value:g} or stored {n.value:g} times larger (divide by {n.value:g}): read as {key} {n.value:g}; "
                f"map it in [{key} cells] of the INI to say which",
            )
        )
    return n


def _scale(cells: _Cells, st: RowSettings) -> tuple[Number | None, str]:
    """The row's scale as a multiplier (a divisor d gives 1/d), with the unit written after it, and its cell.
    In a column that is both the scale and the units (`10V DC`, `0.01s`), a unit alone (`W`) is scale 1."""
    ix = cells.cols.index
    if "divisor" not in ix:  # most tables: a multiplier column or none, read as below
        m = _scale_of(cells, st, "multiplier") if "multiplier" in ix else None
        if m is not None and m.value == 0:
            cells.problems.append(
                (
                    "",
                    f"{cells.cols.describe(ix['multiplier'])} multiplier {shown(cells.raw('multiplier'))}: "
                    "0 would lose every value; "
                    "multiplier left at its default (the row is kept)",
                )
            )
            return None, ""
        return m, cells.raw("multiplier")
    keys = [key for key in ("multiplier", "divisor") if key in ix]
    given = {key: n for key in keys if (n := _scale_of(cells, st, key)) is not None}
    raw = {key: cells.raw(key) for key in keys}
    if len(given) == 2:
        cells.problems.append(
            (
                "",
                f"both a multiplier ({shown(raw['multiplier'])}) and a divisor ({shown(raw['divisor'])}): "
                "a row is scaled one way, not both; no scale read (the row is kept)",
            )
        )
        return None, ""
    if "divisor" in given:
        d = given["divisor"]
        multiplier = 1.0 / d.value if d.value else 0.0
        if not math.isfinite(multiplier) or multiplier == 0:
            cells.problems.append(
                (
                    "",
                    f"{cells.cols.describe(ix['divisor'])} divisor {shown(raw['divisor'])} "
                    f"{'is 0: no value can be divided by it' if d.value == 0 else 'is out of range'}; "
                    "divisor left at its default (the row is kept)",
                )
            )
            return None, ""
        return Number(multiplier, d.unit, d.comma, d.alone), raw["divisor"]
    m = given.get("multiplier")
    if m is not None and m.value == 0:
        cells.problems.append(
            (
                "",
                f"{cells.cols.describe(ix['multiplier'])} multiplier {shown(raw['multiplier'])}: "
                "0 would lose every value; "
                "multiplier left at its default (the row is kept)",
            )
        )
        return None, ""
    return m, raw.get("multiplier", "")
