"""A new user's first hour with their own files (issue 20, reading them): a Latin-1 table and a
`Modbus Protocol Start Address Hex` header are read and said; an unreadable file is exit 1 in mdl's
words, as a missing one; XSD errors name their column; an XML command given a CSV, an INI or a .mod
says what the file looks like and which command reads it; a long csv2xml run shows progress on a
terminal, without long silences, and nothing elsewhere."""

from __future__ import annotations

import builtins
import errno
import io
import os
import random
import re
import shutil
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.diagnostics import MdlError
from mdl.formats.mdl.parse import parse_source, schema_errors
from mdl.formats.sniff import not_xml
from mdl.formats.table.readers.delimited import (
    HEADER_SYNONYMS,
    QUALIFIERS,
    Row,
    decode_table,
    header_score,
    normalize_header,
    synonym_rank,
)
from support.common import EXAMPLE, MDL_NS
from support.run import assert_clean_error, cli, run_mdl
from support.tables import functions

# --- a Latin-1 (cp1252) table -------------------------------------------------------------------------

LATIN1_TABLE = (
    "Modbus Protocol Start Address Hex;Description;Data Type;Unit\n"
    "0010;Température extérieure (outdoor temperature);INT16;°C\n"
    "001A;Room temperature;INT16;°C\n"
).encode("cp1252")


def test_a_latin1_table_is_read_and_the_guess_said(tmp_path):
    table = tmp_path / "map.csv"
    table.write_bytes(LATIN1_TABLE)
    proc = cli("csv2xml", table, "--all")
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if "Windows-1252" in line]
    assert notes == [
        f"{table}: note: not UTF-8 (byte 0xe9 on line 2, column 10): read as Windows-1252 (cp1252, "
        "the Latin-1 of Windows exports), where that byte is 'é'; set encoding = cp1252 in "
        "[Input/Output] of a device INI (--ini) to say so, or encoding = NAME for another (latin-1, "
        "cp1250, utf-16 ...)"
    ], proc.stderr
    fns = functions(proc.stdout)
    assert fns["outdoor_temperature"]["description"] == "Température extérieure (outdoor temperature)"
    assert fns["outdoor_temperature"]["units"] == "°C"


def _ini(folder: Path, io_lines: str = "") -> Path:
    ini = folder / "device.ini"
    ini.write_text(
        "[Modbus Device]\ndevice_name = Heat pump\n\n[Input/Output]\naddress_map_csv_file = map.csv\n"
        f"{io_lines}\n[Function Name Search Synonyms]\noutdoor_temperature = outdoor temperature\n"
        "room_temperature = room temperature\n",
        encoding="utf-8",
    )
    return ini


@pytest.mark.parametrize("encoding", ["cp1252", "latin-1", "CP1252", "windows-1252"])
def test_the_ini_states_the_encoding_and_nothing_is_guessed(tmp_path, encoding):
    (tmp_path / "map.csv").write_bytes(LATIN1_TABLE)
    proc = cli("csv2xml", _ini(tmp_path, f"encoding = {encoding}\n"), "-o", "-")
    assert proc.returncode == 0, proc.stderr
    assert "UTF-8" not in proc.stderr and "encoding" not in proc.stderr
    assert functions(proc.stdout)["outdoor_temperature"]["units"] == "°C"


def test_an_ini_that_says_utf8_gets_the_byte_that_is_not(tmp_path):
    (tmp_path / "map.csv").write_bytes(LATIN1_TABLE)
    proc = cli("csv2xml", _ini(tmp_path, "encoding = utf-8\n"), "-o", "-")
    assert_clean_error(proc, 1, f"{tmp_path / 'map.csv'}:2:10: error: cannot decode byte 0xe9 as utf-8")
    assert proc.stdout == ""


@pytest.mark.parametrize("value", ["klingon", "base64", "rot13"])
def test_an_encoding_that_is_no_text_encoding_is_an_error_on_its_line(tmp_path, value):
    (tmp_path / "map.csv").write_bytes(LATIN1_TABLE)
    ini = _ini(tmp_path, f"encoding = {value}\n")
    proc = cli("csv2xml", ini, "-o", "-")
    assert_clean_error(proc, 1, f"{ini}:6: error: encoding must name a text encoding", f"not '{value}'")


