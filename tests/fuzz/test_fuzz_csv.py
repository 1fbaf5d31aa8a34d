"""Fuzzing `mdl csv2xml` with hostile vendor tables and INI files: a run ends with MDL that validates
(XSD and semantic checks), or with errors that name the file (`FILE:LINE:COL: error: ...`, exit 1);
never with a traceback, another exception or another exit status."""

from __future__ import annotations

import csv
import io
import re
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from mdl.cli.csv2xml import run_csv2xml
from mdl.diagnostics import EXIT_INVALID, MdlError
from mdl.formats.mdl import validate_file
from support.run import assert_clean_error, run_mdl

# the cells of each kind of column, (common, rare): mostly plausible cells, so that rows get deep
ADDRESSES = (
    [
        "0",
        "1",
        "2",
        "7",
        "100",
        "101",
        "40001",
        "400001",
        "30010",
        "10001",
        "0x10",
        "10h",
        "hr:2..hr:5",
        "hr:2#4",
        "0 to 3",
        "22to100",
        "17,18,19",
        "4x0102",
        "3x0001",
        "1x2",
        "c:1",
        "di:1",
        "400001#2",
    ],
    [
        "hr:2#99999999999",
        "0 to 99999999999",
        "0x0 to 0xFFFFFFFFFF",
        "0x" + "F" * 5000,
        "566 - 583",
        "-1",
        "65535",
        "65536",
        "\u00b2",
        "\u0663",
        "1\u00b2",
        "9" * 5000,
        "0" * 300 + "1",
        "1e3",
        " ",
        "",
        "hr:",
        "#",
        "to",
        "1..",
        "..2",
        "5-2",
        "1,1",
        "ir:0#0",
        "hr:1 and hr:3",
        "4&5",
        "7/8",
        "\u2013",
        "FFFFh",
    ],
)
DESCRIPTIONS = (
    [
        "Room temperature",
        "Setpoint",
        "Fan speed",
        "Phase 1 voltage",
        "Serial number",
        "Humidity",
        "Firmware version",
        "temperature",
        "Operating mode",
        "CO2",
    ],
    ["", "\u00b2", "x" * 300],
)
FORMATS = (
    [
        "UINT16",
        "int16",
        "float",
        "FLOAT64",
        "IEEE754 float",
        "string[8]",
        "STR",
        "bool",
        "uint64",
        "bit",
        "text",
        "int8",
        "dword",
        "char[4]",
        "uint32",
        "",
    ],
    [
        "char(0)",
        "string99999999999",
        "string" + "9" * 5000,
        "ascii\u00b2",
        "string\u0663",
        "?",
        ">I",
        "<h",
        ">xB",
        ">B",
        "=q",
        ">Ix",
        "<d",
        "INT",
    ],
)
WORD_ORDERS = (["TRUE", "FALSE", ""], ["CDAB", "little", "sideways", "\u00b2"])
NUMBERS = (
    ["0", "1", "0.1", "0,1", "10", "-40", "1/10", "x10", ""],
    [
        "1.234,5",
        "1/0",
        "0/0",
        "1e999",
        "-1e999",
        "nan",
        "inf",
        "\u22125",
        "\u0661",
        "99999999999",
        "9" * 5000,
        "abc",
        "1e-400",
        "-0",
    ],
)
COUNTS = (
    ["1", "2", "4", ""],
    ["0", "-1", "125", "126", "2000", "99999999999", "1e300", "0x10", "1.5", "\u00b2", "9" * 5000],
)
LENGTHS = (["Lower byte", "Upper byte", "Full word", ""], ["low", "hi", "16 bit", "x", "2"])
ACCESS = (["R", "W", "R/W", "rw", "read only", ""], ["x", "\u00b2"])
TABLES = (["holding", "input", "coil", "discrete", "FC03", "3", ""], ["fc05", "\u00b2", "4x", "x"])
UNITS = (["\u00b0C", "%", "V", "kWh", ""], ["\u00b2"])
NOTES = (["see page 3", ""], ["#comment", '"', '""', "a\nb", "\r", "\ufeff", "\x85", "\u2028"])
COLUMNS = {  # a header text -> the cells its column holds
    "Address": ADDRESSES,
    "Register": ADDRESSES,
    "Reg No": ADDRESSES,
    "Modbus Address": ADDRESSES,
    "Address (hex)": ADDRESSES,
    "Offset": ADDRESSES,
    "Description": DESCRIPTIONS,
    "Parameter": DESCRIPTIONS,
    "Name": DESCRIPTIONS,
    "Tag": DESCRIPTIONS,
    "Format": FORMATS,
    "Data Type": FORMATS,
    "Type": (FORMATS[0] + TABLES[0], FORMATS[1] + TABLES[1]),
    "Count": COUNTS,
    "Words": COUNTS,
    "Bytes": COUNTS,
    "Length": (LENGTHS[0], LENGTHS[1] + COUNTS[1]),
    "Multiplier": NUMBERS,
    "Scale": NUMBERS,
    "Units": UNITS,
    "Access": ACCESS,
    "R/W": ACCESS,
    "Block": DESCRIPTIONS,
    "Register Type": TABLES,
    "Function Code": TABLES,
    "Min": NUMBERS,
    "Max": NUMBERS,
    "Value Offset": NUMBERS,
    "Notes": NOTES,
    "Mixed Endian": WORD_ORDERS,
}
ANY_CELL = st.sampled_from(sorted({cell for pair in COLUMNS.values() for cells in pair for cell in cells})) | st.text(
    max_size=10
)


