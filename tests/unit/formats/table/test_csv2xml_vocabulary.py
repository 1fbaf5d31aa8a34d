"""`mdl csv2xml` told what a table's words mean (SPEC 4.1): `[<field> cells]` maps, `[function NAME]`
sections, the built-in readings of vendors' words, which cells cost a row, quoted synonyms, and what
--explain and --all say. Values are proven by serving the converted description with `mdl sim` and
reading it back; the new INI sections are fuzzed (a positioned error or valid MDL, nothing else)."""

from __future__ import annotations

import re
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.cli.csv2xml import run_csv2xml
from mdl.diagnostics import EXIT_INVALID, MdlError
from mdl.formats.mdl import validate_file
from mdl.formats.table.cells import CellError, parse_bit_cell, read_address_cell, read_mapped_format
from support.common import DATA
from support.corpus import read_served as read_values
from support.run import assert_clean_error, cli
from support.tables import functions

VOCAB = DATA / "csv2xml_vocab"


def convert(tmp_path: Path, table: Path, ini: Path | None, *args: str):
    out = tmp_path / "out.xml"
    extra = ["--ini", ini] if ini else []
    proc = cli("csv2xml", table, *extra, "-o", out, *args)
    return proc, (functions(out.read_text()) if out.exists() else {})


def write(tmp_path: Path, table: str, ini: str | None = None) -> tuple[Path, Path | None]:
    (tmp_path / "t.csv").write_text(table)
    if ini is None:
        return tmp_path / "t.csv", None
    (tmp_path / "t.ini").write_text(ini)
    return tmp_path / "t.csv", tmp_path / "t.ini"


# ---- 1. [<field> cells] -------------------------------------------------------------------------


@pytest.mark.commands  # serves or dials a device
def test_cell_maps_win_and_each_is_said(tmp_path, sim_factory):
    proc, fns = convert(tmp_path, VOCAB / "meter.csv", VOCAB / "meter.ini", "--strict")
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stderr
    path = VOCAB / "meter.csv"
    for said in (
        f"{path}:2: note: format cell 'int' on line 2 (and any like it) read as 'INT32', as [format cells]",
        f"{path}:4: note: format cell 'bitfield' on line 4 (and any like it) read as 'UINT16'",
        f"{path}:5: note: format cell 'STR32' on line 5 (and any like it) read as 'STRING 4'",
        f"{path}:2: note: multiplier cell 'FIX2' on line 2 (and any like it) read as '0.01'",
        f"{path}:6: note: access cell 'R/W: yes' on line 6 (and any like it) read as 'read_write'",
        f"{path}:7: note: multiplier cell '*10' on line 7 (and any like it) read as '0.1'",
    ):
        assert said in proc.stderr
    assert fns["model"]["count"] == "4" and fns["model"]["format"] == "STRING"  # STR32 = STRING 4
    assert fns["current_l1"]["format"] == "INT32" and fns["current_l1"]["register_type"] == "input"
    assert "access" not in fns["voltage_l1"]  # R/- on an input register: read, its default
    assert "access" not in fns["demand"] and "register_type" not in fns["demand"]  # "R/W: yes", holding
    raw = {
        "input": {"100": 0xFFFF, "101": 0xCFC7, "102": 2305, "103": 5, "201": 5000}
        | {str(104 + i): w for i, w in enumerate((0x4142, 0x4344, 0x4546, 0x4748))},
        "holding": {"200": 15},
    }
    values = read_values(sim_factory, tmp_path / "out.xml", raw)
    assert values == {
        "current_l1": -123.45,
        "voltage_l1": 230.5,
        "status": 5,
        "model": "ABCDEFGH",
        "demand": 15,
        "rated_power": 500.0,
    }


def test_a_cell_map_lets_a_guessed_column_be_kept(tmp_path):
    """A `Kind` column of the vendor's own words is a format column once the INI maps them."""
    table, ini = write(
        tmp_path,
        "Address,Description,Data type\n0,Mode,enum16\n1,Power,enum16\n",
        "[format cells]\nenum16 = UINT16\n[Function Name Search Synonyms]\nmode = Mode\npower = Power\n",
    )
    proc, fns = convert(tmp_path, table, ini, "--strict")
    assert proc.returncode == 0, proc.stderr
    assert "format = column 2 'Data type'" in proc.stderr and fns["mode"]["format"] == "UINT16"