def test_a_utf16_table_with_its_bom_is_read_and_said(tmp_path):
    table = tmp_path / "map.txt"
    table.write_bytes(LATIN1_TABLE.decode("cp1252").replace(";", "\t").encode("utf-16"))  # Excel "Unicode text"
    proc = cli("csv2xml", table, "--all")
    assert proc.returncode == 0, proc.stderr
    assert "note: read as UTF-16 (the file starts with its byte order mark)" in proc.stderr
    assert functions(proc.stdout)["room_temperature"]["units"] == "°C"


def test_a_table_neither_utf8_nor_cp1252_is_an_error_at_the_byte(tmp_path):
    table = tmp_path / "map.csv"
    table.write_bytes(b"Address,Description\n0,Temp\x81\n")  # 0x81: undefined in cp1252
    proc = cli("csv2xml", table)
    assert_clean_error(
        proc,
        1,
        f"{table}:2:7: error: cannot decode byte 0x81 as utf-8, nor as cp1252",
        "encoding = NAME in [Input/Output]",
    )


def test_a_latin1_ini_is_read_and_said(tmp_path):
    (tmp_path / "map.csv").write_bytes(LATIN1_TABLE)
    ini = _ini(tmp_path)
    ini.write_bytes(ini.read_bytes().replace(b"Heat pump", "Pompe à chaleur".encode("cp1252")))
    proc = cli("csv2xml", ini, "-o", "-")
    assert proc.returncode == 0, proc.stderr
    assert f"{ini}: note: not UTF-8 (byte 0xe0 on line 2, column 21)" in proc.stderr
    assert "save the INI as UTF-8" in proc.stderr
    assert "Pompe &#224; chaleur" in proc.stdout


# --- headers that say more than the field ---------------------------------------------------------------


@pytest.mark.parametrize(
    "header",
    ["Modbus Protocol Start Address Hex", "Start Address (Hex)", "Register Address [hex]", "Modbus Start Register HEX"],
)
def test_an_address_header_with_qualifiers_is_the_address_column_read_as_hex(tmp_path, header):
    table = tmp_path / "map.csv"
    table.write_text(
        f"{header},Description,Data Type\n0010,Outdoor temperature,INT16\n001A,Room temperature,INT16\n",
        encoding="utf-8",
    )
    proc = cli("csv2xml", table)
    assert proc.returncode == 0, proc.stderr
    assert f"addresses = column 0 '{header}'" in proc.stderr
    assert f"note: addresses read as hexadecimal: the header '{header}' says so" in proc.stderr
    fns = functions(proc.stdout)
    assert (fns["outdoor_temperature"]["addresses"], fns["room_temperature"]["addresses"]) == ("16", "26")


def test_a_plain_synonym_wins_over_a_qualified_one(tmp_path):
    """`Address` and `Address Hex` side by side: the plain one is the address column (as the INI can say)."""
    table = tmp_path / "map.csv"
    table.write_text("Address Hex,Address,Description\n0x10,16,Outdoor temperature\n", encoding="utf-8")
    proc = cli("csv2xml", table)
    assert proc.returncode == 0, proc.stderr
    assert "addresses = column 1 'Address'" in proc.stderr
    assert functions(proc.stdout)["outdoor_temperature"]["addresses"] == "16"


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.sampled_from(sorted(QUALIFIERS) + ["address", "register", "type", "x", "-", "(", ")"]), max_size=6),
    st.text(max_size=20),
)
def test_fuzz_header_recognition(words, noise):
    """Any header text: a rank or None, never an exception; qualifiers alone name no column."""
    header = " ".join(words) + noise
    norm = normalize_header(header)
    for key in HEADER_SYNONYMS:
        rank = synonym_rank(key, norm)
        assert rank is None or rank >= 0
    if norm and set(norm.split()) <= QUALIFIERS:
        assert all(synonym_rank(key, norm) is None for key in HEADER_SYNONYMS)
    header_score(Row(1, [header, noise]))


# --- an unreadable file is invalid input (exit 1), as a missing one ------------------------------------


