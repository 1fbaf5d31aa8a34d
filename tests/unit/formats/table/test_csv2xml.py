"""`mdl csv2xml`: ORNL's own example, messy vendor tables, matching, interactive mode, bad input."""

from __future__ import annotations

import shutil

import pytest
from lxml import etree

from support.common import DATA, EXAMPLE, ORNL, ROOT
from support.run import assert_clean_error, run_mdl
from support.tables import functions


@pytest.fixture
def ornl_copy(tmp_path):
    for name in ("tempco_device.ini", "tempco_address_map.csv"):
        shutil.copy(ORNL / name, tmp_path / name)
    return tmp_path


@pytest.mark.conformance("ornl")
def test_ornl_example_unchanged(ornl_copy):
    proc = run_mdl("csv2xml", ornl_copy / "tempco_device.ini")
    assert proc.returncode == 0, proc.stderr
    out = ornl_copy / "mdl_map.xml"  # the INI names the output, relative to itself
    text = out.read_text()
    fns = functions(text)
    assert list(fns) == [
        "temperature",
        "fan_relay_on",
        "cooling_stage1_relay_on",
        "cooling_stage2_relay_on",
        "heating_stage1_relay_on",
        "heating_stage2_relay_on",
        "temperature_set_point",
    ]
    assert {name: f["addresses"] for name, f in fns.items()} == {
        "temperature": "121",
        "fan_relay_on": "255",
        "cooling_stage1_relay_on": "256",
        "cooling_stage2_relay_on": "257",
        "heating_stage1_relay_on": "258",
        "heating_stage2_relay_on": "259",
        "temperature_set_point": "345",
    }
    # the table's own words: bytes in "Bytes", "0.1(?)" multipliers, "Low byte"
    assert fns["temperature"]["format"] == "INT16" and fns["temperature"]["multiplier"] == "0.1"
    assert "count" not in fns["temperature"]  # 2 bytes = one full word
    assert fns["fan_relay_on"]["length"] == "Lower byte" and fns["temperature_set_point"]["multiplier"] == "0.1"
    assert fns["fan_relay_on"]["description"] == "Relay1 manual output value"
    assert "read_function_code" not in text and "Enter" not in text
    ornl_xsd = etree.XMLSchema(etree.parse(str(ORNL / "mdl.xsd")))
    assert ornl_xsd.validate(etree.parse(str(out))), ornl_xsd.error_log
    assert run_mdl("validate", "--schema", "0.9b", out).returncode == 0


@pytest.mark.conformance("ornl")
def test_ornl_bytes_count_for_multi_register_rows(ornl_copy, tmp_path):
    ini = ornl_copy / "tempco_device.ini"
    ini.write_text(ini.read_text() + "serial_number = Serial Number\nsoftware_version = Software Version\n")
    proc = run_mdl("csv2xml", ini, "-o", tmp_path / "out.xml")
    fns = functions((tmp_path / "out.xml").read_text())
    assert fns["serial_number"]["addresses"] == "0 1 2 3" and fns["serial_number"]["count"] == "4"
    assert fns["software_version"]["addresses"] == "4 5" and fns["software_version"]["multiplier"] == "0.1"
    assert proc.returncode == 0


def test_meter_with_title_rows_modicon_input_registers_and_floats():
    proc = run_mdl("csv2xml", DATA / "meter.csv", "--ini", DATA / "meter.ini")
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    assert fns["voltage_l1"] == {
        **fns["voltage_l1"],
        "addresses": "0",
        "format": "FLOAT32",
        "register_type": "input",
        "units": "V",
    }
    assert fns["total_power"]["addresses"] == "52"  # not the "Total system power factor" row above it
    assert fns["total_energy"]["addresses"] == "342" and fns["frequency"]["units"] == "Hz"
    assert 'version="1.0"' in proc.stdout


def test_european_export_bom_semicolons_decimal_commas_degree_sign(tmp_path):
    proc = run_mdl(
        "csv2xml", DATA / "room_controller.csv", "--ini", DATA / "room_controller.ini", "-o", tmp_path / "rc.xml"
    )
    assert proc.returncode == 0, proc.stderr
    text = (tmp_path / "rc.xml").read_text(encoding="ascii")
    fns = functions(text)
    assert fns["room_temperature"]["multiplier"] == "0.1" and fns["room_temperature"]["units"] == "°C"
    assert fns["humidity"]["multiplier"] == "0.5" and fns["room_temperature"]["access"] == "read"
    assert fns["fan_stage"]["description"] == "Lüfterstufe" and fns["outdoor_temperature"]["multiplier"] == "0.01"
    assert "&#176;C" in text
    # the same table saved in Windows-1252 without a BOM
    latin = tmp_path / "rc1252.csv"
    latin.write_bytes((DATA / "room_controller.csv").read_text(encoding="utf-8-sig").encode("cp1252"))
    proc = run_mdl("csv2xml", latin, "--ini", DATA / "room_controller.ini")
    assert functions(proc.stdout) == fns


