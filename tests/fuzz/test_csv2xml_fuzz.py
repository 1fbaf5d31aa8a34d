"""Fuzzing the cell readers and guesses csv2xml gained for published tables (scales with units,
register-type words, access letters, phrase search, the address-base guess) and whole tables in
their shapes (Markdown, VOLTTRON maps, divisor columns, the new INI keys): a result or a CellError /
MdlError with a position, never another exception."""

from __future__ import annotations

import math
import re
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from mdl.cli.csv2xml import run_csv2xml
from mdl.diagnostics import EXIT_INVALID, MdlError
from mdl.formats.mdl import validate_file
from mdl.formats.table.address_base import guess_address_base
from mdl.formats.table.cells import CellError, access_words, parse_access, parse_table, parse_word_order, read_type
from mdl.formats.table.numbers import parse_int, parse_number, unit_alone
from mdl.formats.table.readers.delimited import Row
from mdl.formats.table.scoring import EXACT, FUZZY, NAME_EXACT, NAME_PHRASE, PHRASE, FunctionName, score_pair
from mdl.model import FORMATS

SCALES = [
    "0.1",
    "0,1V",
    "0.01 Hz",
    "-1W",
    "scale(0.1)",
    "mod10k(True)",
    "x10",
    "×10",
    "1/10",
    "1/0",
    "10^-2",
    "10^999",
    "0.1(?)",
    "1.234,5",
    "1,000",
    "1.000.000",
    "1e999",
    "-",
    "n/a",
    "10k",
    "1e-400",
    "0x10",
    "9" * 400,
    "1," + "0" * 50,
    ".5",
    "5.",
    "\u22125",
    "scale()",
    "x",
    "%",
    "°C",
    "1 2",
    "1/-0",
    "+-1",
]
TABLES = [
    "holding",
    "3",
    "FC03",
    "0x04",
    "03/06/16",
    "1/3",
    "fc99",
    "analog_output_holding_registers",
    "discrete_input_contacts",
    "Read Input Registers (FC04)",
    "(0x01)",
    "FC 5",
    "17",
    "",
    "4x",
    "c",
]
ACCESS = ["R", "W", "R/W", "RW", "WO", "TRUE", "false", "yes", "W/R(Reboot)", "r & w", "x", "", "RD", "RD/WR", "R/O"]
TYPES = [
    ">I",
    "<h",
    ">f",
    ">d",
    "<H",
    ">q",
    "!Q",
    "=i",
    ">xB",
    ">Bx",
    "<xb",
    ">B",
    ">Ix",
    ">e",
    "<",
    ">xBx",
    "INT",
    "uint",
    "unsigned int",
    "int16",
    "float",
    "string[8]",
    "char(4)",
    "?",
]
WORD_ORDERS = ["TRUE", "False", "1", "0", "swapped", "big", "little", "CDAB", "badc", "3412", "lsw first", "-", "x"]


def cells(pool: list[str]) -> st.SearchStrategy[str]:
    return (
        st.sampled_from(pool)
        | st.text(max_size=12)
        | st.builds(lambda a, b: a + b, st.sampled_from(pool), st.text(max_size=4))
    )


@settings(max_examples=400, deadline=None)
@given(cells(SCALES), st.sampled_from(["auto", "point", "comma"]), st.booleans())
@example("10^999", "auto", True)
@example("1," + "0" * 50, "auto", True)
def test_number_cells(text, decimal, scale):
    try:
        number = parse_number(text, decimal, "multiplier", scale)
    except CellError as exc:
        assert str(exc)
        return
    assert number is None or math.isfinite(number.value)
    try:
        parse_int(text)
    except CellError:
        pass


@settings(max_examples=400, deadline=None)
@given(cells(TABLES), cells(ACCESS), st.lists(cells(ACCESS), max_size=5))
def test_register_type_and_access_cells(table, access, column):
    try:
        assert parse_table(table) in ("holding", "input", "coil", "discrete")
    except CellError:
        pass
    w_alone = access_words(column)
    try:
        assert parse_access(access, w_alone) in ("read", "write", "read_write")
    except CellError:
        pass


@settings(max_examples=400, deadline=None)
@given(cells(TYPES), cells(WORD_ORDERS), cells(SCALES))
def test_type_word_order_and_unit_cells(type_cell, order_cell, unit_cell):
    try:
        found = read_type(type_cell)
    except CellError as exc:
        assert str(exc)
    else:
        assert found.format in FORMATS and found.order in (None, "big", "little")
        assert found.length in (None, "Lower byte", "Upper byte")
    try:
        said = parse_word_order(order_cell)
    except CellError as exc:
        assert str(exc)
    else:
        assert (said.swapped is None) != (said.word_order is None)
    unit = unit_alone(unit_cell)
    assert unit is None or (unit and not unit[0].isdecimal())