def often(common: list, rare: list) -> st.SearchStrategy:
    """Mostly one of `common`, sometimes one of `rare`."""
    return st.sampled_from(common * 4 + rare)


def cell_of(header: str) -> st.SearchStrategy[str]:
    return often(*COLUMNS[header]) if header in COLUMNS else ANY_CELL


@st.composite
def tables(draw: st.DrawFn) -> bytes:
    """A vendor's CSV: titles, a header, rows of cells that fit (or not) their columns, comments;
    any delimiter, quoting, line end and encoding."""
    delimiter = draw(st.sampled_from([",", ";", "\t", "|"]))
    header = draw(st.lists(st.sampled_from(list(COLUMNS)) | st.text(max_size=8), max_size=6))
    if draw(st.integers(0, 4)):  # mostly a header csv2xml recognizes
        for name in ("Address", "Description"):
            header.insert(draw(st.integers(0, len(header))), name)
    header = header or ["Address"]
    titles = draw(st.lists(st.lists(ANY_CELL, max_size=3), max_size=2))
    data = draw(
        st.lists(
            st.tuples(*(st.one_of(cell_of(h), cell_of(h), cell_of(h), ANY_CELL) for h in header)).map(list), max_size=8
        )
    )
    lines = [*titles, header, *data]
    if draw(st.booleans()):
        buf = io.StringIO()
        quoting = draw(st.sampled_from([csv.QUOTE_MINIMAL, csv.QUOTE_ALL, csv.QUOTE_NONNUMERIC]))
        csv.writer(buf, delimiter=delimiter, quoting=quoting, lineterminator="\n").writerows(lines)
        text = buf.getvalue()
    else:  # joined raw: stray quotes and delimiters inside cells
        text = "\n".join(delimiter.join(line) for line in lines)
    text = text.replace("\n", draw(st.sampled_from(["\n", "\r\n", "\r"])))
    encoding = draw(often(["utf-8"], ["utf-8-sig", "cp1252", "utf-16"]))
    return text.encode(encoding, errors="replace") + draw(often([b""], [b"\xff\xfe", b"\x81", b"\x00"]))


