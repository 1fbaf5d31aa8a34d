"""One table row -> one MDL function (named later, by the matcher or by --all)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from mdl.lang.cfrag import FragmentError, check
from mdl.model import BIT_TABLES, Function
from mdl.model.layout import LayoutError, layout
from mdl.resolve.checks import bound_problems
from mdl.sources.csvmap.cells import (
    CellError,
    hexify,
    is_digits,
    parse_access,
    parse_addresses,
    parse_format,
    parse_length,
    parse_table,
)
from mdl.sources.csvmap.columns import Columns
from mdl.sources.csvmap.numbers import Number, parse_int, parse_number
from mdl.sources.csvmap.table import Row
from mdl.sources.mdlxml.write import unwritable


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


@dataclass
class ParsedRow:
    row: Row
    function: Function
    texts: list[str]  # description and name cells, for matching
    label: str  # what --all names it by
    comma: str | None = None  # a number cell read with a decimal comma nobody asked for


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
    column_table = parse_table(cell(ix["register_type"])) if "register_type" in ix and cell(ix["register_type"]) \
        else None
    if base == "modicon" and column_table == "coil" and is_digits(address_text) and len(address_text) <= 4:
        address_text = address_text.zfill(5)  # coil number 1 is 00001 without its zeros (VOLTTRON's maps)
    try:
        addresses, table = parse_addresses(address_text, base)
    except CellError as exc:
        if base == "modicon" and st.base_guessed:
            raise CellError(f"{exc}, though the column's other addresses are (read as Modicon numbers: "
                            "set address_base = 0 or 1 in [Modbus Device] if they are not)") from None
        raise
    if column_table is not None:
        if table and column_table != table:
            raise CellError(f"address '{address_text}' is a {table} but the register type column says {column_table}")
        table = column_table
    table = table or st.register_type or "holding"

    fmt, strlen = (None, None)
    if "format" in ix and cell(ix["format"]):
        fmt, strlen = parse_format(cell(ix["format"]))
    if table in BIT_TABLES:
        fmt = "BIT" if fmt is not None else None
    length = parse_length(cell(ix["length"])) if "length" in ix and cell(ix["length"]) else None
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
    description = cell(ix.get("description"))
    names = [cell(i) for i in cols.names if cell(i)]
    fn = Function(
        name="", description=description or (names[0] if names else address_text), addresses=addresses,
        length=length if length and length != "Full word" and table not in BIT_TABLES else None,
        count=count if count and count > 1 else None, format=fmt,
        register_type=table if table != "holding" else None,
        byte_order=st.byte_order if st.byte_order == "little" else None,
        word_order=st.word_order if st.word_order == "little" else None,
        line=row.line,
    )
    if "block_label" in ix and cell(ix["block_label"]):
        fn.block_labels = [cell(ix["block_label"])]
    comma = _numbers(row, cols, st, fn)
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
    return ParsedRow(row, fn, [description] + names, names[0] if names else description or address_text, comma)


def _numbers(row: Row, cols: Columns, st: RowSettings, fn: Function) -> str | None:
    """Offset, limits, scale and units onto `fn`; the first cell read with a guessed decimal comma."""
    ix, commas = cols.index, []
    for key in ("offset", "minimum", "maximum"):
        number = parse_number(row.cell(ix[key]), st.decimal, key) if key in ix else None
        if number is not None:
            commas += [row.cell(ix[key])] if number.comma else []
            setattr(fn, key, None if key == "offset" and number.value == 0 else number.value)
    scale, scale_cell = _scale(row, ix, st)
    if scale is not None:
        commas += [scale_cell] if scale.comma else []
        fn.multiplier = None if scale.value == 1 else scale.value
    if cols.scale_has_units:
        fn.units = scale.unit if scale is not None else None
    elif "units" in ix and row.cell(ix["units"]):
        fn.units = row.cell(ix["units"])
    return commas[0] if commas else None


def _scale(row: Row, ix: dict[str, int], st: RowSettings) -> tuple[Number | None, str]:
    """The row's scale as a multiplier (a divisor d gives 1/d), with the unit written after it, and its cell."""
    cells = {key: row.cell(ix[key]) for key in ("multiplier", "divisor") if key in ix}
    given = {key: n for key, text in cells.items() if (n := parse_number(text, st.decimal, key, scale=True))}
    if len(given) == 2:
        raise CellError(f"both a multiplier ('{cells['multiplier']}') and a divisor ('{cells['divisor']}'): "
                        "a row is scaled one way, not both")
    if "divisor" in given:
        d = given["divisor"]
        if d.value == 0:
            raise CellError(f"divisor '{cells['divisor']}' is 0: no value can be divided by it")
        multiplier = 1.0 / d.value
        if not math.isfinite(multiplier) or multiplier == 0:
            raise CellError(f"divisor '{cells['divisor']}' is out of range")
        return Number(multiplier, d.unit, d.comma), cells["divisor"]
    m = given.get("multiplier")
    if m is not None and m.value == 0:
        raise CellError("multiplier 0 would lose every value")
    return m, cells.get("multiplier", "")