@pytest.mark.commands  # serves or dials a device
def test_every_field_may_be_mapped(tmp_path, sim_factory):
    """word order, units, block label, count and bits cells too; an empty value means an empty cell."""
    table, ini = write(
        tmp_path,
        "Address,Description,Type,Order,Unit,Group,Words,Bit\n0,Energy,u32,lsw,kwh,main,two,\n2,Door,UINT16,,,,,third\n",
        "[Column/Field Indices]\nword_order = Order\nunits = Unit\nblock_label = Group\ncount = Words\nbits = Bit\n"
        "[word_order cells]\nlsw = little\n[units cells]\nkwh = kWh\n[block_label cells]\nmain = Main meter\n"
        "[count cells]\ntwo = 2\n[bits cells]\nthird = 3\n[format cells]\nu32 =\n"
        "[Function Name Search Synonyms]\nenergy = Energy\ndoor = Door\n",
    )
    proc, fns = convert(tmp_path, table, ini, "--strict")
    assert proc.returncode == 0, proc.stderr
    energy = fns["energy"]
    assert (energy["word_order"], energy["units"], energy["block_label"], energy["format"]) == (
        "little",
        "kWh",
        "Main meter",
        "UINT32",  # `u32 =`: no format cell, so two registers are UINT32
    )
    assert fns["door"]["bits"] == "3"
    values = read_values(sim_factory, tmp_path / "out.xml", {"holding": {"0": 2, "1": 1, "2": 8}})
    assert values == {"energy": 65538, "door": True}


@pytest.mark.parametrize(
    "section, message",
    [
        ("[format cells]\nfoo = int99\n", ":2: error: [format cells] 'foo': unknown format 'int99'"),
        ("[access cells]\nX = sometimes\n", ":2: error: [access cells] 'X': unknown access 'sometimes'"),
        ("[colour cells]\nred = 1\n", ":1: error: [colour cells]: no field 'colour'"),
        ("[multiplier cells]\nFIX = lots\n", ":2: error: [multiplier cells] 'FIX': multiplier 'lots' is not a scale"),
        ("[function x]\nformat = int99\n", ":2: error: [function x] format = int99: unknown format 'int99'"),
        ("[function x]\ncolour = red\n", ":2: error: [function x] cannot set 'colour'"),
        ("[function x]\nrow = two\n", ":2: error: [function x] row = two: must be a line number"),
        ("[function x]\ndivisor = 0\n", ":2: error: [function x] divisor = 0: a divisor of 0 loses every value"),
        ("[function x]\nbyte_order = middle\n", ":2: error: [function x] byte_order = middle: must be big or little"),
        ('[Function Name Search Synonyms]\nx = "a, b\n', ":2: error: synonyms of 'x': a '\"' is not closed"),
    ],
)
def test_bad_sections_are_errors_at_their_line(tmp_path, section, message):
    table, ini = write(tmp_path, "Address,Description\n0,Mode\n", section)
    proc, _ = convert(tmp_path, table, ini)
    assert_clean_error(proc, 1, f"{ini}{message}")
    assert not (tmp_path / "out.xml").exists()


# ---- 2. [function NAME] -------------------------------------------------------------------------


@pytest.mark.commands  # serves or dials a device
def test_function_sections_rows_bits_and_quoted_synonyms(tmp_path, sim_factory):
    proc, fns = convert(tmp_path, VOCAB / "inverter.csv", VOCAB / "inverter.ini")
    assert proc.returncode == 0, proc.stderr
    ini = VOCAB / "inverter.ini"
    for said in (
        f"{ini}:20: note: amp_l1: multiplier 0.1 from [function amp_l1] instead of no value",
        f"{ini}:21: note: amp_l1: units A from [function amp_l1] instead of no value",
        f"{ini}:23: note: system_time: format INT32 from [function system_time] instead of the table's 'UINT32'",
        f"{ini}:24: note: system_time: line 3 of the table, as [function system_time] row says",
        f"{ini}:26: note: nominal_power: line 8 of the table, as [function nominal_power] row says",
    ):
        assert said in proc.stderr
    # `30101 (100)`: the bracket is the address; `bool (bit 3)`, a bits column's B5 and `30105.2` are bits
    assert {n: (f["addresses"], f.get("bits")) for n, f in fns.items()} == {
        "amp_l1": ("100", None),
        "alarm": ("103", "3"),
        "fan": ("103", "5"),
        "relay": ("104", "2"),
        "system_time": ("101", None),
        "nominal_power": ("106", None),
    }
    raw = {"input": {"100": 123, "101": 0xFFFF, "102": 0xFFFE, "103": 0b101000, "104": 4, "106": 5000}}
    values = read_values(sim_factory, tmp_path / "out.xml", raw)
    assert values == {
        "amp_l1": 12.3,
        "alarm": True,
        "fan": True,
        "relay": True,
        "system_time": -2,
        "nominal_power": 5000,
    }