def test_phrases_that_contain_each_other_pick_the_closest_row():
    proc = run_mdl("csv2xml", DATA / "thermostat_setpoints.csv", "--ini", DATA / "thermostat_setpoints.ini")
    fns = functions(proc.stdout)
    assert fns["occupied_heating_setpoint"]["addresses"] == "102"
    assert fns["occupied_cooling_setpoint"]["addresses"] == "103"
    assert fns["occupied_heating_setpoint"]["description"].startswith("Occupied heating setpoint, used while the\nroom")


def test_bad_row_is_reported_with_its_line_and_others_convert():
    proc = run_mdl("csv2xml", DATA / "thermostat_setpoints.csv", "--ini", DATA / "thermostat_setpoints.ini")
    assert proc.returncode == 0
    # line 9: the quoted description of register 102 spans lines 4-5
    # a format column found by its header never costs a row (SPEC 4.1): the row is kept, as UINT16
    assert (
        f"{DATA / 'thermostat_setpoints.csv'}:9: warning: column 2 'Type' format cell 'int99': unknown format 'int99'"
        in proc.stderr
    )
    assert functions(proc.stdout)["fan_speed"]["addresses"] == "107"


def test_address_forms_and_all():
    proc = run_mdl("csv2xml", DATA / "address_forms.csv", "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    got = {
        name: (f["addresses"], f.get("register_type", "holding"), f.get("format"), f.get("count"))
        for name, f in fns.items()
    }
    assert got == {
        "hex_address": ("16", "holding", "UINT16", None),
        "range_with_to": ("20 21", "holding", "UINT32", "2"),
        "range_without_spaces": ("22 23", "holding", "INT32", "2"),
        "range_with_dash": ("24 25", "holding", "FLOAT32", "2"),
        "list": ("26 27", "holding", "UINT32", "2"),
        "modicon_x_form": ("30", "holding", "UINT16", None),
        "named_holding": ("40", "holding", "UINT16", None),
        "named_input": ("7", "input", "INT16", None),
        "named_coil": ("3", "coil", "BIT", None),
        "named_discrete": ("4", "discrete", "BIT", None),
        "counted_words": ("50", "holding", "UINT16", "2"),
        "text": ("60", "holding", "STRING", "4"),
    }


def test_interactive_mode_is_driven_by_its_prompt():
    # occupied_heating_setpoint: pick the 2nd candidate; occupied_cooling_setpoint: skip; fan_speed: default (1st)
    proc = run_mdl(
        "csv2xml", DATA / "thermostat_setpoints.csv", "--ini", DATA / "thermostat_setpoints.ini", "-i", input="2\n0\n\n"
    )
    assert proc.returncode == 0, proc.stderr
    assert "function 'occupied_heating_setpoint': which row?" in proc.stderr
    assert "1. [0.94] line 4: Occupied heating setpoint, used while the room is occupied" in proc.stderr
    fns = functions(proc.stdout)
    assert set(fns) == {"occupied_heating_setpoint", "fan_speed"}
    assert fns["occupied_heating_setpoint"]["addresses"] != "102" and fns["fan_speed"]["addresses"] == "107"


def test_interactive_refuses_out_of_range_choice():
    proc = run_mdl(
        "csv2xml",
        DATA / "thermostat_setpoints.csv",
        "--ini",
        DATA / "thermostat_setpoints.ini",
        "-i",
        input="42\n1\n1\n1\n",
    )
    assert proc.returncode == 0
    assert "42 is not in the range" in proc.stderr


def test_example_ini_reproduces_committed_mdl(tmp_path):
    shutil.copy(EXAMPLE / "temco_tstat.csv", tmp_path)
    shutil.copy(EXAMPLE / "temco_tstat.ini", tmp_path)
    proc = run_mdl("csv2xml", tmp_path / "temco_tstat.ini")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "temco_tstat.xml").read_text() == (EXAMPLE / "temco_tstat.xml").read_text()


def test_options_win_over_the_ini(tmp_path):
    shutil.copy(EXAMPLE / "temco_tstat.csv", tmp_path / "other.csv")
    shutil.copy(EXAMPLE / "temco_tstat.ini", tmp_path)
    proc = run_mdl("csv2xml", tmp_path / "other.csv", "--ini", tmp_path / "temco_tstat.ini", "-o", tmp_path / "o.xml")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "o.xml").exists() and not (tmp_path / "temco_tstat.xml").exists()


