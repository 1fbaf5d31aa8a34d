"""One datapoint row of a `.mod` file -> a function: each cell read by the column its heading names,
every bad cell reported at its line and column while the rest of the row is still read."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from fractions import Fraction

from mdl.diagnostics import Collector, TextSpan, record_span
from mdl.exchange.text import unwritable
from mdl.formats.xif import columns as C
from mdl.formats.xif.records import Cell, Record
from mdl.formats.xif.scaling import ScalingError, abc, linear, number, to_float, two_point
from mdl.model import BIT_TABLES, READ_ONLY_TABLES, Function
from mdl.model.addressing import MODICON_TABLE, AddressError, parse_address, whole_number
from mdl.model.layout import MAX_ADDRESS

_WHOLE = re.compile(r"[+-]?[0-9]{1,12}")
_FUNCTION_CODE = re.compile(r"(?i)(?:fc)?\s*0*([0-9]{1,3})")


class CellError(ValueError):
    """A cell that cannot be read; the message says why (the reader adds where)."""


@dataclass
class Columns:
    """The heading: where each column is, and what kind of file it makes."""

    width: int  # the heading's cells
    index: dict[str, int] = field(default_factory=dict)  # column key -> position in a row
    wire_only: bool = False  # a 3.1-format heading: addresses are wire addresses, as releases before 3.5 read them

    def cell(self, record: Record, key: str) -> Cell | None:
        """The row's cell of column `key`: None if the file has no such column; an empty cell
        (positioned after the row's last one) where the row is shorter than the heading."""
        position = self.index.get(key)
        if position is None:
            return None
        if position < len(record.cells):
            return record.cells[position]
        last = record.cells[-1]
        return Cell("", last.line, last.col + len(last.text))


@dataclass
class Point:
    """A datapoint read: its function and what the checks across rows need."""

    fn: Function
    row: Record
    name_cell: Cell
    address_cell: Cell
    block: tuple[str, int]  # (Block Name, Block Index): datapoint names are unique within one
    slot: tuple[str, int, str]  # (table, first address, part of the register): two datapoints may not share one


class RowReader:
    """One datapoint row read into a function; each bad cell reported, the rest still read."""

    def __init__(self, columns: Columns, record: Record, report: Collector, modicon_guessed: list[int]):
        self.columns, self.record, self.report = columns, record, report
        self.modicon_guessed = modicon_guessed  # lines whose address is read as a Modicon number: said once
        self.failed = False

    def error(self, cell: Cell, message: str) -> None:
        self.failed = True
        self.report.error(line=cell.line, col=cell.col, message=message)

    def warn(self, cell: Cell, message: str, kind: str) -> None:
        """A warning of `kind` (a fixed text: said once for all rows that have it)."""
        self.report.warn(message, cell.line, cell.col, kind=kind)

    def text(self, key: str) -> str:
        """A text cell (name, description, Block Name) as `text_cell` reads it; "" if bad (said)."""
        cell = self.cell(key)
        if cell is None or not cell.value:
            return ""
        value = text_cell(cell, cell.value, self.report)
        if value is None:
            self.failed = True
            return ""
        return value

    def cell(self, key: str) -> Cell | None:
        return self.columns.cell(self.record, key)

    def value(self, key: str) -> str:
        cell = self.cell(key)
        return cell.value if cell is not None else ""

    def parse(self, key: str, parse: Callable[[str], object]) -> object:
        """`parse(text)` of the column's cell (None if the column is absent or the cell empty); a
        CellError is reported at the cell and gives None."""
        cell = self.cell(key)
        if cell is None or not cell.value:
            return None
        try:
            return parse(cell.value)
        except (CellError, ScalingError) as exc:
            self.error(cell, f"{C.CURRENT.get(key, key)}: {exc}")
            return None

    def point(self) -> Point | None:
        name_cell = self.cell("name")
        address_cell = self.cell("address")
        assert name_cell is not None and address_cell is not None  # required columns
        name = self.text("name")
        if not name_cell.value:
            self.error(name_cell, "the datapoint has no name")
        code = self.parse("function_code", _function_code)
        modicon = self.parse("modicon", _yes_no)
        unreadable = (code is None and self.value("function_code")) or (modicon is None and self.value("modicon"))
        table_and_address = None if unreadable else self.address(address_cell, code, modicon)
        table = table_and_address[0] if table_and_address else None
        native = self.native(table)
        writable, multiple = self.write_enable(table)
        orders = {key: self.parse(key, _order) for key in ("word_order", "byte_order", "bit_order")}
        precision = self.parse("precision", _whole)
        minimum = self.parse("range_min", _float)
        maximum = self.parse("range_max", _float)
        marker = self.parse("marker", _markers)
        block_index = self.parse("block_index", _index)
        length = self.ascii_length(native)
        scale = self.scaling()
        if self.failed or native is None or table_and_address is None:
            return None
        table, address = table_and_address
        if table in BIT_TABLES and native.format != "BIT":
            self.error(
                self.cell("native") or name_cell,
                f"Native Type {native.name}: a {table} ({C.TABLE_CODES[table]}) holds one bit (use BIT)",
            )
            return None
        fn = Function(name, self.text("description") or name, [address], format=native.format, line=self.record.line)
        record_span(fn, "", TextSpan(name_cell.line, name_cell.col))
        if table != "holding":
            fn.register_type = table
        part = self.orders(fn, native, length, orders)
        self.access(fn, table, writable, multiple)
        self.limits(fn, native, scale, minimum, maximum)
        fn.precision = precision if isinstance(precision, int) else None
        fn.marker = marker if isinstance(marker, list) and marker else None
        block = self.text("block")
        index = block_index if isinstance(block_index, int) else 0
        if block:
            fn.block_labels = [block] + ([f"{block}[{index}]"] if index else [])
        elif index:
            self.warn(
                self.cell("block_index") or name_cell,
                "Block Index without a Block Name; ignored",
                "Block Index without a Block Name, ignored,",
            )
        return Point(fn, self.record, name_cell, address_cell, (block, index), (table, address, part))

    # -- the cells that need more than one column --------------------------------------------------
    def native(self, table: str | None) -> C.Native | None:
        cell = self.cell("native")
        assert cell is not None  # a required column
        text = cell.value
        if not text:
            return C.NATIVE_TYPES["BIT" if table in BIT_TABLES else "UINT16"]
        key = C.NATIVE_ALIASES.get(text, text)
        found = C.NATIVE_TYPES.get(key)
        if found is None:
            upper = C.NATIVE_ALIASES.get(text.upper(), text.upper())
            found = C.NATIVE_TYPES.get(upper)
            if found is not None:
                self.warn(
                    cell,
                    f"Native Type '{text}' read as {found.name} (SmartServer wants upper case)",
                    "Native Types not in upper case, read as the upper-case type,",
                )
        if found is None:
            known = ", ".join([*C.NATIVE_TYPES, *C.NATIVE_ALIASES])
            self.error(cell, f"Native Type: unknown native type '{text[:40]}' (expected one of {known})")
        return found

    def address(self, cell: Cell, code: object, modicon: object) -> tuple[str, int] | None:
        """(table, wire address) from the Address, Function Code and Modicon cells."""
        text = cell.value
        code_table = C.FUNCTION_TABLES[code] if isinstance(code, int) else None
        if not text:
            self.error(cell, "the datapoint has no address")
            return None
        if not (text.isascii() and text.isdigit()):
            self.error(cell, f"Address '{text[:40]}' is not a whole number")
            return None
        wire_only = self.columns.wire_only
        as_modicon = modicon is True
        if modicon is None:  # no function code: a Modicon number; else one only where it names the same table
            as_modicon = code_table is None or (not wire_only and _modicon_table(text) == code_table)
            if as_modicon and code_table is not None:
                self.modicon_guessed.append(self.record.line)
        if as_modicon:
            return self.modicon(cell, code_table)
        if code_table is None:
            self.error(
                cell,
                f"Function Code is blank and Address {text} is a wire address: "
                "give FC01-FC04, or a Modicon address (40001 = holding register 0)",
            )
            return None
        try:
            address = whole_number(text, "address")
        except AddressError as exc:
            self.error(cell, f"Address: {exc}")
            return None
        if address > MAX_ADDRESS:
            self.error(cell, f"Address {address} is over {MAX_ADDRESS}")
            return None
        return code_table, address

    def modicon(self, cell: Cell, code_table: str | None) -> tuple[str, int] | None:
        text = cell.value
        if _modicon_table(text) is None:
            why = "Function Code is blank and " if code_table is None else ""
            self.error(
                cell,
                f"{why}Address {text[:40]} is not a Modicon address (5 or 6 digits, the first 0, 1, 3 "
                "or 4 naming the table: 40001 = holding register 0)"
                + (": give FC01-FC04 for a wire address" if code_table is None else ""),
            )
            return None
        try:
            table, address = parse_address(text)
        except AddressError as exc:
            self.error(cell, f"Address: {exc}")
            return None
        if code_table is not None and code_table != table:
            self.error(
                cell,
                f"Modicon address {text} is a {table} but the Function Code reads the {code_table} "
                f"table ({C.TABLE_CODES[code_table]})",
            )
            return None
        return table, address

    def write_enable(self, table: str | None) -> tuple[bool, bool]:
        cell = self.cell("write")
        assert cell is not None  # a required column
        text = cell.value
        if not text:
            if table not in READ_ONLY_TABLES:
                self.warn(
                    cell, "Write Enable is blank: read as - (read-only)", "Write Enable blank, read as - (read-only),"
                )
            return False, False
        found = C.WRITE_ENABLE.get(text.lower())
        if found is None:
            self.error(cell, f"Write Enable '{text[:40]}' must be -, + or ++ (Direction: R or RW)")
            return False, False
        return found

    def ascii_length(self, native: C.Native | None) -> int | None:
        cell = self.cell("ascii_length")
        if native is None or native.name not in C.STRING_TYPES:
            if cell is not None and cell.value not in ("", "0") and native is not None:
                self.warn(
                    cell,
                    f"ASCII Length ignored: Native Type {native.name} is not a string",
                    "ASCII Length ignored on a Native Type that is not a string",
                )
            return None
        if cell is None or not cell.value:
            self.error(
                cell or self.cell("native") or self.record.cells[0],
                f"Native Type {native.name} needs an ASCII Length (the string's characters)",
            )
            return None
        length = self.parse("ascii_length", _index)
        if isinstance(length, int) and length < 1:
            self.error(cell, "ASCII Length must be 1 or more")
            return None
        return length if isinstance(length, int) else None

    def scaling(self) -> tuple[float, float] | None:
        """(multiplier, offset) from the two points, or the pre-3.2 A', B', C' or Multiplier and Offset."""
        values = {key: self.parse(key, number) for key in (*C.SCALING_POINTS, "a", "b", "c", "multiplier", "offset")}
        given = [key for key in C.SCALING_POINTS if self.value(key)]
        legacy_abc = [key for key in ("a", "b", "c") if self.value(key)]
        legacy_linear = [key for key in ("multiplier", "offset") if self.value(key)]
        cell = self.cell(given[0] if given else "name")
        assert cell is not None
        if not all(isinstance(values[k], Fraction) for k in [*given, *legacy_abc, *legacy_linear]):
            return None  # a number is bad: said at its cell
        try:
            if given:
                if len(given) < 4:
                    names = ", ".join(C.CURRENT[k] for k in C.SCALING_POINTS if k not in given)
                    self.error(
                        cell,
                        f"scaling needs all four of Native Value 1, Native Value 2, Scaled Value 1 "
                        f"and Scaled Value 2; {names} {'is' if len(given) == 3 else 'are'} missing",
                    )
                    return None
                if legacy_abc or legacy_linear:
                    self.warn(
                        cell,
                        "A', B', C' / Multiplier, Offset ignored: the Native and Scaled Values give the scale",
                        "A', B', C' / Multiplier, Offset ignored beside Native and Scaled Values",
                    )
                n1, n2, s1, s2 = (_fraction(values[k]) for k in C.SCALING_POINTS)
                return two_point(n1, n2, s1, s2)
            if legacy_abc:
                a, b, c = (_fraction(values[k], default) for k, default in (("a", 1), ("b", 0), ("c", 0)))
                if legacy_linear:
                    self.warn(
                        cell,
                        "Multiplier and Offset ignored: A', B', C' give the scale",
                        "Multiplier and Offset ignored beside A', B', C'",
                    )
                return abc(a, b, c)
            if legacy_linear:
                return linear(_fraction(values["multiplier"], 1), _fraction(values["offset"], 0))
        except ScalingError as exc:
            self.error(cell, str(exc))
        return None

    def orders(self, fn: Function, native: C.Native, length: int | None, orders: dict[str, object]) -> str:
        """Byte and word order (and a string's registers) into the function; which part of its first
        register the value takes (word, low or high)."""
        word = orders["word_order"]
        byte = orders["byte_order"]
        bit = orders["bit_order"]
        name = native.name
        if bit == "big" and name != "BIT":
            self.warn(
                self.cell("bit_order") or self.record.cells[0],
                "Bit Order big is not supported: bits are read least significant first, so the value "
                "differs from what a SmartServer reads",
                "Bit Order big (not supported)",
            )
        if name == "BIT":
            return C.register_part(native, None)
        if native.chars == 1:  # CHAR8, CHAR16: a character in each register
            fn.count = length
            fn.length = "Upper byte" if byte == "little" else "Lower byte"
            if name == "CHAR16":
                self.warn(
                    self.cell("native") or self.record.cells[0],
                    "CHAR16 read as the low byte of each register: ASCII text reads right, other characters do not",
                    "CHAR16 read as the low byte of each register",
                )
            return C.register_part(native, byte if isinstance(byte, str) else None)
        registers = native.registers
        if native.chars == 2 and length is not None:  # CHAR8_2: two characters in each register
            registers = -(-length // 2)
            fn.count = registers
        if byte == "little":
            fn.byte_order = "little"
        if registers > 1:
            if word == "little":
                fn.word_order = "little"
            elif word is None and byte == "little" and native.format != "STRING":
                self.warn(
                    self.cell("word_order") or self.cell("byte_order") or self.record.cells[0],
                    "Word Order blank read as big (each register's bytes swapped); the vendor page reads "
                    "Byte Order little with a blank Word Order as the whole value little-endian: write Word "
                    "Order little for that",
                    "Word Order blank with Byte Order little, read as big,",
                )
        return C.register_part(native, byte if isinstance(byte, str) else None)

    def access(self, fn: Function, table: str, writable: bool, multiple: bool) -> None:
        if table in READ_ONLY_TABLES:
            if writable:
                self.warn(
                    self.cell("write") or self.record.cells[0],
                    f"{C.TABLE_CODES[table]} datapoints are read-only: Write Enable '{self.value('write')}' ignored",
                    "Write Enable + or ++ on FC02/FC04, ignored,",
                )
            return
        if not writable:
            fn.access = "read"
        elif multiple:
            fn.write_multiple = True

    def limits(
        self, fn: Function, native: C.Native, scale: tuple[float, float] | None, minimum: object, maximum: object
    ) -> None:
        text = native.format == "STRING"
        if scale is not None and scale != (1.0, 0.0):
            if native.format in ("BIT", "STRING"):
                self.warn(
                    self.cell("native_1") or self.cell("a") or self.cell("multiplier") or self.record.cells[0],
                    f"scaling ignored: a {native.name} value is not a number",
                    "scaling ignored on a BIT or string datapoint",
                )
            else:
                fn.multiplier = scale[0] if scale[0] != 1 else None
                fn.offset = scale[1] if scale[1] != 0 else None
        for key, value in (("minimum", minimum), ("maximum", maximum)):
            if not isinstance(value, float):
                continue
            if text:
                self.warn(
                    self.cell("range_min" if key == "minimum" else "range_max") or self.record.cells[0],
                    f"Range ignored: a {native.name} string has no order to bound",
                    "Range ignored on a string datapoint",
                )
                continue
            setattr(fn, key, value)


def text_cell(cell: Cell, value: str, report: Collector) -> str | None:
    """A text cell's value (a name, a description, a Block Name, a product line's): without the `'` mdl
    export puts before a text a spreadsheet would take for a formula (a note says so); None, with an
    error at the cell, if it holds a character MDL (XML) cannot carry."""
    plain = C.unmarked(value)
    if plain is not None:
        report.note(
            f"'{value[:40]}' read as '{plain[:40]}': a leading ' marks a text that a spreadsheet would "
            "take for a formula (mdl export writes it)",
            cell.line,
            cell.col,
            kind="a leading ' (the mark mdl export puts before a text a spreadsheet would run as a formula) removed",
        )
        value = plain
    bad = unwritable(value)
    if bad:
        report.error(
            line=cell.line,
            col=cell.col,
            message=f"'{value[:40]}' holds the character {bad}, which MDL (XML) cannot carry",
        )
        return None
    return value


def _fraction(value: object, default: int | None = None) -> Fraction:
    if isinstance(value, Fraction):
        return value
    assert default is not None
    return Fraction(default)


def _function_code(text: str) -> int:
    m = _FUNCTION_CODE.fullmatch(text)
    code = int(m.group(1)) if m else None
    if code in C.WRITE_CODES:
        raise CellError(
            f"'{text}' is a write function code: give the read one (FC01-FC04); the write code follows from it"
        )
    if code not in C.FUNCTION_TABLES:
        raise CellError(f"'{text[:40]}' is not FC01, FC02, FC03 or FC04")
    return code


def _yes_no(text: str) -> bool:
    t = text.lower()
    if t in ("y", "yes"):
        return True
    if t in ("n", "no"):
        return False
    raise CellError(f"'{text[:40]}' must be Y, N or blank")


def _order(text: str) -> str:
    t = text.lower()
    if t not in C.ORDERS:
        raise CellError(f"'{text[:40]}' must be big, little or blank")
    return t


def _whole(text: str) -> int:
    if not _WHOLE.fullmatch(text):
        raise CellError(f"'{text[:40]}' is not a whole number")
    return int(text)


def _index(text: str) -> int:
    value = _whole(text)
    if value < 0:
        raise CellError(f"'{text}' must be 0 or more")
    return value


def _float(text: str) -> float:
    return to_float(number(text), f"'{text[:40]}'")


def _markers(text: str) -> list[int]:
    out = []
    for token in re.split(r"[\s;|]+", text):
        if not token:
            continue
        try:
            value = number(token)
        except ScalingError:
            value = None
        if value is None and re.fullmatch(r"(?i)0x[0-9a-f]{1,16}", token):
            value = Fraction(int(token, 16))
        if value is None or value.denominator != 1:
            raise CellError(f"'{token[:40]}' is not a whole number")
        out.append(int(value))
    return out


def _modicon_table(text: str) -> str | None:
    """The table a Modicon address names (5 or 6 digits, register number 1 or more), else None."""
    if len(text) not in (5, 6) or not (text.isascii() and text.isdigit()) or text[0] not in MODICON_TABLE:
        return None
    return MODICON_TABLE[text[0]] if int(text[1:]) >= 1 else None