@pytest.fixture
def unreadable(monkeypatch):
    """Make files unreadable (mode 000). Root reads any file, so when the tests run as root the kernel's
    answer to any other user is played: os.access says no, open raises EACCES, for those files only."""
    denied: set[str] = set()
    if os.geteuid() == 0:
        real_open, real_access = builtins.open, os.access

        def fake_open(file, *args, **kwargs):
            if not isinstance(file, int) and os.fsdecode(file) in denied:
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), os.fsdecode(file))
            return real_open(file, *args, **kwargs)

        def fake_access(path, mode, *args, **kwargs):
            if not isinstance(path, int) and os.fsdecode(path) in denied and mode & os.R_OK:
                return False
            return real_access(path, mode, *args, **kwargs)

        monkeypatch.setattr(builtins, "open", fake_open)
        monkeypatch.setattr(os, "access", fake_access)

    def deny(*paths: Path) -> None:
        for path in paths:
            path.chmod(0o000)
            denied.add(str(path))

    return deny


@pytest.mark.parametrize("command", [["validate"], ["gen", "--check"], ["export", "--to", "senml"], ["csv2xml"]])
def test_permission_denied_is_exit_1_in_mdls_words_as_a_missing_file(tmp_path, unreadable, command):
    secret = tmp_path / "device.xml"
    shutil.copy(EXAMPLE / "temco_tstat.xml", secret)
    unreadable(secret)
    proc = cli(command[0], secret, *command[1:])
    assert_clean_error(proc, 1, f"{secret}: error: cannot read: Permission denied")
    assert "Usage:" not in proc.stderr and "not readable" not in proc.stderr
    missing = cli(command[0], tmp_path / "missing.xml", *command[1:])
    assert_clean_error(missing, 1, f"{tmp_path / 'missing.xml'}: error: no such file")


def test_an_unreadable_ini_or_table_of_csv2xml_is_exit_1(tmp_path, unreadable):
    shutil.copy(EXAMPLE / "temco_tstat.csv", tmp_path / "map.csv")
    ini = _ini(tmp_path)
    unreadable(tmp_path / "map.csv")
    proc = cli("csv2xml", ini, "-o", "-")
    assert_clean_error(proc, 1, f"{tmp_path / 'map.csv'}: error: cannot read: Permission denied")
    unreadable(ini)
    proc = cli("csv2xml", tmp_path / "map.csv", "--ini", ini, "-o", "-")
    assert_clean_error(proc, 1, f"{ini}: error: cannot read: Permission denied")


# --- XSD errors name their column ------------------------------------------------------------------------

INVALID = f"""<?xml version="1.0"?>
<device xmlns="{MDL_NS}">
  <name>x</name>
  <description>d</description>
  <function>
    <name>a</name>
    <description>b</description>
  </function>
  <function><name>c</name>
      <description>e</description><bogus/>
    <addresses>1</addresses>
  </function>
  <function>
    <name>f</name><description>g</description><addresses>2</addresses>
    <format>INT99</format>
  </function>
  <function
      ><name>h</name><description>i</description><addresses>3</addresses><count>0</count>
  </function>
</device>
"""


def test_xsd_errors_give_the_column_of_the_element(tmp_path):
    doc = tmp_path / "bad.xml"
    doc.write_text(INVALID, encoding="utf-8")
    proc = cli("validate", doc)
    assert proc.returncode == 1, proc.stderr
    errors = [line.split(": error: ")[0] for line in proc.stderr.splitlines()]
    assert errors == [f"{doc}:5:3", f"{doc}:10:35", f"{doc}:15:5", f"{doc}:18:74"], proc.stderr
    assert "Missing child element(s). Expected is ( addresses )" in proc.stderr


def _tag_at(text: str, line: int, col: int) -> str:
    return text.splitlines()[line - 1][col - 1 :]