@pytest.mark.commands  # serves or dials a device
def test_a_function_section_may_set_every_field(tmp_path, sim_factory):
    table, ini = write(
        tmp_path,
        "Address,Description,Type\n10,Setpoint,UINT16\n20,Exponent,INT16\n",
        "[Function Name Search Synonyms]\nsetpoint = Setpoint\nsetpoint_sf = Exponent\n"
        "[function setpoint]\naddresses = 11\ncount = 2\nformat = INT32\nword_order = little\n"
        "byte_order = big\ndivisor = 10\noffset = -5\nunits = degC\nminimum = -100\nmaximum = 100\n"
        "access = R/W\nregister_type = holding\nrole = setpoint\n"
        "[function setpoint_sf]\nbits = 0-3\n",
    )
    proc, fns = convert(tmp_path, table, ini)
    assert proc.returncode == 0, proc.stderr
    sp = fns["setpoint"]
    assert (sp["addresses"], sp["count"], sp["format"], sp["word_order"]) == ("11", "2", "INT32", "little")
    assert (sp["multiplier"], sp["offset"], sp["units"], sp["minimum"], sp["maximum"]) == (
        "0.1",
        "-5",
        "degC",
        "-100",
        "100",
    )
    assert fns["setpoint_sf"]["bits"] == "0-3"
    assert "setpoint: addresses 11 from [function setpoint] instead of the table's '10'" in proc.stderr
    values = read_values(sim_factory, tmp_path / "out.xml", {"holding": {"11": 255, "12": 0, "20": 0x00F3}})
    assert values == {"setpoint": 20.5, "setpoint_sf": 3}


@pytest.mark.parametrize(
    "section, message",
    [
        ("[function mode]\nrow = 9\n", "[function mode] row = 9: line 9 of the table holds no row with an address"),
        ("[function mode]\nrow = 3\n", "[function mode] row = 3: line 3 of the table was skipped"),
        ("[function mode]\nformat = FLOAT32\nbits = 3\n", "[function mode] leaves mode impossible"),
    ],
)
def test_a_function_section_that_cannot_be_is_an_error(tmp_path, section, message):
    table, ini = write(
        tmp_path,
        "Address,Description,Type\n0,Mode,UINT16\n1,Other,int99\n",
        "[Column/Field Indices]\nformat = Type\n[Function Name Search Synonyms]\nmode = Mode\n" + section,
    )
    proc, _ = convert(tmp_path, table, ini)
    assert_clean_error(proc, 1, message)
    assert not (tmp_path / "out.xml").exists()


def test_a_function_section_without_a_row_is_a_warning(tmp_path):
    table, ini = write(
        tmp_path,
        "Address,Description\n0,Mode\n",
        "[Function Name Search Synonyms]\nmode = Mode\n[function nothing_like_it]\nunits = V\n",
    )
    proc, fns = convert(tmp_path, table, ini)
    assert proc.returncode == 0 and list(fns) == ["mode"]
    assert f"{ini}:3: warning: [function nothing_like_it]: no row matched nothing_like_it" in proc.stderr


def test_a_function_sections_name_is_case_insensitive(tmp_path):
    """SPEC 4.1: section names are case-insensitive; [function amp_L1] is amp_l1's, with a note."""
    table, ini = write(
        tmp_path,
        "Address,Description,Format\n0,Phase current,UINT16\n",
        "[Function Name Search Synonyms]\nAmp_L1 = Phase current\n[function amp_l1]\nformat = INT16\n",
    )
    proc, fns = convert(tmp_path, table, ini)
    assert proc.returncode == 0, proc.stderr
    assert list(fns) == ["Amp_L1"] and fns["Amp_L1"]["format"] == "INT16"
    assert f"{ini}:3: note: [function amp_l1] is the section of Amp_L1" in proc.stderr
    assert "no row matched" not in proc.stderr


