"""`mdl csv2xml` on tables shaped like the ones vendors publish (SPEC 4): scales that divide, scales
written before their unit, access letters, register-type words, Modicon columns with a stray row,
header guesses checked against their cells, the phrase tie-break, name columns named in the INI.
Values are proven by serving the converted description with `mdl sim` and reading it back."""

from __future__ import annotations

import shutil

import pytest

from support.common import DATA
from support.corpus import read_served as read_values
from support.run import assert_clean_error, cli
from support.tables import functions

TABLES = DATA / "csv2xml"


def convert(tmp_path, table: str, *args: str, ini: str | None = None):
    """csv2xml of tests/data/csv2xml/TABLE (with INI if given) to tmp_path/out.xml: (proc, functions)."""
    out = tmp_path / "out.xml"
    extra = ["--ini", TABLES / ini] if ini else []
    proc = cli("csv2xml", TABLES / table, *extra, "-o", out, *args)
    return proc, (functions(out.read_text()) if out.exists() else {})


# ---- scales -----------------------------------------------------------------------------------


@pytest.mark.commands  # serves or dials a device
def test_a_divisor_column_divides(tmp_path, sim_factory):
    """Victron's "Scalefactor 10" means tenths: named as divisor, 2305 reads 230.5, not 23050."""
    proc, fns = convert(tmp_path, "victron_gx.csv", ini="victron_gx.ini")
    assert proc.returncode == 0, proc.stderr
    assert fns["ac_input_voltage"]["multiplier"] == "0.1" and fns["battery_voltage"]["multiplier"] == "0.01"
    assert "multiplier" not in fns["switch_position"]  # a scale factor of 1
    assert fns["ac_input_voltage"]["access"] == "read" and "access" not in fns["current_limit"]  # writable: yes
    # a divisor that is not a number: reported with its line and column; the row keeps no scale (SPEC 4.1)
    assert (
        f"{TABLES / 'victron_gx.csv'}:8: warning: column 4 'Scalefactor' divisor cell 'x': divisor 'x' is not a scale"
    ) in proc.stderr
    assert "multiplier" not in fns["state_of_charge"]
    xml = tmp_path / "out.xml"
    values = read_values(
        sim_factory,
        xml,
        {"holding": {"3": 2305, "9": 5000, "22": 160, "26": 2654}},
        "ac_input_voltage",
        "ac_frequency",
        "current_limit",
        "battery_voltage",
    )
    assert values == {"ac_input_voltage": 230.5, "ac_frequency": 50.0, "current_limit": 16.0, "battery_voltage": 26.54}


@pytest.mark.commands  # serves or dials a device
def test_scales_written_before_their_unit_and_function_codes(tmp_path, sim_factory):
    """An inverter table as an open-source Modbus library keeps it: a `function` column of function
    codes, a `unit` column of `0,1V`, wire addresses that look like Modicon numbers; no INI columns."""
    proc, fns = convert(tmp_path, "inverter_grug.csv", ini="inverter_grug.ini")
    assert proc.returncode == 0, proc.stderr
    pv = fns["pv_voltage_1"]
    assert (pv["addresses"], pv["register_type"], pv["multiplier"], pv["units"]) == ("33049", "input", "0.1", "V")
    assert fns["grid_frequency"]["multiplier"] == "0.01" and fns["grid_frequency"]["units"] == "Hz"
    assert "multiplier" not in fns["pv_power"] and fns["pv_power"]["units"] == "W"  # 1W
    assert fns["remote_control"]["addresses"] == "43000" and "register_type" not in fns["remote_control"]
    # the function codes are the register type, never the description
    assert fns["pv_voltage_1"]["description"] == "DC voltage 1"
    err = proc.stderr
    assert "register_type = column 0 'function'" in err
    assert "multiplier = column 4 'unit', units = column 4 'unit'" in err
    assert "read as wire addresses (0-based), though 7 of 8 look like Modicon" in err
    assert "set address_base = modicon in [Modbus Device]" in err
    assert "decimal comma: '0,1V' on line 2" in err and "decimal_separator = point" in err
    assert "warning" not in err
    values = read_values(
        sim_factory, tmp_path / "out.xml", {"input": {"33049": 3456, "33094": 5001}}, "pv_voltage_1", "grid_frequency"
    )
    assert values == {"pv_voltage_1": 345.6, "grid_frequency": 50.01}