SECTIONS = [
    "Modbus Device",
    "Input/Output",
    "Column/Field Indices",
    "Additional Column/Field Indices",
    "Function Name Search Synonyms",
    "modbus device",
    "Other",
]
KEYS = [
    "name",
    "description",
    "addresses",
    "length",
    "count",
    "format",
    "block_label",
    "multiplier",
    "units",
    "divisor",
    "read_function_code",
    "write_function_code",
    "register_type",
    "access",
    "minimum",
    "maximum",
    "offset",
    "device_name",
    "device_description",
    "address_base",
    "byte_order",
    "word_order",
    "count_unit",
    "threshold",
    "default_synonyms",
    "address_map_csv_file",
    "lines_to_skip",
    "output_xml_file",
    "temperature",
    "setpoint",
    "fan_speed",
    "operation_info",
]
VALUES = [
    "0",
    "1",
    "2",
    "3",
    "7",
    "\u00b2",
    "\u0663",
    "9" * 5000,
    "",
    "yes",
    "no",
    "big",
    "little",
    "modicon",
    "words",
    "bytes",
    "holding",
    "coil",
    "0.5",
    "2",
    "-1",
    "nan",
    "Address",
    "Description",
    "Format",
    "temperature, room temperature",
    ",",
    "table.csv",
    "missing.csv",
    ".",
    "..",
    "/",
    "out.xml",
    "x*2",
    "r[0]",
    "(",
    "1/0",
    "\u00b0C",
]


@st.composite
def inis(draw: st.DrawFn) -> str:
    """A device INI: known and unknown sections and keys, hostile values, sometimes not an INI at all."""
    lines: list[str] = []
    sections = draw(st.lists(often(SECTIONS, ["", "DEFAULT"]) | st.text(max_size=6), max_size=4, unique=True))
    if "Input/Output" not in sections and draw(st.integers(0, 3)):
        sections.insert(0, "Input/Output")
    for section in sections:
        lines.append(f"[{section}]")
        if section == "Input/Output" and draw(st.integers(0, 3)):
            lines.append("address_map_csv_file = table.csv")
        for key in draw(st.lists(st.sampled_from(KEYS) | st.text(max_size=6), max_size=5, unique=True)):
            if key != "address_map_csv_file" or section != "Input/Output":
                value = draw(st.sampled_from(VALUES) | st.text(max_size=8))
                lines.append(f"{key} {draw(st.sampled_from(['=', ':', ' = ']))} {value}")
    if draw(st.integers(0, 9)) == 0:
        lines.insert(draw(st.integers(0, len(lines))), draw(st.text(max_size=20)))
    return "\n".join(lines) + "\n"


def assert_positioned(exc: MdlError) -> None:
    """Exit 1, and every message names a file (with its line and column where known)."""
    assert exc.exit_code == EXIT_INVALID, exc
    for diag in exc.diagnostics:
        assert diag.severity == "error" and diag.file and diag.message, str(diag)
        assert re.match(r"^.+?(:\d+(:\d+)?)?: error: \S", str(diag)), str(diag)


def convert(
    folder: Path, table: bytes, ini: str | None, ini_names_table: bool, threshold: float | None, emit_all: bool
) -> None:
    """`mdl csv2xml` in process: output that validates, or MdlError with positions."""
    source = folder / "table.csv"
    source.write_bytes(table)
    ini_path = None
    if ini is not None:
        ini_path = folder / "device.ini"
        ini_path.write_text(ini, encoding="utf-8", errors="surrogatepass")
    if ini_path is not None and ini_names_table:
        source, ini_path = ini_path, None  # the `mdl csv2xml DEVICE.ini` form
    output = folder / "out.xml"
    try:
        run_csv2xml(source, ini_path, output, False, threshold, emit_all)
    except MdlError as exc:
        assert_positioned(exc)
        event(re.sub(r"'.*'|\d+", "_", exc.diagnostics[0].message)[:50])  # --hypothesis-show-statistics
        return
    event("valid MDL")
    device, diagnostics = validate_file(output)
    assert device is not None and not [d for d in diagnostics if d.severity == "error"], diagnostics


