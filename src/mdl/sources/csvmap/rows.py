"""One table row -> one MDL function (named later, by the matcher or by --all)."""

from __future__ import annotations

import re
from dataclasses import dataclass

from mdl.lang.cfrag import FragmentError, check
from mdl.model import BIT_TABLES, Function
from mdl.model.layout import LayoutError, layout
from mdl.resolve.checks import bound_problems
from mdl.sources.csvmap.cells import (
    CellError,
    is_modicon_number,
    parse_access,
    parse_addresses,
    parse_format,
    parse_int,
    parse_length,
    parse_number,
    parse_table,
)
from mdl.sources.csvmap.columns import Columns
from mdl.sources.csvmap.table import Row
from mdl.sources.mdlxml.write import unwritable

_TOKENS = re.compile(r"[0-9A-Za-z:x]+")


@dataclass
class RowSettings:
    address_base: str  # 0 | 1 | modicon | hex
    count_unit: str  # words | bytes
    register_type: str | None
    byte_order: str | None
    word_order: str | None
    decimal_comma: bool


def guess_address_base(rows: list[Row], index: int, hex_header: bool) -> str:
    """'modicon' when every plain number of the address column is a Modicon 5/6-digit number."""
    if hex_header:
        return "hex"
    tokens = [t for r in rows for t in re.findall(r"\d+", r.cell(index)) if not re.search(r"[A-Za-z:]", r.cell(index))]
    if tokens and all(is_modicon_number(t) for t in tokens):
        return "modicon"
    return "0"


def _hexify(text: str) -> str:
    return re.sub(r"(?i)(?<![\w:])(?:0x)?([0-9a-f]+)(?!\w)", lambda m: "0x" + m.group(1), text)


@dataclass
class ParsedRow:
    row: Row
    function: Function
    texts: list[str]  # description and name cells, for matching
    label: str  # what --all names it by


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
        address_text, base = _hexify(address_text), "0"
    addresses, table = parse_addresses(address_text, base)
    if "register_type" in ix and cell(ix["register_type"]):
        column_table = parse_table(cell(ix["register_type"]))
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
    for key in ("multiplier", "offset", "minimum", "maximum"):
        if key in ix and cell(ix[key]):
            value = parse_number(cell(ix[key]), st.decimal_comma, key)
            if key == "multiplier" and value == 0:
                raise CellError("multiplier 0 would lose every value")
            neutral = (key == "multiplier" and value == 1) or (key == "offset" and value == 0)
            setattr(fn, key, None if neutral else value)
    if "units" in ix and cell(ix["units"]):
        fn.units = cell(ix["units"])
    if "access" in ix and cell(ix["access"]):
        access = parse_access(cell(ix["access"]))
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
    return ParsedRow(row, fn, [description] + names, names[0] if names else description or address_text)