SCALE_CELLS = [  # cell, multiplier written, units written
    ("0.1V", "0.1", "V"),
    ('"0,01Hz"', "0.01", "Hz"),
    ("-1W", "-1", "W"),
    ("scale(0.001)", "0.001", None),
    ("x10", "10", None),
    ("1/10", "0.1", None),
    ("0.1(?)", "0.1", None),
    ("10^-2", "0.01", None),
    ("0.5 %RH", "0.5", "%RH"),
    ("1", None, None),
    ("-", None, None),
]


@pytest.mark.parametrize("cell, multiplier, units", SCALE_CELLS, ids=[c[0] for c in SCALE_CELLS])
def test_scale_cells(tmp_path, cell, multiplier, units):
    table = tmp_path / "t.csv"
    table.write_text(f"Address,Description,Type,Scale\n0,Room temperature,int16,{cell}\n")
    ini = tmp_path / "t.ini"
    ini.write_text("[Column/Field Indices]\nmultiplier = Scale\nunits = Scale\n")
    proc = cli("csv2xml", table, "--ini", ini, "--all")
    assert proc.returncode == 0, proc.stderr
    fn = functions(proc.stdout)["room_temperature"]
    assert (fn.get("multiplier"), fn.get("units")) == (multiplier, units)


@pytest.mark.parametrize("cell", ["mod10k(True)", "scale_int(10)", "10k", "abc", "1/0", "1e999", "0.1.2", "x"])
def test_a_scale_cell_that_is_not_a_number_is_reported(tmp_path, cell):
    """Never the first number inside it: mod10k(True) is not a multiplier of 10."""
    table = tmp_path / "t.csv"
    table.write_text(f"Address,Description,Type,Multiplier\n0,Room temperature,int16,{cell}\n1,Humidity,uint16,0.5\n")
    proc = cli("csv2xml", table, "--all")
    assert proc.returncode == 0, proc.stderr
    assert f"{table}:2: warning: column 3 'Multiplier' multiplier cell '{cell}'" in proc.stderr
    assert "multiplier left at its default (the row is kept)" in proc.stderr  # SPEC 4.1
    fns = functions(proc.stdout)
    assert list(fns) == ["room_temperature", "humidity"] and fns["humidity"]["multiplier"] == "0.5"
    assert "multiplier" not in fns["room_temperature"]