BASE = (EXAMPLE / "temco_tstat.xml").read_text(encoding="ascii")
ELEMENTS = sorted(set(re.findall(r"<([a-z_]+)>[^<]*</\1>", BASE)))  # the elements that hold text


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.sampled_from(ELEMENTS),
    st.integers(0, 40),
    st.sampled_from(["x", "", "-1", "INT99", "<bogus/>", "99999"]),
    st.booleans(),
)
def test_fuzz_xsd_errors_point_at_a_start_tag_or_libxml2s_column(tmp_path_factory, element, nth, text, split_tag):
    """An element's text replaced (its start tag perhaps split over two lines): every XSD error has a
    line and a column, and where libxml2 gave none, the column is that of a start tag."""
    found = list(re.finditer(rf"<{element}>[^<]*</{element}>", BASE))
    m = found[nth % len(found)]
    opening = f"<{element}\n  >" if split_tag else f"<{element}>"
    source = BASE[: m.start()] + f"{opening}{text}</{element}>" + BASE[m.end() :]
    try:
        tree, data = parse_source(_write(tmp_path_factory, source))
    except MdlError:
        return
    for diag in schema_errors(tree, "doc.xml", "1.0", data):
        assert diag.line and diag.col, diag
        assert _tag_at(source, diag.line, diag.col).startswith("<"), (diag, source.splitlines()[diag.line - 1])


def _write(factory, text: str) -> Path:
    path = factory.mktemp("xsd") / "doc.xml"
    path.write_text(text, encoding="utf-8")
    return path


# --- an XML command given another kind of file ------------------------------------------------------------

TABLE = "Address,Description,Format\n0,Room temperature,INT16\n"
XML_COMMANDS = [
    ["validate"],
    ["gen", "--check"],
    ["export", "--to", "senml"],
    ["test"],
    ["read", "--host", "127.0.0.1", "--port", "1"],
]


@pytest.mark.parametrize("command", XML_COMMANDS)
def test_a_csv_given_to_an_xml_command_points_at_csv2xml(tmp_path, command):
    table = tmp_path / "map.csv"
    table.write_text(TABLE, encoding="utf-8")
    proc = cli(command[0], table, *command[1:])
    assert_clean_error(
        proc,
        1,
        f"{table}:1:1: error: not MDL XML (it does not start with '<'): this looks like a "
        f"register table (cells separated by commas); `mdl csv2xml {table} [--ini "
        "DEVICE.ini]` converts it to MDL",
    )
    assert "Start tag expected" not in proc.stderr


def test_a_csv_given_to_sim_points_at_csv2xml(tmp_path):
    table = tmp_path / "map.csv"
    table.write_text(TABLE.replace(",", ";"), encoding="utf-8")
    proc = run_mdl("sim", table, "--port", "0")
    assert_clean_error(proc, 1, "register table (cells separated by semicolons); `mdl csv2xml")


@pytest.mark.parametrize(
    ("name", "content", "looks", "command"),
    [
        (
            "meter.mod",
            (EXAMPLE.parent / "xif_meter" / "meter.mod").read_text(encoding="utf-8"),
            "an XIF file (SmartServer .mod)",
            "`mdl import {path}` converts it to MDL",
        ),
        (
            "heat_pump.yaml",
            (EXAMPLE.parent / "toolkit_heat_pump" / "heat_pump.yaml").read_text(encoding="utf-8"),
            "a Modbus Schema Toolkit YAML file",
            "`mdl import {path}`",
        ),
        (
            "device.ini",
            "; my device\n[Modbus Device]\ndevice_name = x\n[Input/Output]\naddress_map_csv_file = m.csv\n",
            "a device INI (csv2xml's)",
            "`mdl csv2xml {path}` converts the register table it names",
        ),
        ("notes.ini", "[General]\nx = 1\n", "an INI file", "`mdl import {path} --from wise`"),
        (
            "table.md",
            "| Address | Description |\n|---|---|\n| 0 | Room temperature |\n",
            "a register table (cells separated by pipes)",
            "`mdl csv2xml {path}",
        ),
        ("raw.json", '{"holding": {"0": 1}}', "a JSON document", "`mdl sim --registers`"),
        ("empty.xml", "", "an empty file", "`mdl csv2xml` makes one"),
        ("blank.xml", "\n  \n", "an empty file", "`mdl csv2xml` makes one"),
        ("map.tsv", "Hello\n", "a register table", "`mdl csv2xml {path}"),
        ("readme.txt", "Hello\n", "plain text", "`mdl csv2xml` makes one"),
        ("readme", "Hello there\n", "plain text", "`mdl csv2xml` makes one"),
    ],
)
def test_validate_says_what_the_file_looks_like(tmp_path, name, content, looks, command):
    path = tmp_path / name
    path.write_text(content, encoding="utf-8")
    proc = cli("validate", path)
    assert_clean_error(
        proc,
        1,
        f"{path}:",
        f"error: not MDL XML (it does not start with '<'): this looks like {looks};",
        command.format(path=path),
    )


