"""`mdl csv2xml` on what the third set of unseen tables found (issue 36, SPEC 4.1's additions): a units
column of scales read cell by cell (a cell that is no scale is a warning, never the whole column's
scale dropped in silence), the INI's column names choosing the table of a page with two, a [function]
section rescuing a skipped row with a STRING format, `REG.bN` and `A~B` address cells, a widthless
type over a count of registers, and --all keeping a row's own name over a similarity-only match."""

from __future__ import annotations

import json
import re

import pytest

from support.run import assert_clean_error, cli, run_mdl
from support.tables import functions

INI_HEAD = "[Modbus Device]\ndevice_name = Test\n\n[Input/Output]\naddress_map_csv_file = {table}\n"


def convert(tmp_path, table_name: str, table: str, ini: str, *args: str):
    (tmp_path / table_name).write_text(table, encoding="utf-8")
    path = tmp_path / "device.ini"
    path.write_text(INI_HEAD.format(table=table_name) + ini, encoding="utf-8")
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", path, "-o", out, *args)
    return proc, (functions(out.read_text()) if out.exists() else {})


SCALES = (
    "Address,Name,Type,Unit\n0,PV power,U16,0.1W\n1,Grid frequency,U16,0.01Hz\n2,Work mode,U16,1:PV\n3,Temp,S16,0.1?\n"
)
NAMED_UNITS = "\n[Column/Field Indices]\naddresses = Address\ndescription = Name\nformat = Type\nunits = Unit\n"


def test_a_units_column_of_scales_keeps_its_scales_when_a_few_cells_are_not(tmp_path):
    """Before: `1:PV` and `0.1?` turned the column's reading as a scale off for every row, with no note
    and no warning, and PV power read 10 times too large."""
    proc, fns = convert(tmp_path, "t.csv", SCALES, NAMED_UNITS, "--all")
    assert proc.returncode == 0, proc.stderr
    by_address = {f["addresses"]: f for f in fns.values()}
    assert by_address["0"]["multiplier"] == "0.1" and by_address["0"]["units"] == "W"
    assert by_address["1"]["multiplier"] == "0.01" and by_address["1"]["units"] == "Hz"
    assert "multiplier" not in by_address["2"] and "multiplier" not in by_address["3"]
    assert "t.csv:4: warning: column 3 'Unit' multiplier cell '1:PV'" in proc.stderr
    assert "t.csv:5: warning: column 3 'Unit' multiplier cell '0.1?'" in proc.stderr
    assert "2 of its cells are not a scale (e.g. '1:PV' on line 4)" in proc.stderr


def test_strict_refuses_a_cell_that_is_not_a_scale(tmp_path):
    proc, _ = convert(tmp_path, "t.csv", SCALES, NAMED_UNITS, "--all", "--strict")
    assert proc.returncode == 1
    assert "multiplier cell '1:PV'" in proc.stderr and "--strict: nothing written" in proc.stderr
    assert not (tmp_path / "out.xml").exists()


TWO_TABLES = """# Protocol

| Code | Meaning |
|---|---|
| 3 | Read holding registers |
| 4 | Read input registers |

| Reg | Parameter | Scale |
|---|---|---|
| 100 | Battery voltage | 0.1 |
| 101 | Battery current | 0.01 |
"""


def test_the_ini_columns_choose_the_table_of_a_page_with_two(tmp_path):
    """Before: the first table with an address-like header (Code) was read, and the INI, which cannot say
    --table, named columns of the second: no row was read."""
    ini = (
        "\n[Column/Field Indices]\naddresses = Reg\ndescription = Parameter\nmultiplier = Scale\n"
        "\n[Function Name Search Synonyms]\nbattery_voltage = Battery voltage\n"
    )
    proc, fns = convert(tmp_path, "t.md", TWO_TABLES, ini)
    assert proc.returncode == 0, proc.stderr
    assert fns["battery_voltage"]["addresses"] == "100" and fns["battery_voltage"]["multiplier"] == "0.1"
    assert "read table 2 (line 8): the first whose header holds the INI's column names" in proc.stderr


def test_a_function_section_rescues_a_row_with_a_string_format(tmp_path):
    """Before: `format = STRING 8`, which [format cells] accepts, was refused on the rescue path, and then
    a false 'no row matched' followed."""
    table = "Address,Name,Type\n0,Voltage,U16\n10-17,Serial number,U16\n"
    ini = (
        "\n[Function Name Search Synonyms]\nvoltage = Voltage\nserial = Serial number\n"
        "\n[function serial]\nformat = STRING 8\n"
    )
    proc, fns = convert(tmp_path, "t.csv", table, ini)
    assert proc.returncode == 0, proc.stderr
    assert fns["serial"]["format"] == "STRING" and fns["serial"]["count"] == "8"
    assert fns["serial"]["addresses"].split()[0] == "10"
    assert "serial: line 3 read with format STRING 8 from [function serial]" in proc.stderr
    assert "no row matched serial" not in proc.stderr