@pytest.mark.parametrize(
    "ini_text, fragments",
    [
        ("[Modbus Device]\ndevice_name = x\nthreshold = abc\n", [":3: error: threshold must be a number"]),
        ("[Modbus Device]\nbyte_order = middle\n", [":2: error: byte_order must be one of big, little"]),
        ("[Input/Output]\nlines_to_skip = two\n", [":2: error: lines_to_skip must be a whole number"]),
        ("device_name = x\n", ["error: a key before any [section]"]),
        ("[Modbus Device]\ndevice_name = a\ndevice_name = b\n", [":3: error: key 'device_name' appears twice"]),
        ("[Column/Field Indices]\naddresses = No Such Header\n", ["no row holds the header texts 'No Such Header'"]),
        (
            "[Column/Field Indices]\naddresses = Register\nunits = Unit Name\n",
            ["units = Unit Name: no such column in the header row (line 4)"],
        ),
    ],
)
def test_bad_ini_values_are_errors(tmp_path, ini_text, fragments):
    ini = tmp_path / "bad.ini"
    ini.write_text(ini_text)
    out = tmp_path / "out.xml"
    out.write_text("previous output")
    proc = run_mdl("csv2xml", EXAMPLE / "temco_tstat.csv", "--ini", ini, "-o", out)
    assert_clean_error(proc, 1, *fragments)
    assert out.read_text() == "previous output"  # nothing lost


def test_unknown_ini_sections_and_keys_warn(tmp_path):
    text = (
        (EXAMPLE / "temco_tstat.ini")
        .read_text()
        .replace("[Input/Output]", "[Extras]\ncolour = red\n\n[Input/Output]\nspeed = 3")
    )
    ini = tmp_path / "temco_tstat.ini"
    ini.write_text(text)
    shutil.copy(EXAMPLE / "temco_tstat.csv", tmp_path)
    proc = run_mdl("csv2xml", ini, "-o", tmp_path / "x.xml")
    assert proc.returncode == 0, proc.stderr
    assert "warning: unknown section [Extras] is ignored" in proc.stderr
    assert "warning: unknown key 'speed' in [Input/Output] is ignored" in proc.stderr


def test_bad_tables(tmp_path):
    missing = tmp_path / "none.csv"
    assert_clean_error(run_mdl("csv2xml", missing), 1, f"{missing}: error: no such file")
    noheader = tmp_path / "noheader.csv"
    noheader.write_text("a,b,c\n1,2,3\n")
    assert_clean_error(run_mdl("csv2xml", noheader), 1, f"{noheader}:1: error: no recognizable header row")
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"Address,Description\n1,ok\n\x00\x01\x02")
    assert_clean_error(run_mdl("csv2xml", binary), 1, f"{binary}:3: error: a NUL byte")
    undecodable = tmp_path / "undecodable.csv"
    undecodable.write_bytes(b"Address,Description\n1,caf\x81\n")
    assert_clean_error(run_mdl("csv2xml", undecodable), 1, f"{undecodable}:2:", "cannot decode byte 0x81")
    empty = tmp_path / "empty.csv"
    empty.write_text("\n\n")
    assert_clean_error(run_mdl("csv2xml", empty), 1, "no rows")
    toobig = tmp_path / "toobig.csv"
    toobig.write_text("Address,Description,Format\n70000,Too high,uint16\n1 to 200,Too long,string\n5,Fine,uint16\n")
    proc = run_mdl("csv2xml", toobig, "--all", "--threshold", "1")
    assert proc.returncode == 0
    assert ":2: warning: row skipped: address 70000 is over 65535" in proc.stderr
    assert ":3: warning: row skipped: the value needs 200 registers" in proc.stderr
    assert list(functions(proc.stdout)) == ["fine"]


def test_no_match_is_an_error(tmp_path):
    ini = tmp_path / "d.ini"
    ini.write_text("[Function Name Search Synonyms]\nxyzzy = plugh\n")
    out = tmp_path / "o.xml"
    proc = run_mdl("csv2xml", EXAMPLE / "temco_tstat.csv", "--ini", ini, "-o", out)
    assert_clean_error(proc, 1, "no function matched")
    assert not out.exists()


def test_readme_mentions_every_command():
    readme = (ROOT / "README.md").read_text()
    for command in ("csv2xml", "validate", "gen", "sim", "read", "write"):
        assert f"mdl {command}" in readme


def test_an_mdl_description_is_said_to_be_one(tmp_path):
    """csv2xml of an MDL file says what it is and what reads it, not "no recognizable header row" (issue 37)."""
    out = tmp_path / "out.xml"
    proc = run_mdl("csv2xml", EXAMPLE / "temco_tstat.xml", "-o", out)
    assert_clean_error(proc, 1, "this is already an MDL description", "`mdl validate`")
    assert "header" not in proc.stderr and not out.exists()