def test_a_workbook_and_binary_data_are_named(tmp_path):
    book = tmp_path / "map.xlsx"
    book.write_bytes(b"PK\x03\x04" + bytes(range(256)))
    assert_clean_error(
        cli("validate", book),
        1,
        "a zip archive (an Excel .xlsx workbook?); save the register "
        "table as CSV and convert it with `mdl csv2xml TABLE.csv`",
    )
    blob = tmp_path / "blob.xml"
    blob.write_bytes(b"\x01\x00\x02binary")
    assert_clean_error(cli("validate", blob), 1, "this looks like binary data")


def test_a_table_on_stdin_names_dash_and_a_name_with_spaces_is_quoted(tmp_path):
    proc = cli("gen", "-", "--check", input=TABLE)
    assert_clean_error(proc, 1, "<stdin>:1:1: error: not MDL XML", "`mdl csv2xml - [--ini DEVICE.ini]`")
    spaced = tmp_path / "my map.csv"
    spaced.write_text(TABLE, encoding="utf-8")
    assert_clean_error(cli("validate", spaced), 1, f"`mdl csv2xml '{spaced}' [--ini DEVICE.ini]`")


def test_broken_xml_is_still_malformed_xml(tmp_path):
    doc = tmp_path / "broken.xml"
    doc.write_text(f'<?xml version="1.0"?>\n<device xmlns="{MDL_NS}">\n  <name>x</nam>\n', encoding="utf-8")
    proc = cli("validate", doc)
    assert_clean_error(proc, 1, f"{doc}:3:", "error: malformed XML:")
    assert "not MDL XML" not in proc.stderr


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=300) | st.text(max_size=300).map(lambda t: t.encode("utf-8")))
def test_fuzz_any_bytes_as_mdl(tmp_path, data):
    """Any bytes where MDL is expected: a document, or MdlError naming the file, never another exception;
    bytes that do not start with markup are described in one line."""
    path = tmp_path / "f.xml"
    path.write_bytes(data)
    try:
        parse_source(path)
    except MdlError as exc:
        assert all(d.file == str(path) for d in exc.diagnostics)
    message = not_xml(data, path)
    assert message.startswith("not MDL XML") and "\n" not in message.replace(str(path), "")


# --- decoding a table ------------------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(
    st.binary(max_size=200)
    | st.text(max_size=100).map(lambda t: t.encode("utf-8"))
    | st.text(alphabet=st.characters(codec="cp1252"), max_size=100).map(lambda t: t.encode("cp1252"))
)
def test_fuzz_decode_table(data):
    """UTF-8 is read as it is and said nothing of; anything else is read as the guess says (and the guess
    loses no byte: it encodes back to the file), or refused with the line and column of the byte."""
    try:
        text, guess = decode_table(data, Path("t.csv"))
    except MdlError as exc:
        (diag,) = exc.diagnostics
        assert diag.line and diag.col and "cannot decode byte" in diag.message
        return
    try:
        data.decode("utf-8-sig")
    except UnicodeDecodeError:
        assert guess is not None
        if guess.encoding == "utf-16":
            assert text.encode("utf-16-le" if data.startswith(b"\xff\xfe") else "utf-16-be") == data[2:]
        else:
            assert guess.encoding == "cp1252" and text.encode("cp1252") == data
        return
    assert guess is None  # UTF-8 is no guess (a UTF-16 byte order mark is never UTF-8)


# --- progress on a terminal --------------------------------------------------------------------------------