def test_bit_of_a_register_and_tilde_ranges(tmp_path):
    table = (
        "Address,Name,Type\n0x0103.b8,Fan running,BIT\n22.b0,Alarm,BIT\n0x000C~0x000D,Energy,U32\n20～21,Power,S32\n"
    )
    ini = "\n[Function Name Search Synonyms]\nfan = Fan running\nalarm = Alarm\nenergy = Energy\npower = Power\n"
    proc, fns = convert(tmp_path, "t.csv", table, ini)
    assert proc.returncode == 0, proc.stderr
    assert fns["fan"]["addresses"] == "259" and fns["fan"]["bits"] == "8"
    assert fns["alarm"]["addresses"] == "22" and fns["alarm"]["bits"] == "0"
    assert fns["energy"]["addresses"] in ("12", "12 13") and fns["energy"]["format"] == "UINT32"
    assert fns["power"]["addresses"] in ("20", "20 21") and fns["power"]["format"] == "INT32"
    assert "row skipped" not in proc.stderr


def test_a_widthless_type_over_a_count_takes_its_width_from_the_count(tmp_path):
    """`Unsigned` with a size of 2 registers is a UINT32, not two UINT16 (which read a wrong value)."""
    table = "Address,Name,Size,Type\n0,Energy,2,Unsigned\n2,Power,1,Signed\n"
    ini = "\n[Modbus Device]\ncount_unit = words\n\n[Function Name Search Synonyms]\nenergy = Energy\npower = Power\n"
    proc, fns = convert(tmp_path, "t.csv", table, ini.replace("[Modbus Device]\n", "", 1).replace("\n\n", "\n", 1))
    assert proc.returncode == 0, proc.stderr
    assert fns["energy"]["format"] == "UINT32" and fns["power"]["format"] == "INT16"
    assert "says no width and the row is 2 registers: read as UINT32" in proc.stderr


def test_all_keeps_a_rows_own_name_over_a_similarity_only_match(tmp_path):
    """Without [Functions], --all named `energy_voltage_68`-like rows after the bundled list by similarity
    alone; now a row only similar to a bundled function keeps its own name, and a note says so."""
    table = "Address,Name\n0,PV power\n1,Grid frequency\n"
    (tmp_path / "t.csv").write_text(table)
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", tmp_path / "t.csv", "--all", "-o", out)
    assert proc.returncode == 0, proc.stderr
    names = set(functions(out.read_text()))
    assert "pv_power" in names and "total_power" not in names
    assert "only similar to the bundled list's total_power keeps its own name" in proc.stderr


def test_pages_of_an_ini_for_a_csv_is_an_error_at_its_line(tmp_path):
    proc, _ = convert(tmp_path, "t.csv", "Address,Name\n0,Voltage\n", "pages = 3\n", "--all")
    assert_clean_error(proc, 1, "device.ini:6: error: pages = 3 in the INI chooses pages of a PDF manual")


ODS = (
    '<?xml version="1.0"?><office:document-content xmlns:office="urn:oasis:names:tc:opendocument:xmlns:office:1.0" '
    'xmlns:table="urn:oasis:names:tc:opendocument:xmlns:table:1.0" '
    'xmlns:text="urn:oasis:names:tc:opendocument:xmlns:text:1.0"><office:body><office:spreadsheet>'
    '<table:table table:name="Regs">{rows}</table:table></office:spreadsheet></office:body></office:document-content>'
)


def test_an_ods_whose_repeats_claim_millions_of_cells_is_refused_before_they_are_made(tmp_path):
    """A few hundred bytes of content.xml can repeat a cell with text over millions of rows or columns:
    the repeats are counted, never expanded past the limits."""
    import zipfile

    header = "<table:table-row><table:table-cell><text:p>Address</text:p></table:table-cell></table:table-row>"
    cell = "<table:table-cell {}><text:p>7</text:p></table:table-cell>"
    cases = {
        "wide.ods": (
            f"<table:table-row>{cell.format(chr(32) + 'table:number-columns-repeated=' + chr(34) + '20000' + chr(34))}"
            "</table:table-row>",
            "has more than 16,384 columns",
        ),
        "tall.ods": (
            f'<table:table-row table:number-rows-repeated="2000000">{cell.format("")}</table:table-row>',
            "hold more than 1,000,000 cells with text",
        ),
    }
    for name, (rows, message) in cases.items():
        path = tmp_path / name
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("content.xml", ODS.format(rows=header + rows))
        proc = cli("csv2xml", path, "--all", "-o", tmp_path / "out.xml")
        assert_clean_error(proc, 1, message)