ROOM = b"Address,Description\n0,Room temperature\n"


@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tables(), st.none() | inis(), st.booleans(), st.none() | st.floats(0, 1), st.booleans())
# crashes the fuzzer found, or that its pools were built to find, fixed since:
@example(ROOM + b"1,\x1b\n", None, False, None, True)  # a control character in an emitted description
@example(ROOM + b"1,Setpoint,\n", "[Modbus Device]\ndevice_name = a\x1bb\n", False, None, False)  # in the name
@example(b"Address", "[Input/Output]\naddress_map_csv_file = table.csv\n = 0\n", True, None, False)  # continued
@example(ROOM + "\u00b2,Setpoint\n".encode(), None, False, None, False)  # '²'.isdigit(), but int('²') fails
@example(ROOM + b"9" * 5000 + b",Setpoint\n", None, False, None, False)  # more digits than int() converts
@example(ROOM + b"hr:2#99999999999,Setpoint\n", None, False, None, False)  # a run built before it was checked
@example(ROOM + b"0x0 to 0xFFFFFFFFFF,Setpoint\n", None, False, None, False)
@example(ROOM + b"0x" + b"F" * 5000 + b",Setpoint\n", None, False, None, False)  # a number str() cannot print
@example(b"Address,Description,Format\n0,Room temperature,string" + b"9" * 5000 + b"\n", None, False, None, False)
@example(b"Address,Description,Register Type\n0,Room temperature,\xc2\xb2\n", None, False, None, False)
@example(ROOM, "[Column/Field Indices]\naddresses = \u00b2\n", False, None, False)
@example(ROOM, "[Input/Output]\nlines_to_skip = \u00b2\n", False, None, False)
@example(ROOM, "[Additional Column/Field Indices]\nnotes = " + "9" * 5000 + "\n", False, None, False)
def test_csv2xml_gives_valid_mdl_or_positioned_errors(table, ini, ini_names_table, threshold, emit_all):
    with tempfile.TemporaryDirectory() as folder:
        convert(Path(folder), table, ini, ini_names_table, threshold, emit_all)


HOSTILE = {  # a handful through the command line, as users meet them
    "binary": (b"\x89PNG\r\n\x1a\n\x00\x00", None),
    "huge_run": (b"Address,Description,Format\nhr:2#99999999999,Room temperature,UINT16\n", None),
    "long_digits": (b"Address,Description\n" + b"9" * 5000 + b",Room temperature\n", None),
    "unicode_digit_index": (
        b"Address,Description\n1,Room temperature\n",
        "[Column/Field Indices]\naddresses = \u00b2\n",
    ),
    "stray_quote": (b'Address,Description\n1,"Room temperature\n2,Setpoint\n', None),
    "control_character_in_name": (ROOM, "[Modbus Device]\ndevice_name = a\x1bb\n"),
    "continued_value": (ROOM, "[Input/Output]\nlines_to_skip = 1\n  2\n"),
}


@pytest.mark.parametrize("case", HOSTILE)
def test_cli_on_hostile_tables(case, tmp_path):
    table, ini = HOSTILE[case]
    (tmp_path / "table.csv").write_bytes(table)
    args = ["csv2xml", tmp_path / "table.csv"]
    if ini is not None:
        (tmp_path / "device.ini").write_text(ini, encoding="utf-8")
        args += ["--ini", tmp_path / "device.ini"]
    proc = run_mdl(*args, "-o", tmp_path / "out.xml")
    if proc.returncode == 0:
        assert run_mdl("validate", tmp_path / "out.xml").returncode == 0
        return
    assert_clean_error(proc, 1)
    for line in proc.stderr.splitlines():
        assert re.match(r"^.+?(:\d+(:\d+)?)?: (error|warning): \S", line), line