def test_every_override_is_said_in_mdl_words(tmp_path):
    """SPEC 4.1: every override is said in a note, one that the table's cell already says too; a field
    left out is named by what it means (holding, read_write), never as None."""
    table, ini = write(
        tmp_path,
        "Address,Description,Format,Type,Access\n1,Alpha,UINT16,IR,R/-\n",
        "[Column/Field Indices]\ndescription = Description\naddresses = Address\nformat = Format\n"
        "register_type = Type\naccess = Access\n"
        "[Function Name Search Synonyms]\nalpha = Alpha\n[function alpha]\nregister_type = holding\n"
        "access = read_write\nformat = UINT16\n",
    )
    proc, fns = convert(tmp_path, table, ini)
    assert proc.returncode == 0, proc.stderr
    assert "register_type" not in fns["alpha"] and "access" not in fns["alpha"]
    assert f"{ini}:10: note: alpha: register_type holding from [function alpha] instead of the table's 'input'" in (
        proc.stderr
    )
    assert f"{ini}:11: note: alpha: access read_write from [function alpha]" in proc.stderr
    assert f"{ini}:12: note: alpha: format UINT16 from [function alpha]\n" in proc.stderr
    assert "None" not in proc.stderr


# ---- 3. built-in readings -----------------------------------------------------------------------

ACCESS = [
    ("R/-", "read"),
    ("RO", "read"),
    ("R/O", "read"),
    ("read only", "read"),
    ("-/W", "write"),
    ("WO", "write"),
    ("RW", None),
    ("R/W", None),
    ("r/-", "read"),
    ("rw", None),
]
TABLES = [
    ("MODBUS_INPUT_REGISTER", "input"),
    ("input register", "input"),
    ("holding register", None),
    ("coil status", "coil"),
    ("input status", "discrete"),
    ("IR", "input"),
    ("HR", None),
    ("DI", "discrete"),
    ("CO", "coil"),
]


def test_access_words_and_register_types(tmp_path):
    rows = [f"{i},Value {i},{a},holding" for i, (a, _) in enumerate(ACCESS)]
    rows += [f"{100 + i},Table {i},,{t}" for i, (t, _) in enumerate(TABLES)]
    table, ini = write(
        tmp_path,
        "Address,Description,Access,Register type\n" + "\n".join(rows) + "\n",
        "[Function Name Search Synonyms]\nfirst = Value 0\n",
    )
    proc, fns = convert(tmp_path, table, ini, "--all", "--strict")
    assert proc.returncode == 0, proc.stderr
    fns["value_0"] = fns.pop("first")
    assert [fns[f"value_{i}"].get("access") for i in range(len(ACCESS))] == [a for _, a in ACCESS]
    assert [fns[f"table_{i}"].get("register_type") for i in range(len(TABLES))] == [t for _, t in TABLES]


@pytest.mark.commands  # serves or dials a device
def test_address_cells_with_bits_brackets_and_line_breaks(tmp_path, sim_factory):
    table, ini = write(
        tmp_path,
        'Address,Description\n40001.3,Door open\n40002/4,Lamp on\n30101 (100),Flow\n"40010\n40011",Energy\n'
        "30103 (7),Wrong bracket\n",
        "[Modbus Device]\naddress_base = modicon\n[Function Name Search Synonyms]\nflow = Flow\n",
    )
    proc, fns = convert(tmp_path, table, ini, "--all")
    assert proc.returncode == 0, proc.stderr
    assert (fns["door_open"]["addresses"], fns["door_open"]["bits"]) == ("0", "3")
    assert (fns["lamp_on"]["addresses"], fns["lamp_on"]["bits"]) == ("1", "4")
    assert (fns["flow"]["addresses"], fns["flow"]["register_type"]) == ("100", "input")
    assert (fns["energy"]["addresses"], fns["energy"]["count"]) == ("9 10", "2")
    assert f"{table}:3: note: '40002/4' read as bit 4 of register 40002, not as a list of two" in proc.stderr
    assert (
        f"{table}:7: warning: row skipped: '30103 (7)': register 30103 and the address 7 in brackets disagree"
        in proc.stderr
    )
    assert "wrong_bracket" not in fns
    values = read_values(sim_factory, tmp_path / "out.xml", {"holding": {"0": 8, "1": 0, "9": 1, "10": 2}})
    assert values == {"door_open": True, "lamp_on": False, "flow": 0, "energy": 65538}