def test_bad_divisors_and_two_scales_are_reported_row_by_row(tmp_path):
    proc, fns = convert(tmp_path, "bad_scales.csv", "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    path = TABLES / "bad_scales.csv"
    # each row is kept with no scale (SPEC 4.1: only essential cells cost a row)
    assert f"{path}:3: warning: both a multiplier ('0.1') and a divisor ('10')" in proc.stderr
    assert f"{path}:4: warning: column 4 'Divisor' divisor '0' is 0" in proc.stderr
    assert f"{path}:5: warning: column 3 'Multiplier' multiplier cell 'mod10k(True)'" in proc.stderr
    assert {name: f.get("multiplier") for name, f in fns.items() if f.get("multiplier")} == {
        "room_temperature": "0.1",
        "flow": "0.1",
    }
    assert len(fns) == 5 and "0 skipped" in proc.stderr


def test_multiplier_and_divisor_naming_one_column_is_an_error(tmp_path):
    ini = tmp_path / "d.ini"
    ini.write_text("[Column/Field Indices]\nmultiplier = Scalefactor\ndivisor = Scalefactor\n")
    assert_clean_error(
        cli("csv2xml", TABLES / "victron_gx.csv", "--ini", ini), 1, "multiplier and divisor name the same column"
    )


def test_a_header_guessed_whole_number_scale_says_it_could_divide(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Address,Description,Type,Scale Factor\n0,Room temperature,int16,10\n1,Humidity,uint16,1\n")
    proc = cli("csv2xml", table, "--all")
    assert proc.returncode == 0
    assert "column 3 'Scale Factor' is read as a multiplier" in proc.stderr
    assert "set divisor = Scale Factor and multiplier = (blank) in [Column/Field Indices]" in proc.stderr


# ---- access letters ---------------------------------------------------------------------------


@pytest.mark.commands  # serves or dials a device
def test_w_in_a_column_of_r_and_w_means_writable(tmp_path, sim_factory):
    proc, fns = convert(tmp_path, "rw_letters.csv", ini="rw.ini")
    assert proc.returncode == 0, proc.stderr
    assert "access" not in fns["setpoint"] and "access" not in fns["fan_speed"]  # read and write
    assert fns["room_temperature"]["access"] == "read"
    assert "holds only the letters R and W: W is read as writable" in proc.stderr
    # mdl read reads every function of it, the W ones too
    values = read_values(sim_factory, tmp_path / "out.xml", {"holding": {"0": 215, "1": 220, "2": 3, "3": 7}})
    assert values == {"room_temperature": 21.5, "setpoint": 22.0, "fan_speed": 3, "reset": 7}


def test_w_beside_r_w_means_write_only(tmp_path):
    proc, fns = convert(tmp_path, "rw_mixed.csv", ini="rw.ini")
    assert proc.returncode == 0, proc.stderr
    assert fns["reset"]["access"] == "write" and "access" not in fns["setpoint"]
    assert "W is read as writable" not in proc.stderr


ACCESS_COLUMNS = [  # the cells of one access column -> the <access> each row gets (None: read and write)
    (("R", "W"), ("read", None)),
    (("R", "W", "R/W"), ("read", "write", None)),
    (("RO", "RW", "W"), ("read", None, "write")),
    (("FALSE", "TRUE"), ("read", None)),
    (("no", "yes"), ("read", None)),
    (("W/R(Reboot after write)", "R"), (None, "read")),
    (("WO", "R"), ("write", "read")),
]


@pytest.mark.parametrize("cells, access", ACCESS_COLUMNS, ids=["/".join(c) for c, _ in ACCESS_COLUMNS])
def test_access_cells(tmp_path, cells, access):
    rows = "".join(f"{i},Point {i},uint16,{c}\n" for i, c in enumerate(cells))
    table = tmp_path / "t.csv"
    table.write_text("Address,Description,Type,Access\n" + rows)
    proc = cli("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    assert tuple(f.get("access") for f in functions(proc.stdout).values()) == access


# ---- addresses --------------------------------------------------------------------------------


def test_a_stray_row_in_a_modicon_column_is_reported_not_obeyed(tmp_path):
    proc, fns = convert(tmp_path, "meter_modicon.csv", ini="meter_modicon.ini")
    assert proc.returncode == 0, proc.stderr
    assert {n: (f["addresses"], f["register_type"]) for n, f in fns.items()} == {
        "voltage_l1": ("0", "input"),
        "current_l1": ("6", "input"),
        "total_power": ("52", "input"),
        "frequency": ("70", "input"),
        "total_energy": ("342", "input"),
    }
    assert fns["total_energy"]["description"] == "Total kwh"  # the stray row could not serve it
    path = TABLES / "meter_modicon.csv"
    assert f"{path}:8: warning: row skipped: '342' is not a Modicon 5- or 6-digit register number" in proc.stderr
    assert "set address_base = 0 or 1 in [Modbus Device]" in proc.stderr
    assert "note: addresses read as Modicon register numbers" in proc.stderr


def test_strict_and_fail_on_warning_refuse_a_table_with_skipped_rows(tmp_path):
    out = tmp_path / "out.xml"
    for flag in ("--strict", "--fail-on-warning"):
        proc = cli("csv2xml", TABLES / "meter_modicon.csv", "--ini", TABLES / "meter_modicon.ini", "-o", out, flag)
        assert_clean_error(proc, 1, "row skipped: '342'", f"1 warning and {flag}: nothing written")
        assert "summary: 8 rows read, 1 skipped" in proc.stderr
        assert not out.exists()
    proc = cli("csv2xml", TABLES / "inverter_grug.csv", "--ini", TABLES / "inverter_grug.ini", "-o", out, "--strict")
    assert proc.returncode == 0 and out.exists()  # notes are not warnings


def test_address_base_in_the_ini_is_obeyed_and_silences_the_guess(tmp_path):
    ini = tmp_path / "m.ini"
    ini.write_text(
        (TABLES / "meter_modicon.ini").read_text().replace("[Modbus Device]", "[Modbus Device]\naddress_base = 0")
    )
    proc = cli("csv2xml", TABLES / "meter_modicon.csv", "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    assert functions(proc.stdout)["voltage_l1"]["addresses"] == "30001"
    assert "addresses read as" not in proc.stderr and "warning" not in proc.stderr


def test_volttron_register_map(tmp_path):
    """A VOLTTRON modbus_tk map: Table names, Writable TRUE/FALSE, scale() transforms, coil numbers
    without their zeros; `total real power` takes the instantaneous row, not the demand."""
    proc, fns = convert(tmp_path, "volttron_meter.csv", ini="volttron_meter.ini")
    assert proc.returncode == 0, proc.stderr
    assert fns["total_power"]["description"] == "TOTAL INSTANTANEOUS REAL POWER"
    assert (fns["total_power"]["addresses"], fns["total_power"]["multiplier"]) == ("129", "0.1")
    assert fns["total_power"]["access"] == "read"  # Writable FALSE
    assert (fns["voltage_a"]["addresses"], fns["voltage_a"]["register_type"]) == ("99", "input")
    assert (fns["relay"]["addresses"], fns["relay"]["register_type"]) == ("0", "coil")
    assert (fns["alarm"]["addresses"], fns["alarm"]["register_type"]) == ("0", "discrete")
    assert "access" not in fns["demand_interval"]  # Writable TRUE
    assert (
        f"{TABLES / 'volttron_meter.csv'}:5: warning: column 5 'Transform' multiplier cell 'mod10k(True)'"
        in proc.stderr
    )
    assert "multiplier" not in fns["energy"]  # kept, its scale at the default (SPEC 4.1)


def test_explain_shows_the_tie_break(tmp_path):
    proc = cli(
        "csv2xml",
        TABLES / "volttron_meter.csv",
        "--ini",
        TABLES / "volttron_meter.ini",
        "-o",
        tmp_path / "out.xml",
        "--explain",
        "total_power",
    )
    assert proc.returncode == 0, proc.stderr
    assert not (tmp_path / "out.xml").exists()  # --explain writes no MDL
    lines = proc.stdout.splitlines()
    assert lines[0] == "function 'total_power': synonyms 'total real power', 'total power' (its name); threshold 0.6"
    assert lines[1] == "  chosen: line 4 (score 0.95)"
    assert lines[2] == "   1. 0.95 phrase line 4: TOTAL INSTANTANEOUS REAL POWER  <- chosen"
    assert "1 word between its words" in lines[3] and "its clause ends there" in lines[3]
    assert lines[4] == "   2. 0.91 phrase line 3: TOTAL REAL POWER MAX. DEMAND IMPORT"
    assert "another word follows in its clause" in lines[5]


def test_explain_an_unmatched_function_and_a_free_phrase(tmp_path):
    proc = cli(
        "csv2xml",
        TABLES / "volttron_meter.csv",
        "--ini",
        TABLES / "volttron_meter.ini",
        "--explain",
        "energy",
        "--explain",
        "relay status",
    )
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "function 'energy': synonyms 'energy delivered', 'energy' (its name); threshold 0.6" in out
    assert "chosen: line 5 (score 1.00)" in out  # its mod10k(True) scale no longer costs the row (SPEC 4.1)
    assert "   1. 1.00 exact  line 5: ENERGY DELIVERED  <- chosen" in out
    assert "'relay status' is not a function of the INI or the bundled list: scoring it as a synonym" in out
    assert "   1. 0.63 fuzzy  line 8: RELAY 1  (taken by relay)\n" in out


# ---- columns ----------------------------------------------------------------------------------


def test_a_function_column_of_function_codes_is_the_register_type(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Function,Address,Name,Type\n4,0,Grid voltage,U16\n3,10,Battery setpoint,U16\nFC01,5,Relay,bool\n")
    proc = cli("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    assert {n: (f.get("register_type"), f["description"]) for n, f in fns.items()} == {
        "grid_voltage": ("input", "Grid voltage"),
        "battery_setpoint": (None, "Battery setpoint"),
        "relay": ("coil", "Relay"),
    }
    assert (
        "column 0 'Function' has a header like description but its cells are not ('4' on line 2): "
        "read as register_type" in proc.stderr
    )


def test_a_guessed_column_whose_cells_do_not_fit_is_not_used(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Address,Description,Type\n0,Room temperature,see page 4\n1,Humidity,see page 5\n")
    proc = cli("csv2xml", table, "--all")
    assert proc.returncode == 0, proc.stderr
    assert (
        "column 2 'Type' has a header like format but its cells are not ('see page 4' on line 2): ignored"
        in proc.stderr
    )
    assert functions(proc.stdout)["room_temperature"]["format"] == "UINT16"


def test_a_name_column_named_in_the_ini_is_matched(tmp_path):
    proc, fns = convert(tmp_path, "named.csv", ini="named.ini")
    assert proc.returncode == 0, proc.stderr
    assert {n: f["addresses"] for n, f in fns.items()} == {
        "room_temperature": "0",
        "occupied_setpoint": "1",
        "fan_speed": "2",
    }
    assert fns["room_temperature"]["description"] == "Measured value (see note 1)"  # the vendor's text kept


def test_markdown_inventory(tmp_path):
    table = tmp_path / "inventory.md"
    shutil.copy(TABLES / "meter_inventory.md", table)
    ini = tmp_path / "inventory.ini"
    ini.write_text(
        "[Function Name Search Synonyms]\nvoltage = voltage\npower = active power\naddress = meter address\n"
    )
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    assert (fns["voltage"]["addresses"], fns["voltage"]["count"], fns["voltage"]["format"]) == ("0", "2", "FLOAT32")
    assert fns["power"]["register_type"] == "input" and "multiplier" not in fns["power"]
    assert (fns["address"]["addresses"], fns["address"].get("count")) == ("28", None)  # 2 bytes: one register
    assert "note: a Markdown table" in proc.stderr
    assert "counts in column 3 'Length' read as bytes" in proc.stderr and "count_unit = words" in proc.stderr


# ---- notes, overrides and the summary -----------------------------------------------------------


def test_every_guess_is_a_note_naming_its_ini_key(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Adresse;Bezeichnung;Datentyp;Faktor;Anzahl\n0;Raumtemperatur;S16;0,1;1\n1;Zähler;U32;1;2\n")
    ini = tmp_path / "t.ini"
    ini.write_text("[Function Name Search Synonyms]\nroom_temperature = raumtemperatur\ncounter = zähler\n")
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if ": note: " in line]
    for key in (
        "delimiter = comma, semicolon, tab or pipe in [Input/Output]",
        "[Column/Field Indices]",
        "address_base = 1 in [Modbus Device]",
        "decimal_separator = point in [Input/Output]",
        "count_unit = bytes in [Modbus Device]",
    ):
        assert any(key in line for line in notes), (key, notes)
    assert notes[-1] == f"{table}: note: summary: 2 rows read, 0 skipped; 2 functions matched, 0 unmatched"
    # the same table with each setting in the INI: nothing left to guess but the columns
    ini.write_text(
        "[Modbus Device]\naddress_base = 0\ncount_unit = words\n[Input/Output]\ndelimiter = semicolon\n"
        "decimal_separator = comma\n[Column/Field Indices]\naddresses = Adresse\ndescription = Bezeichnung\n"
        "format = Datentyp\nmultiplier = Faktor\ncount = Anzahl\n" + ini.read_text()
    )
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    assert [line for line in proc.stderr.splitlines() if ": note: " in line] == [notes[-1]]
    assert functions(proc.stdout)["room_temperature"]["multiplier"] == "0.1"


def test_bad_new_ini_values_are_errors(tmp_path):
    ini = tmp_path / "t.ini"
    ini.write_text("[Input/Output]\ndelimiter = colon\ndecimal_separator = dot-ish\n")
    assert_clean_error(
        cli("csv2xml", TABLES / "rw_letters.csv", "--ini", ini),
        1,
        ":2: error: delimiter must be one of comma, semicolon, tab, pipe, not 'colon'",
        ":3: error: decimal_separator must be point or comma, not 'dot-ish'",
    )


def test_decimal_separator_point_reads_thousands(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text('Address,Description,Type,Multiplier,Maximum\n0,Energy,uint32,"1,000",1.5\n')
    ini = tmp_path / "t.ini"
    ini.write_text("[Input/Output]\ndecimal_separator = point\n[Function Name Search Synonyms]\nenergy = energy\n")
    fns = functions(cli("csv2xml", table, "--ini", ini).stdout)
    assert fns["energy"]["multiplier"] == "1000" and fns["energy"]["maximum"] == "1.5"


def test_the_summary_counts_rows_and_functions(tmp_path):
    proc = cli("csv2xml", TABLES / "victron_gx.csv", "--ini", TABLES / "victron_gx.ini")
    last = proc.stderr.splitlines()[-1]
    assert (
        last == f"{TABLES / 'victron_gx.csv'}: note: summary: 7 rows read, 0 skipped; 7 functions matched, 0 unmatched"
    )


def test_a_repeated_header_and_a_title_row_are_said_not_warned(tmp_path):
    """A table printed in sections repeats its header and puts section titles in the address column:
    neither is a register, nor a row csv2xml could not read (a note each, no warning)."""
    table = tmp_path / "t.csv"
    table.write_text(
        "Address,Description,Type\n0,Room temperature,int16\n7,Supply air,int16\n8,Exhaust air,int16\n"
        "9,Outdoor air,int16\n10,Return water,int16\nCOIL REGISTERS,,\n"
        "Registers 1 to 49 are measurements and status information,,\nAddress,Description,Type (bits)\n"
        "1,Fan speed,uint16\n"
    )
    ini = tmp_path / "t.ini"
    ini.write_text("[Function Name Search Synonyms]\nroom_temperature = room temperature\nfan_speed = fan speed\n")
    proc = cli("csv2xml", table, "--ini", ini, "--strict")
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stderr
    assert f"{table}:9: note: line 9 repeats the header" in proc.stderr
    assert "line 7 is a title or a remark ('COIL REGISTERS'" in proc.stderr
    assert "line 8 is a title or a remark ('Registers 1 to 49" in proc.stderr
    assert functions(proc.stdout)["fan_speed"]["addresses"] == "1"


def test_raw_limits_are_scaled_with_the_offset_and_the_inis_scale(tmp_path):
    """`limits = raw`: a limit is a register value, so it is scaled as the value is, offset and a
    [function NAME] multiplier included (-40 + 0.1 x 1000 = 60 °C; 200 x 0.5 = 100)."""
    table = tmp_path / "t.csv"
    table.write_text(
        "Address,Description,Type,Scale,Offset,Min,Max,Unit\n0,Supply temperature,INT16,0.1,-40,0,1000,C\n"
        "1,Fan speed,UINT16,1,10,0,90,%\n2,Pump,UINT16,1,,0,200,%\n3,Valve,INT16,-1,,-50,20,%\n"
    )
    ini = tmp_path / "t.ini"
    ini.write_text(
        "[Modbus Device]\nlimits = raw\n[Column/Field Indices]\nmultiplier = Scale\noffset = Offset\n"
        "minimum = Min\nmaximum = Max\n[Function Name Search Synonyms]\nsupply = Supply temperature\n"
        "fan = Fan speed\npump = Pump\nvalve = Valve\n[function pump]\nmultiplier = 0.5\n"
    )
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    limits = {n: (fns[n].get("minimum"), fns[n].get("maximum")) for n in ("supply", "fan", "pump", "valve")}
    assert limits == {"supply": ("-40", "60"), "fan": ("10", "100"), "pump": ("0", "100"), "valve": ("-20", "50")}
    assert "pump: multiplier 0.5 from [function pump]" in proc.stderr