@settings(max_examples=400, deadline=None)
@given(st.text(max_size=20), st.text(max_size=40), st.booleans())
@example("total real power", "TOTAL INSTANTANEOUS REAL POWER", False)
@example("a a", "a - a a", False)
@example("battery state of charge (system)", "x-Battery State of Charge (System)) estimate", True)
def test_scores_stay_in_their_tier(synonym, text, named):
    score = score_pair(FunctionName(synonym) if named else synonym, text)
    assert score.tier in ((NAME_EXACT, NAME_PHRASE, FUZZY) if named else (EXACT, PHRASE, FUZZY))
    assert (0.0 <= score.value <= 1.0) and (score.tier in (EXACT, NAME_EXACT, FUZZY) or 0.9 <= score.value <= 1.0)
    assert score.tier not in (EXACT, NAME_EXACT) or score.value == 1.0


ADDRESS_CELLS = [
    "30001",
    "40001",
    "400001",
    "1",
    "0",
    "3000",
    "33000",
    "30000",
    "20001",
    "65535",
    "99999",
    "1 to 3",
    "0x10",
    "hr:1",
    "40001-40002",
    "",
]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(cells(ADDRESS_CELLS), cells(TABLES)), max_size=12), st.text(max_size=10), st.booleans())
def test_address_base_guess(rows, header, with_types):
    data = [Row(i + 2, [a, t]) for i, (a, t) in enumerate(rows)]
    guess = guess_address_base(data, 0, header, 1 if with_types else None)
    assert guess.base in ("0", "modicon", "hex")


HEADERS = [
    "Address",
    "Register",
    "Description",
    "Name",
    "Register Name",
    "Type",
    "Function",
    "Table",
    "Units",
    "unit",
    "Scale",
    "Scalefactor",
    "Divisor",
    "Transform",
    "Writable",
    "R/W",
    "Count",
    "Length",
    "Bytes",
    "Mixed Endian",
    "Word Order",
]
POOL = (
    SCALES
    + TABLES
    + ACCESS
    + ADDRESS_CELLS
    + TYPES
    + WORD_ORDERS
    + [
        "Room temperature",
        "TOTAL REAL POWER",
        "uint16",
        "float",
        "U32",
        "int16",
        "string[8]",
        "bool",
        "V",
        "kWh",
        "W",
        "10V DC",
        "None",
        "Battery State of Charge (System)",
    ]
)
INI_LINES = [
    "divisor = Divisor",
    "divisor = Scalefactor",
    "multiplier = Scale",
    "multiplier = Divisor",
    "units = unit",
    "multiplier = unit",
    "name = Name",
    "name = Register Name",
    "access = R/W",
    "register_type = Table",
    "addresses = Register",
    "divisor = 9",
    "name = 1",
    "divisor = unit",
    "word_order = Mixed Endian",
    "word_order =",
    "format = Type",
]
IO_LINES = [
    "delimiter = semicolon",
    "delimiter = pipe",
    "delimiter = tab",
    "delimiter = comma",
    "delimiter = ;",
    "decimal_separator = comma",
    "decimal_separator = point",
    "decimal_separator = x",
]


@st.composite
def published_tables(draw: st.DrawFn) -> tuple[str, str]:
    header = draw(st.lists(st.sampled_from(HEADERS), min_size=1, max_size=6, unique=True))
    rows = draw(st.lists(st.lists(cells(POOL), min_size=len(header), max_size=len(header)), max_size=6))
    delimiter = draw(st.sampled_from([",", ";", "\t", "|"]))
    markdown = delimiter == "|" and draw(st.booleans())
    lines = [header, *rows]
    if markdown:
        text = "\n".join("| " + " | ".join(line) + " |" for line in [header, ["---"] * len(header), *rows])
    else:
        text = "\n".join(delimiter.join(c.replace(delimiter, " ").replace('"', "") for c in line) for line in lines)
    ini = (
        "[Column/Field Indices]\n"
        + "\n".join(draw(st.lists(st.sampled_from(INI_LINES), max_size=3, unique_by=lambda x: x.split("=")[0])))
        + "\n[Input/Output]\n"
        + "\n".join(draw(st.lists(st.sampled_from(IO_LINES), max_size=2, unique_by=lambda x: x.split("=")[0])))
        + "\n[Function Name Search Synonyms]\nroom_temperature = room temperature\n"
        "total_power = total real power\nsoc = Battery State of Charge (System)\n"
    )
    return text + "\n", ini


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(published_tables(), st.booleans(), st.booleans())
def test_published_tables_give_valid_mdl_or_positioned_errors(case, emit_all, strict):
    text, ini = case
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        (folder / "t.csv").write_text(text, encoding="utf-8")
        (folder / "t.ini").write_text(ini, encoding="utf-8")
        out = folder / "out.xml"
        try:
            run_csv2xml(folder / "t.csv", folder / "t.ini", out, False, None, emit_all, strict=strict)
        except MdlError as exc:
            assert exc.exit_code == EXIT_INVALID
            for diag in exc.diagnostics:
                assert diag.file and re.match(r"^.+?(:\d+(:\d+)?)?: error: \S", str(diag)), str(diag)
            return
        device, diagnostics = validate_file(out)
        assert device is not None and not [d for d in diagnostics if d.severity == "error"], diagnostics