@pytest.mark.commands  # serves or dials a device
def test_a_column_of_register_then_bit_cells_counts_as_modicon_numbers(tmp_path, sim_factory):
    """`40001.3` names register 40001 (holding register 0), whatever the column's other cells: the
    guess of the address base counts its register, and never reads 40001 as a wire address."""
    table, ini = write(tmp_path, "Address,Description\n40001.3,Door open\n40002/4,Lamp on\n", None)
    proc, fns = convert(tmp_path, table, ini, "--all")
    assert proc.returncode == 0, proc.stderr
    assert "addresses read as Modicon register numbers" in proc.stderr
    assert (fns["door_open"]["addresses"], fns["door_open"]["bits"]) == ("0", "3")
    assert (fns["lamp_on"]["addresses"], fns["lamp_on"]["bits"]) == ("1", "4")
    values = read_values(sim_factory, tmp_path / "out.xml", {"holding": {"0": 8, "1": 16}})
    assert values == {"door_open": True, "lamp_on": True}


def test_an_unmapped_times_scale_is_a_warning_naming_both_readings(tmp_path):
    table = VOCAB / "inverter.csv"
    proc, fns = convert(tmp_path, table, VOCAB / "inverter.ini", "--all")
    assert proc.returncode == 0, proc.stderr
    assert (
        f"{table}:7: warning: column 5 'Scale' multiplier cell 'x10' may mean multiply by 10 or stored 10 times "
        "larger (divide by 10): read as multiplier 10; map it in [multiplier cells] of the INI to say which"
    ) in proc.stderr
    assert fns["nom_p"]["multiplier"] == "10"
    proc, _ = convert(tmp_path, table, VOCAB / "inverter.ini", "--strict")
    assert_clean_error(proc, 1, "1 warning and --strict: nothing written")


def test_a_count_column_wins_over_a_text_formats_width(tmp_path):
    table, ini = write(
        tmp_path,
        "Address,Description,Type,Count\n0,Serial number,STR32,8\n",
        "[Column/Field Indices]\ncount = Count\n[Function Name Search Synonyms]\nserial = Serial number\n",
    )
    proc, fns = convert(tmp_path, table, ini)
    assert proc.returncode == 0, proc.stderr
    assert fns["serial"]["count"] == "8"
    assert "format 'STR32' on line 2 (and any like it) is 16 registers wide but the count column says 8" in proc.stderr


# ---- 4. which cells cost a row ------------------------------------------------------------------


@pytest.mark.commands  # serves or dials a device
def test_a_function_section_reads_a_row_whose_cell_it_sets(tmp_path, sim_factory):
    """SPEC 4.1: [function NAME] wins over the table's cells, an unreadable one too: the row skipped for its
    format is read with the section's format, with a note, and the other fields of the section apply."""
    table, ini = write(
        tmp_path,
        "Description,Address,Format\nPhase current L1,0,bitfield\nVoltage,1,UINT16\nOther,2,bitfield\n",
        "[Column/Field Indices]\ndescription = Description\naddresses = Address\nformat = Format\n"
        "[Function Name Search Synonyms]\namp_l1 = Phase current L1\nvolts = Voltage\nother = Other\n"
        "[function amp_l1]\nformat = UINT16\nmultiplier = 0.1\n",
    )
    proc, fns = convert(tmp_path, table, ini)
    assert proc.returncode == 0, proc.stderr
    assert fns["amp_l1"]["format"] == "UINT16" and fns["amp_l1"]["multiplier"] == "0.1"
    assert (
        f"{ini}:10: note: amp_l1: line 2 read with format UINT16 from [function amp_l1], which wins over the cell "
        "'bitfield' that could not be read" in proc.stderr
    )
    assert "other" not in fns  # no section sets its format: still skipped, and said
    assert f"{table}:4: warning: other: line 4 names it" in proc.stderr
    values = read_values(sim_factory, tmp_path / "out.xml", {"holding": {"0": 123, "1": 230}})
    assert values == {"amp_l1": 12.3, "volts": 230}