@pytest.mark.commands  # serves a device
def test_a_function_section_gives_an_expression_for_an_encoding_the_fields_cannot_say(tmp_path, sim_factory):
    """A temperature stored with its bytes swapped, in tenths: `expression =` in [function NAME] (SPEC 2.2's
    language) replaces the table's format, is checked like every expression, and reads through mdl sim."""
    table = "Address,Name,Type\n5,Water temperature,U16\n6,Flow,U16\n"
    ini = (
        "\n[Function Name Search Synonyms]\nwater_temperature = Water temperature\nflow = Flow\n"
        "\n[function water_temperature]\nexpression = int16(swapbytes(hr:5)) / 10\n"
    )
    proc, fns = convert(tmp_path, "t.csv", table, ini)
    assert proc.returncode == 0, proc.stderr
    assert fns["water_temperature"]["expression"] == "int16(swapbytes(hr:5)) / 10"
    assert "format" not in fns["water_temperature"]
    raw = tmp_path / "raw.json"
    raw.write_text('{"holding": {"5": 65280, "6": 3}}')  # 0xFF00: 0x00FF swapped, 255 tenths
    sim = sim_factory(tmp_path / "out.xml", "--registers", raw)
    read = run_mdl("read", tmp_path / "out.xml", "--host", sim.host, "--port", sim.port, "--format", "json")
    assert json.loads(read.stdout) == {"water_temperature": 25.5, "flow": 3}, read.stderr
    broken, _ = convert(tmp_path, "t.csv", table, ini.replace("hr:5))", "hr:5)"))
    assert_clean_error(broken, 1, "function 'water_temperature': expression: expected ')'")


def test_without_an_ini_a_row_keeps_the_name_of_its_own_name_column(tmp_path):
    """SPEC 4.1: the bundled list names only rows that have no name of their own (the review's n.csv:
    `grid_v` became voltage_l1, `my_freq` frequency)."""
    (tmp_path / "n.csv").write_text(
        "Address,Name,Description,Type\n1,grid_v,Phase A voltage,UINT16\n2,my_freq,Grid frequency,UINT16\n"
        "3,,Total active power,INT32\n"
    )
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", tmp_path / "n.csv", "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert set(functions(out.read_text())) == {"grid_v", "my_freq", "total_power"}
    assert "2 rows keep the names of their own name column over the bundled list's" in proc.stderr


def test_an_expression_beside_fields_it_replaces_is_an_error_at_the_section(tmp_path):
    """Before: `multiplier = 0.1` beside `expression =` was announced, then dropped: 10 times off."""
    ini = (
        "\n[Function Name Search Synonyms]\nwater = Water temperature\n"
        "\n[function water]\nmultiplier = 0.1\nexpression = int16(hr:5)\n"
    )
    proc, _ = convert(tmp_path, "t.csv", "Address,Name,Type\n5,Water temperature,U16\n", ini)
    assert_clean_error(proc, 1, "expression gives the whole value: multiplier cannot stand beside it")


def test_a_bit_address_of_a_byte_format_is_that_byte(tmp_path):
    """SPEC 4.1: `.b8` with a byte format is the upper byte (and `.b0` the lower), not bit 8 of a byte."""
    table = "Address,Name,Type\n0x0103.b8,High byte,UINT8\n0x0103.b0,Low byte,INT8\n"
    ini = "\n[Function Name Search Synonyms]\nhigh = High byte\nlow = Low byte\n"
    proc, fns = convert(tmp_path, "t.csv", table, ini)
    assert proc.returncode == 0, proc.stderr
    assert (fns["high"]["length"], fns["high"]["format"], "bits" in fns["high"]) == ("Upper byte", "UINT8", False)
    assert (fns["low"]["length"], fns["low"]["format"], "bits" in fns["low"]) == ("Lower byte", "INT8", False)


@pytest.mark.parametrize(
    ("cell", "addresses"),
    [("16#2136", [8502]), ("16#2136 = 08502", [8502]), ("16#0C84 = 03204", [3204]), ("8#17", [15]), ("35.", [35])],
)
def test_iec_based_numbers_and_numbered_lists_are_addresses(cell, addresses):
    """Schneider's logic addresses (IEC 61131-3 based numbers, with the decimal beside them) and a number
    written as a numbered list (Growatt's `35.`)."""
    from mdl.formats.table.cells import read_address_cell

    assert read_address_cell(cell).addresses == addresses


@pytest.mark.parametrize(
    ("cell", "message"),
    [
        ("16#2136 = 08503", "16#2136 is 8502, not 8503"),
        (
            "16#219B = 8603 (speed)\n16#0C81 = 3201 (frequency)",
            "names 2 addresses, one for each of 'speed', 'frequency'",
        ),
        ("16#FFFFF", "address 1048575 is over 65535"),
    ],
)
def test_iec_addresses_that_say_two_things_are_refused(cell, message):
    from mdl.formats.table.cells import CellError, read_address_cell

    with pytest.raises(CellError, match=re.escape(message)):
        read_address_cell(cell)


@pytest.mark.parametrize(
    ("cell", "fmt"),
    [
        ("INT (Signed16)", "INT16"),
        ("UINT (Unsigned16)", "UINT16"),
        ("DINT (Signed32)", "INT32"),
        ("WORD (BitString16)", "UINT16"),
        ("WORD (Enumeration)", "UINT16"),
    ],
)
def test_a_type_with_its_kind_in_brackets_is_read(cell, fmt):
    from mdl.formats.table.cells import read_type

    typed = read_type(cell)
    assert typed.format == fmt and not typed.widthless


def test_a_type_whose_bracket_says_another_is_refused():
    from mdl.formats.table.cells import CellError, read_type

    with pytest.raises(CellError, match="INT and Unsigned16 are not one format"):
        read_type("INT (Unsigned16)")
