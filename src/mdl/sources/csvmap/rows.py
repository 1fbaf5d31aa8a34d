"""One table row -> one MDL function (named later, by the matcher or by --all)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from mdl.exchange.text import unwritable
from mdl.lang.cfrag import FragmentError, check
from mdl.model import BIT_TABLES, Function
from mdl.model.layout import LayoutError, layout
from mdl.resolve.checks import bound_problems
from mdl.sources.csvmap.cells import (
    CellError,
    TypeCell,
    hexify,
    is_digits,
    parse_access,
    parse_addresses,
    parse_length,
    parse_table,
    parse_word_order,
    read_type,
)
from mdl.sources.csvmap.columns import Columns
from mdl.sources.csvmap.numbers import NO_VALUE, Number, parse_int, parse_number, unit_alone
from mdl.sources.csvmap.table import Row


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


# what a row may have had to guess, said once per table with the first cell read so (convert.py)
COMMA, UNIT_ALONE, WIDTHLESS, NATIVE = "comma", "unit alone", "widthless", "native"


@dataclass
class ParsedRow:
    row: Row
    function: Function
    texts: list[str]  # description and name cells, for matching
    label: str  # what --all names it by
    guesses: dict[str, str]  # COMMA, UNIT_ALONE ... -> the cell read so


def row_texts(row: Row, cols: Columns) -> list[str]:
    """The row's description and name cells, for matching (also of a row that cannot be read)."""
    return [row.cell(cols.index.get("description"))] + [row.cell(i) for i in cols.names if row.cell(i)]


def _check_writable(fn: Function) -> None:
    """CellError for a text no MDL document can hold (a control character in a description)."""
    texts = [(key, getattr(fn, key)) for key in ("description", "units", "read_function_code", "write_function_code")]
    for what, text in texts + [("block label", label) for label in fn.block_labels]:
        bad = unwritable(text) if text else None
        if bad:
            raise CellError(f"the {what} holds the character {bad}, which MDL (XML) cannot carry")