class Screen(io.StringIO):
    """A terminal for stderr that records, for each write, the (fake) time it was written at."""

    def __init__(self, clock: list[float]) -> None:
        super().__init__()
        self.clock = clock
        self.writes: list[tuple[float, str]] = []

    def isatty(self) -> bool:
        return True

    def write(self, text: str) -> int:
        written = super().write(text)  # click probes with bytes first: refused here, as by any text stream
        self.writes.append((self.clock[0], text))
        return written


WORDS = [
    "pump",
    "inlet",
    "outlet",
    "phase",
    "voltage",
    "current",
    "peak",
    "daily",
    "total",
    "reactive",
    "power",
    "frequency",
    "setpoint",
    "flow",
    "rate",
    "energy",
    "status",
    "alarm",
    "counter",
    "level",
    "tank",
    "valve",
]


def _long_table(path: Path, rows: int) -> None:
    rng = random.Random(20)
    lines = ["Address,Description,Format"]
    lines += [f"{2 * i},{' '.join(rng.sample(WORDS, 4)).capitalize()},int16" for i in range(rows)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def test_a_long_match_shows_progress_on_a_terminal_without_long_silences(tmp_path, monkeypatch):
    """Time passes (on a fake clock) only while ratios are computed, the bulk of matching: the bar is
    drawn within a second of it starting and never stays unchanged for more than a second and a half
    (before, it moved only as functions were settled, after every function's search)."""
    from mdl.cli import main
    from mdl.formats.table import match

    clock = [1000.0]
    real_fuzzy = match.fuzzy

    def fuzzy(a: str, b: str) -> float:
        clock[0] += 0.002
        return real_fuzzy(a, b)

    monkeypatch.setattr(match, "fuzzy", fuzzy)
    monkeypatch.setattr("mdl.formats.table.report.time.monotonic", lambda: clock[0])
    screen = Screen(clock)
    monkeypatch.setattr(sys, "stderr", screen)
    table = tmp_path / "map.csv"
    _long_table(table, 2000)
    start = clock[0]
    with pytest.raises(SystemExit) as done:
        main.main(["csv2xml", str(table), "-o", str(tmp_path / "out.xml")], prog_name="mdl")
    assert done.value.code == 0, screen.writes
    bar = [(t, text) for t, text in screen.writes if "matching" in text or text == "\r\x1b[K"]
    frames = [(t, text) for t, text in bar if "matching" in text]
    assert frames and bar[-1][1] == "\r\x1b[K"
    assert clock[0] - start > 5, "the fake work is long enough that a silence would show"
    times = [start] + [t for t, _ in bar]
    assert max(b - a for a, b in zip(times, times[1:], strict=False)) <= 1.5, bar
    assert re.fullmatch(r"\rmdl csv2xml: matching 41 functions \[[#.]{30}\] \d+% \d+s", frames[0][1])


def test_no_progress_when_stderr_is_not_a_terminal(tmp_path):
    table = tmp_path / "map.csv"
    _long_table(table, 2000)
    proc = run_mdl("csv2xml", table, "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr and "matching" not in proc.stderr and "[#" not in proc.stderr
    assert "summary: 2000 rows read" in proc.stderr


# --- mdl import of a file whose format it cannot tell ------------------------------------------------


@pytest.mark.parametrize(
    "name, text, fragments",
    [
        ("t.csv", "Register,Name\n40001,Temp\n", ["looks like a register table", "`mdl csv2xml ", "t.csv [--ini"]),
        (
            "d.ini",
            "[Input/Output]\naddress_map_csv_file = t.csv\n",
            ["a device INI (csv2xml's)", "`mdl csv2xml ", "d.ini` converts"],
        ),
        ("x.xml", "<device/>\n", ["looks like XML", "MDL needs no import"]),
    ],
)
def test_import_says_what_a_file_of_no_import_format_is(tmp_path, name, text, fragments):
    path = tmp_path / name
    path.write_text(text)
    proc = cli("import", path)
    assert_clean_error(proc, 1, f"{path}: error: cannot tell the format", *fragments)


def test_import_of_an_unreadable_file_says_so(tmp_path):
    proc = cli("import", tmp_path / "absent.bin")
    assert_clean_error(proc, 1, f"{tmp_path / 'absent.bin'}: error: no such file")