def test_a_row_is_read_with_every_essential_field_its_section_sets(tmp_path):
    """The address list and the format clash in the table; the section gives both: the row is read with
    both. A section that still leaves the row unreadable is a warning saying why."""
    table, ini = write(
        tmp_path,
        "Address,Description,Format\n0 1,Alpha,UINT16\n2,Beta,UINT16\n3 4,Gamma,UINT16\n",
        "[Column/Field Indices]\ndescription = Description\naddresses = Address\nformat = Format\n"
        "[Function Name Search Synonyms]\nalpha = Alpha\nbeta = Beta\ngamma = Gamma\n"
        "[function alpha]\naddresses = 0,1\nformat = UINT32\n[function gamma]\naddresses = 3,4\n",
    )
    proc, fns = convert(tmp_path, table, ini)
    assert proc.returncode == 0, proc.stderr
    assert (fns["alpha"]["addresses"], fns["alpha"]["format"]) == ("0 1", "UINT32")
    assert f"{ini}:10: note: alpha: line 2 read with addresses 0,1 from [function alpha]" in proc.stderr
    assert "gamma" not in fns
    assert f"{ini}:12: warning: gamma: line 4 cannot be read with [function gamma]'s fields either: " in proc.stderr


def test_two_spellings_of_one_section_are_an_error(tmp_path):
    table, ini = write(
        tmp_path,
        "Address,Description,Format\n0,Phase current,UINT16\n",
        "[Function Name Search Synonyms]\nAmp_L1 = Phase current\n[function amp_l1]\nformat = INT16\n"
        "[function AMP_L1]\nmultiplier = 0.1\n",
    )
    proc, _ = convert(tmp_path, table, ini)
    assert_clean_error(
        proc, 1, f"{ini}:5: error: function 'AMP_L1' has two [function] sections ([function amp_l1] too)"
    )


def test_essential_cells_skip_the_row_others_keep_it(tmp_path):
    table, ini = write(
        tmp_path,
        "Address,Description,Type,Scale,Access,Unit\n0,Mode,int99,1,R,\n1,Power,UINT16,lots,sometimes,W\n"
        "2,Energy,UINT16,0.1,R,kWh\n",
        "[Column/Field Indices]\nformat = Type\nmultiplier = Scale\naccess = Access\n"
        "[Function Name Search Synonyms]\npower = Power\n",
    )
    proc, fns = convert(tmp_path, table, ini, "--all")
    assert proc.returncode == 0, proc.stderr
    assert (
        f"{table}:2: warning: row skipped: column 2 'Type' format cell 'int99': unknown format 'int99'" in proc.stderr
    )
    assert f"{table}:3: warning: column 3 'Scale' multiplier cell 'lots'" in proc.stderr
    assert f"{table}:3: warning: column 4 'Access' access cell 'sometimes'" in proc.stderr
    assert list(fns) == ["power", "energy"] and "multiplier" not in fns["power"] and "access" not in fns["power"]


def test_a_named_column_none_of_whose_cells_can_be_read_is_one_error(tmp_path):
    table, ini = write(
        tmp_path,
        "Address,Description,Type\n0,Mode,int99\n1,Power,int77\n",
        "[Column/Field Indices]\nformat = Type\n",
    )
    proc, _ = convert(tmp_path, table, ini, "--all")
    assert_clean_error(
        proc, 1, f"{table}:2: error: no cell of column 2 'Type' (named as format in the INI) could be read as format"
    )
    assert "usable address" not in proc.stderr


def test_a_guessed_column_never_costs_a_row(tmp_path):
    table, ini = write(
        tmp_path,
        "Address,Description,Type\n0,Mode,int99\n1,Power,UINT16\n2,Energy,UINT32\n",
        "[Function Name Search Synonyms]\nmode = Mode\n",
    )
    proc, fns = convert(tmp_path, table, ini, "--all")
    assert proc.returncode == 0, proc.stderr
    assert list(fns) == ["mode", "power", "energy"] and fns["mode"]["format"] == "UINT16"
    assert f"{table}:2: warning: column 2 'Type' format cell 'int99': unknown format 'int99'" in proc.stderr


# ---- 5. synonyms, --explain, --all --------------------------------------------------------------