def parse_row(row: Row, cols: Columns, st: RowSettings) -> ParsedRow | None:
    """None for rows without an address (section titles, notes); CellError for bad rows."""
    cell = row.cell
    ix = cols.index
    address_text = cell(ix.get("addresses"))
    if not address_text:
        return None
    base = st.address_base
    if base == "hex":
        address_text, base = hexify(address_text), "0"
    column_table = (
        parse_table(cell(ix["register_type"])) if "register_type" in ix and cell(ix["register_type"]) else None
    )
    if base == "modicon" and column_table == "coil" and is_digits(address_text) and len(address_text) <= 4:
        address_text = address_text.zfill(5)  # coil number 1 is 00001 without its zeros (VOLTTRON's maps)
    try:
        addresses, table = parse_addresses(address_text, base)
    except CellError as exc:
        if base == "modicon" and st.base_guessed:
            raise CellError(
                f"{exc}, though the column's other addresses are (read as Modicon numbers: "
                "set address_base = 0 or 1 in [Modbus Device] if they are not)"
            ) from None
        raise
    if column_table is not None:
        if table and column_table != table:
            raise CellError(f"address '{address_text}' is a {table} but the register type column says {column_table}")
        table = column_table
    table = table or st.register_type or "holding"

    typed = read_type(cell(ix["format"])) if "format" in ix and cell(ix["format"]) else None
    fmt, strlen = (typed.format, typed.strlen) if typed else (None, None)
    if table in BIT_TABLES:
        fmt = "BIT" if fmt is not None else None
    length = parse_length(cell(ix["length"])) if "length" in ix and cell(ix["length"]) else None
    if typed and typed.length:
        if length not in (None, typed.length):
            raise CellError(
                f"format '{cell(ix['format'])}' is the {typed.length.lower()} but the length column says {length}"
            )
        length = typed.length
    unit_bits = 16 if (length or "Full word") == "Full word" else 8
    count = None
    if len(addresses) > 1:
        count = len(addresses)
    elif strlen:
        count = -(-strlen * 8 // unit_bits)
    elif "count" in ix and cell(ix["count"]):
        n = parse_int(cell(ix["count"]))
        if n < 1:
            raise CellError(f"count '{cell(ix['count'])}' must be 1 or more")
        count = -(-n * 8 // unit_bits) if st.count_unit == "bytes" else n
    if fmt is None and table not in BIT_TABLES and unit_bits == 16:
        fmt = {1: "UINT16", 2: "UINT32", 4: "UINT64"}.get(count or 1)
    texts = row_texts(row, cols)
    description, names = texts[0], texts[1:]
    byte_order, word_order, own_order = _orders(row, cols, st, typed)
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
        line=row.line,
    )
    if "block_label" in ix and cell(ix["block_label"]):
        fn.block_labels = [cell(ix["block_label"])]
    guesses = _numbers(row, cols, st, fn)
    if "access" in ix and cell(ix["access"]):
        access = parse_access(cell(ix["access"]), st.w_alone)
        default = "read" if table in ("input", "discrete") else "read_write"
        if access != default:
            if table in ("input", "discrete"):
                raise CellError(f"access '{cell(ix['access'])}' is impossible for a {table}")
            fn.access = access
    try:
        lay = layout(fn)
    except LayoutError as exc:
        raise CellError(str(exc)) from None
    if own_order and table in BIT_TABLES:  # a bit has no order: a Mixed Endian cell on a coil row says nothing
        fn.byte_order = fn.word_order = None
    if len(lay.addresses) == 1:
        if own_order:
            fn.word_order = None  # nor has one register a word order
        if typed and typed.widthless and lay.unit == "word":
            guesses[WIDTHLESS] = cell(ix["format"])
    if typed and typed.native:
        guesses[NATIVE] = cell(ix["format"])
    for problem in bound_problems(fn, lay):
        raise CellError(problem)
    for key in ("read_function_code", "write_function_code"):
        if key in ix and cell(ix[key]):
            try:
                check(cell(ix[key]), len(lay.addresses))
            except FragmentError as exc:
                raise CellError(f"{key}: {exc}") from None
            setattr(fn, key, cell(ix[key]))
    _check_writable(fn)
    return ParsedRow(row, fn, texts, names[0] if names else description or address_text, guesses)


def _flip(order: str) -> str:
    return "big" if order == "little" else "little"


def _orders(row: Row, cols: Columns, st: RowSettings, typed: TypeCell | None) -> tuple[str | None, str | None, bool]:
    """(byte order, word order, whether the row itself said the word order). A struct type's prefix
    gives both orders of its row (`<` reverses every byte); a word-order column (`Mixed Endian`)
    reverses the registers from the type's own order (TRUE), keeps it (FALSE), or names the order;
    otherwise the INI's [Modbus Device] orders."""
    byte_order = typed.order if typed and typed.order else st.byte_order
    word_order = typed.order if typed and typed.order else st.word_order
    own = bool(typed and typed.order)
    i = cols.index.get("word_order")
    text = row.cell(i) if i is not None else ""
    if text and text.strip().lower() not in NO_VALUE:
        said = parse_word_order(text)
        if said.swapped is not None:
            type_order = typed.order if typed and typed.order else "big"
            word_order = _flip(type_order) if said.swapped else type_order
        else:
            word_order = said.word_order
            byte_order = said.byte_order or byte_order
        own = True
    return byte_order, word_order, own


def _numbers(row: Row, cols: Columns, st: RowSettings, fn: Function) -> dict[str, str]:
    """Offset, limits, scale and units onto `fn`; what was guessed (a decimal comma, a unit alone in a
    scale column) with the cell."""
    ix, guesses = cols.index, dict[str, str]()
    for key in ("offset", "minimum", "maximum"):
        number = parse_number(row.cell(ix[key]), st.decimal, key) if key in ix else None
        if number is not None:
            if number.comma:
                guesses.setdefault(COMMA, row.cell(ix[key]))
            setattr(fn, key, None if key == "offset" and number.value == 0 else number.value)
    scale, scale_cell = _scale(row, cols, st)
    if scale is not None:
        if scale.comma:
            guesses.setdefault(COMMA, scale_cell)
        if scale.alone:
            guesses[UNIT_ALONE] = scale_cell
        fn.multiplier = None if scale.value == 1 else scale.value
    if cols.scale_has_units:
        fn.units = scale.unit if scale is not None else None
    elif "units" in ix and row.cell(ix["units"]) and row.cell(ix["units"]).strip().lower() not in NO_VALUE:
        fn.units = row.cell(ix["units"])
    return guesses


def _scale(row: Row, cols: Columns, st: RowSettings) -> tuple[Number | None, str]:
    """The row's scale as a multiplier (a divisor d gives 1/d), with the unit written after it, and its cell.
    In a column that is both the scale and the units (`10V DC`, `0.01s`), a unit alone (`W`) is scale 1."""
    ix = cols.index
    cells = {key: row.cell(ix[key]) for key in ("multiplier", "divisor") if key in ix}
    given: dict[str, Number] = {}
    for key, text in cells.items():
        try:
            n = parse_number(text, st.decimal, key, scale=True)
        except CellError:
            unit = unit_alone(text) if cols.scale_has_units and ix[key] == ix.get("units") else None
            if unit is None:
                raise
            n = Number(1.0, unit, alone=True)
        if n is not None:
            given[key] = n
    if len(given) == 2:
        raise CellError(
            f"both a multiplier ('{cells['multiplier']}') and a divisor ('{cells['divisor']}'): "
            "a row is scaled one way, not both"
        )
    if "divisor" in given:
        d = given["divisor"]
        if d.value == 0:
            raise CellError(f"divisor '{cells['divisor']}' is 0: no value can be divided by it")
        multiplier = 1.0 / d.value
        if not math.isfinite(multiplier) or multiplier == 0:
            raise CellError(f"divisor '{cells['divisor']}' is out of range")
        return Number(multiplier, d.unit, d.comma, d.alone), cells["divisor"]
    m = given.get("multiplier")
    if m is not None and m.value == 0:
        raise CellError("multiplier 0 would lose every value")
    return m, cells.get("multiplier", "")