def test_explain_says_which_cell_matched(tmp_path):
    proc = cli("csv2xml", VOCAB / "inverter.csv", "--ini", VOCAB / "inverter.ini", "--explain", "amp_l1")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "function 'amp_l1': synonyms 'Current, L1', 'amp l1' (its name); threshold 0.6"
    assert "on the description cell 'Current, L1': the text is the synonym 'Current, L1'" in lines[3]
    proc = cli("csv2xml", VOCAB / "inverter.csv", "--ini", VOCAB / "inverter.ini", "--explain", "NOM_P")
    assert "on the name cell 'NOM_P'" in proc.stdout


def test_all_names_unmatched_rows_by_their_own_text(tmp_path):
    table, ini = write(
        tmp_path,
        "Address,Description\n0,Supply voltage\n1,Room temperature\n2,Grid power\n",
        "[Function Name Search Synonyms]\ngrid = Grid power\n",
    )
    proc, fns = convert(tmp_path, table, ini, "--all")
    assert proc.returncode == 0, proc.stderr
    assert list(fns) == ["grid", "supply_voltage", "room_temperature"]  # never voltage_l1 from the bundled list


# ---- the new INI sections, fuzzed ---------------------------------------------------------------

FIELDS = ["format", "register_type", "access", "multiplier", "divisor", "count", "bits", "units", "addresses"]
VALUES = ["UINT16", "STRING 4", "UINT16 bit 3", "input", "coil", "read", "R/-", "0.1", "0", "x10", "3", "0-3", "", "="]
FUNCTION_KEYS = ["format", "count", "bits", "multiplier", "divisor", "offset", "units", "register_type", "access"]
FUNCTION_KEYS += ["byte_order", "word_order", "minimum", "maximum", "scale_exponent", "role", "addresses", "row"]
FUNCTION_VALUES = VALUES + ["INT32", "FLOAT32", "big", "little", "2", "4", "9", "-1", "1e999", "mode", "40001.3"]
KEYS = ["int", "FIX2", '"R/W: yes"', "*10", "bitfield", "x", '"a=b"', "STR32", "1"]
TABLE = "Address,Description,Type,Scale,Access\n0,Mode,int,FIX2,R/W: yes\n1,Power,bitfield,*10,R/-\n2,Name,STR32,,RO\n"


@st.composite
def ini_texts(draw: st.DrawFn) -> str:
    parts = ["[Function Name Search Synonyms]\nmode = Mode\npower = Power\n"]
    for f in draw(st.lists(st.sampled_from(FIELDS), max_size=3, unique=True)):
        pairs = draw(st.lists(st.tuples(st.sampled_from(KEYS), st.sampled_from(VALUES)), max_size=3))
        parts.append(f"[{f} cells]\n" + "".join(f"{k} = {v}\n" for k, v in dict(pairs).items()))
    for name in draw(st.lists(st.sampled_from(["mode", "power", "other"]), max_size=2, unique=True)):
        keys = draw(st.lists(st.sampled_from(FUNCTION_KEYS), max_size=4, unique=True))
        parts.append(
            f"[function {name}]\n" + "".join(f"{k} = {draw(st.sampled_from(FUNCTION_VALUES))}\n" for k in keys)
        )
    return "".join(parts)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ini_texts(), st.booleans())
def test_fuzz_vocabulary_sections(ini_text, emit_all):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "t.csv").write_text(TABLE)
        (folder / "t.ini").write_text(ini_text)
        out = folder / "out.xml"
        try:
            run_csv2xml(folder / "t.csv", folder / "t.ini", out, False, None, emit_all)
        except MdlError as exc:
            assert exc.exit_code == EXIT_INVALID
            for diag in exc.diagnostics:
                assert diag.file and re.match(r"^.+?(:\d+(:\d+)?)?: error: \S", str(diag)), str(diag)
            assert not out.exists()
            return
        device, diagnostics = validate_file(out)
        assert device is not None and not [d for d in diagnostics if d.severity == "error"], diagnostics


@settings(max_examples=200, deadline=None)
@given(
    st.text(alphabet="0123456789 ./()bBitxX-,\n", max_size=16)
    | st.sampled_from(["40001.3", "30101 (100)", "B3", "bool (bit 3)", "STRING 16", "UINT16 bit 3"])
)
def test_fuzz_vocabulary_cell_readers(text):
    """The new cell readers: a result or a CellError, never another exception."""
    for reader in (read_address_cell, parse_bit_cell, read_mapped_format):
        try:
            reader(text)
        except CellError as exc:
            assert str(exc)
