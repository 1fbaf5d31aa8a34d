"""Corpus: register tables that solar vendors and the projects around them publish (PV inverters,
hybrid inverters with batteries), each read by `mdl csv2xml` with an INI written from docs/ only, served
by `mdl sim` with raw registers worked out by hand from the vendor's documented encoding, and read
back with `mdl read`. Sources, commits and licences: tests/data/corpus/README.md (section "solar")."""

from __future__ import annotations

import json

from support.corpus import CORPUS, check_table, convert
from support.run import run_mdl

SOLAR = CORPUS / "solar"


def test_sma_sunny_tripower_html_modbus_list(tmp_path, sim_factory):
    """SMA Sunny Tripower 8.0/10.0: SMA's own HTML Modbus list (the first 200 of its rows). Hard: a
    20-column page where the SMA and SunSpec views of each value stand side by side; the scale is a
    code in a "Data format" column (FIX2, TEMP, and TAGLIST/UTF8 meaning no scale at all); STR32 with a
    count column that disagrees; a U64 counter; the same name and text on up to four rows (Total
    yield in Wh, kWh, MWh); SMA addresses that look like Modicon numbers but are wire addresses."""
    registers = {
        "holding": {
            # GridMs.TotW 30775 S32 FIX0 W: 9876 W
            "30775": 0,
            "30776": 9876,
            # GridMs.Hz 30803 U32 FIX2 Hz: 50.02 Hz is 5002
            "30803": 0,
            "30804": 5002,
            # GridMs.A.phsA 30977 S32 FIX3 A: 12.345 A is 12345
            "30977": 0,
            "30978": 12345,
            # Metering.TotWhOut 30513 U64 FIX0 Wh: 12,345,678,901 Wh = 0x0000_0002_DFDC_1C35
            "30513": 0,
            "30514": 2,
            "30515": 0xDFDC,
            "30516": 0x1C35,
            # Coolsys.Cab.TmpVal 30953 S32 TEMP: -5.2 degC is -52 = 0xFFFF_FFCC
            "30953": 0xFFFF,
            "30954": 0xFFCC,
            # Operation.Health 30201 U32 TAGLIST: 307 is "Ok"
            "30201": 0,
            "30202": 307,
            # Nameplate.Location 40631, 12 registers of UTF-8, two characters each, high byte first
            "40631": 0x526F,  # "Ro"
            "40632": 0x6F66,  # "of"
            "40633": 0x2045,  # " E"
            "40634": 0x6173,  # "as"
            "40635": 0x7400,  # "t", then NULs
            # PCC.WMax 41217 U32 FIX0 W (RW): 10000 W
            "41217": 0,
            "41218": 10000,
        }
    }
    expected = {
        "ac_power": 9876,
        "grid_frequency": 50.02,
        "grid_current_l1": 12.345,
        "total_yield": 12345678901,
        "internal_temp": -5.2,
        "condition": 307,
        "location": "Roof East",
        "grid_power_limit": 10000,
    }
    proc, fns = check_table(
        tmp_path, sim_factory, SOLAR / "sma_stp10_modbuslist_en.html", SOLAR / "sma_stp10.ini", registers, expected
    )
    err = proc.stderr
    # the STR32 cells are 16 registers wide, SMA's count column says 8 or 12: the count wins, said once
    assert "format 'STR32' on line 32 (and any like it) is 16 registers wide but the count column says 8" in err
    assert fns["location"]["count"] == "12"
    # the rows the INI picked among identical names are said at the INI's lines
    assert "total_yield: line 144 of the table" in err
    assert "internal_temp: line 166 of the table" in err
    assert fns["total_yield"]["format"] == "UINT64"
    # the scale codes are the INI's words, said
    assert "multiplier cell 'TEMP' on line 47 (and any like it) read as '0.1'" in err
    assert "200 rows read, 0 skipped; 8 functions matched, 0 unmatched" in err
    # the RW rows are writable (a setpoint and a text), the RO rows are not
    sim = sim_factory(tmp_path / "out.xml", "--registers", tmp_path / "raw.json")
    conn = ("--host", sim.host, "--port", sim.port)
    wrote = run_mdl("write", tmp_path / "out.xml", *conn, "grid_power_limit=8000", "location=Carport West")
    assert wrote.returncode == 0, wrote.stderr
    back = run_mdl("read", tmp_path / "out.xml", *conn, "grid_power_limit", "location", "--format", "json")
    assert back.returncode == 0, back.stderr
    assert json.loads(back.stdout) == {"grid_power_limit": 8000, "location": "Carport West"}
    refused = run_mdl("write", tmp_path / "out.xml", *conn, "ac_power=5")
    assert refused.returncode == 1
    assert "read-only" in refused.stderr


def test_sma_wire_addresses_without_address_base_are_a_said_guess(tmp_path):
    """SMA Sunny Tripower: SMA's register addresses (30775, 40631 ...) are wire addresses that look
    like Modicon numbers. Without `address_base`, csv2xml's documented rule (some numbers start a table:
    30059 is below 31000) reads them as Modicon numbers; that guess must be said, with the key that
    overrides it, since it shifts every address by one and moves 3xxxx to the input table."""
    ini = tmp_path / "sma_no_base.ini"
    ini.write_text((SOLAR / "sma_stp10.ini").read_text().replace("address_base       = 0\n", ""))
    proc, fns, _ = convert(tmp_path, SOLAR / "sma_stp10_modbuslist_en.html", ini)
    assert proc.returncode == 0, proc.stderr
    assert "addresses read as Modicon register numbers" in proc.stderr
    assert "set address_base = 0 in [Modbus Device] if they are wire addresses" in proc.stderr
    assert (fns["ac_power"]["addresses"], fns["ac_power"]["register_type"]) == ("774", "input")


def test_sungrow_hybrid_markdown_openwb(tmp_path, sim_factory):
    """Sungrow SH10RT hybrid inverter (and SG string inverters): openWB's German Markdown table.
    Hard: three address columns (SH over LAN, SH over WiNet-S, SG) where `--` means "not on this
    model"; the scale and the unit in one cell ("0.1 kWh", "-1 W", a bare "0.001", "ja/nein"); the
    vendor's words for formats ("UINT_32 mixed": low word first, "8-bit bitmask"); two rows with the
    same text for AC power, one of them preferred by a remark; a sign flip as a scale of -1."""
    registers = {
        "input": {
            # BAT: SoC 13022 UINT16 "0.1 %": 85.3 % is 853
            "13022": 853,
            # BAT: Zähler Gesamtladung 13026 UINT32 mixed "0.1 kWh": 12345.6 kWh is 123456 = 0x0001_E240,
            # low word first
            "13026": 0xE240,
            "13027": 0x0001,
            # Netz: Akt. Wirkleistung 13009 INT32 mixed "-1 W": the inverter reports export positive; raw
            # -2500 (0xFFFF_F63C, low word first) is 2500 W drawn from the grid in openWB's sign
            "13009": 0xF63C,
            "13010": 0xFFFF,
            # WR: Akt. DC Bruttoleistung 5016 INT_32 mixed "1 W": 8432 W
            "5016": 8432,
            "5017": 0,
            # WR: AC Ausgangsspannung Phase A 5018 UINT_16 "0.1 V": 231.4 V is 2314
            "5018": 2314,
            # Netz: Akt. Leistungsfaktor 5034 INT_16 "0.001": -0.987 is -987 = 0xFC25
            "5034": 0xFC25,
            # WR: Akt. AC Wirkleistung 13033 INT_32 mixed "1 W": 7000 W
            "13033": 7000,
            "13034": 0,
            # WR: Akt. Leistungsfluss 13000 bitmask: bit 0 PV generating, bit 2 battery discharging
            "13000": 0b101,
        }
    }
    expected = {
        "battery_soc": 85.3,
        "battery_charge_total": 12345.6,
        "grid_power": 2500,
        "dc_power": 8432,
        "phase_a_voltage": 231.4,
        "power_factor": -0.987,
        "ac_power": 7000,
        "battery_discharging": 1,
    }
    table, ini = SOLAR / "sungrow_sh_sg_openwb.md", SOLAR / "sungrow_sh_sg_openwb.ini"
    proc, fns = check_table(tmp_path, sim_factory, table, ini, registers, expected)
    err = proc.stderr
    # rows with no address in the SH_LAN column are reported, not silently dropped
    assert "sungrow_sh_sg_openwb.md:30: warning: row skipped: '--' is not an address" in err
    # ... and the readable row of the same text takes the function
    assert fns["grid_power"]["addresses"] == "13009"
    assert fns["grid_power"]["multiplier"] == "-1"
    # AC power: the row the INI chose, said at the INI's line
    assert "ac_power: line 21 of the table" in err
    assert fns["ac_power"]["addresses"] == "13033"
    # the unit-only cell of the scale-and-unit column is said
    assert "'ja/nein' on line 23" in err
    assert "30 rows read, 2 skipped; 8 functions matched, 0 unmatched" in err


def test_deye_sg04lp3_markdown_deye_inverter_mqtt(tmp_path, sim_factory):
    """Deye SUN-xK-SG04LP3 three-phase hybrid inverter: deye-inverter-mqtt's Markdown metric table.
    Hard: the address given twice (decimal and hex columns), a 32-bit counter written as a list of
    its two addresses ("534,535") with its word order only in the type cell ("U_DWORD (LW,HW)": low
    word first); Deye's own type words (U_WORD, S_WORD); signed currents and powers; a "computed"
    row that has no address at all."""
    registers = {
        "holding": {
            # Running status 500 U_WORD: 2 is "normal"
            "500": 2,
            # Total Production 534,535 U_DWORD (LW,HW) 0.1 kWh: 9876.5 kWh is 98765 = 0x0001_81CD
            "534": 0x81CD,
            "535": 0x0001,
            # Total Energy Bought 522,523 U_DWORD (LW,HW) 0.1 kWh: 70000 kWh is 700000 = 0x000A_AE60
            "522": 0xAE60,
            "523": 0x000A,
            # Total Grid Power 625 S_WORD 1 W: -3210 W (fed in) is 0xF376
            "625": 0xF376,
            # PV1 Voltage 676 U_WORD 0.1 V: 385.2 V is 3852
            "676": 3852,
            # Current L1 630 S_WORD 0.01 A: -4.56 A is -456 = 0xFE38
            "630": 0xFE38,
            # Inverter L1 Power 633 S_WORD 1 W: 2750 W
            "633": 2750,
        }
    }
    expected = {
        "running_status": 2,
        "total_production": 9876.5,
        "total_energy_bought": 70000,
        "grid_power": -3210,
        "pv1_voltage": 385.2,
        "current_l1": -4.56,
        "inverter_l1_power": 2750,
    }
    table, ini = SOLAR / "deye_sg04lp3.md", SOLAR / "deye_sg04lp3.ini"
    proc, fns = check_table(tmp_path, sim_factory, table, ini, registers, expected)
    err = proc.stderr
    # the address list gives the counter its two registers; the INI's word order is said at its line
    assert fns["total_production"]["addresses"] == "534 535"
    assert fns["total_production"]["count"] == "2"
    assert "total_production: word_order little from [function total_production]" in err
    # the "computed" row is reported with its line, not dropped in silence
    assert "deye_sg04lp3.md:36: warning: row skipped: 'computed' is not an address" in err
    assert "34 rows read, 1 skipped; 7 functions matched, 0 unmatched" in err


SOLAKON_REGISTERS = {
    "holding": {
        # Model name 39002 STR, 16 registers: "Solakon ONE", two characters a register, high byte first
        "39002": 0x536F,  # "So"
        "39003": 0x6C61,  # "la"
        "39004": 0x6B6F,  # "ko"
        "39005": 0x6E20,  # "n "
        "39006": 0x4F4E,  # "ON"
        "39007": 0x4500,  # "E", then NULs
        # PV1 voltage 39070 I16 V, Faktor 10 (divides): 38.5 V is 385
        "39070": 385,
        # Active power 39134 I32 kW, Faktor 1000: 0.65 kW is 650, high word first
        "39134": 0,
        "39135": 650,
        # Grid frequency 39139 I16 Hz, Faktor 100: 50.01 Hz is 5001
        "39139": 5001,
        # internal temperature 39141 I16 degC, Faktor 10: -3.5 degC is -35 = 0xFFDD
        "39141": 0xFFDD,
        # Cumulative power generation 39149 U32 kWh, Faktor 100: 1234.56 kWh is 123456 = 0x0001_E240
        "39149": 0x0001,
        "39150": 0xE240,
        # Battery 1 Power 39230 I32 W: -800 W (discharging) is 0xFFFF_FCE0
        "39230": 0xFFFF,
        "39231": 0xFCE0,
        # Meter collection Active power 39168 I32 W: 420 W fed in
        "39168": 0,
        "39169": 420,
    }
}


def test_solakon_one_markdown_document_table_9(tmp_path, sim_factory):
    """Solakon ONE balcony PV inverter with battery: the German Markdown transcription (ziwoas) of
    Solakon's Modbus protocol, a document of 20 tables (transport settings, code cross-references,
    alarms, grid codes ...); the measurements are its 9th (`table = 9` in the INI). Hard: a "Faktor" that divides
    (1000 for kW), em dashes for "none", bold marks around some addresses, rows that pack three
    phases into one ("39123 / 39124 / 39125", "je 1"), a range ("39072–39077") and an "I16/I32" type."""
    expected = {
        "model_name": "Solakon ONE",
        "pv1_voltage": 38.5,
        "active_power": 0.65,
        "grid_frequency": 50.01,
        "internal_temp": -3.5,
        "total_generation": 1234.56,
        "battery_power": -800,
        "meter_power": 420,
    }
    table, ini = SOLAR / "solakon_one_modbus_protokoll.md", SOLAR / "solakon_one.ini"
    proc, fns = check_table(tmp_path, sim_factory, table, ini, SOLAKON_REGISTERS, expected)
    err = proc.stderr
    assert "read table 9 (line 254): the one table = 9 in the INI names" in err
    # "Faktor 1000" divides: the multiplier is its inverse
    assert fns["active_power"]["multiplier"] == "0.001"
    # "**Battery 1 Power**": the emphasis is not part of the text
    assert fns["battery_power"]["description"] == "Battery 1 Power"
    # rows of three values (count "je 1") are reported on their lines, and the function that names
    # one of them is left unmatched rather than given another row
    assert "solakon_one_modbus_protokoll.md:277: warning: row skipped: column 7 '#Reg' count cell 'je 1'" in err
    assert "grid_voltage_r: line 277 names it (exact 1.00: 'Grid R/S/T phase voltage') but was skipped" in err
    assert "grid_voltage_r" not in fns
    assert "format cell 'I16/I32': unknown format 'I16/I32'" in err
    assert "58 rows read, 13 skipped; 8 functions matched, 1 unmatched" in err


def test_solakon_three_phases_in_one_row_are_not_one_integer(tmp_path):
    """Solakon ONE, table 2-5: "Grid R/S/T phase voltage | I16 | 39123 / 39124 / 39125 | je 1" is three
    one-register values in one row. A user who maps the count cell (`[count cells] je 1 = 1`, as
    ini-reference.md allows for every field) must not get one 48-bit integer composed of the three
    phase voltages (reads 988287081087.5 V for 230.1/230.5/229.9 V) without a word: the format (I16,
    one register) and the count (1) both disagree with the three addresses."""
    ini = tmp_path / "solakon_counts.ini"
    ini.write_text((SOLAR / "solakon_one.ini").read_text() + "\n[count cells]\nje 1 = 1\nje 2 = 2\n")
    proc, fns, _ = convert(tmp_path, SOLAR / "solakon_one_modbus_protokoll.md", ini)
    assert proc.returncode == 0, proc.stderr
    voltage = fns.get("grid_voltage_r", {})
    said = "solakon_one_modbus_protokoll.md:277: warning" in proc.stderr
    assert said and voltage.get("count") != "3", (voltage, proc.stderr)


def test_eg4_18kpv_battery_pack_xlsx(tmp_path, sim_factory):
    """EG4 18kPV-12LV (Luxpower) hybrid inverter, battery pack 1 at input registers 5000-5029: the
    Excel map DoubleDoc/EG4-18KPV-BatteryDetails publishes. Hard: an .xlsx whose only sheet has no
    header csv2xml knows as an address column ("Input Addr"); the scale only inside the unit cell
    ("0.01V", "0.1amp", "0.1DegC", a bare "ah", a number 0.01); signedness only as the word "signed" in
    a "Range" column; two values packed in one register (SOC in the low byte, SOH in the high byte,
    the second on a row with no address); a merged address cell over two rows."""
    registers = {
        "input": {
            # Design Capacity 5003 "ah": 280 Ah (the sheet's own sample, 0x118)
            "5003": 280,
            # Charge Max Ampacity 5005 "0.1amp": 200.0 A is 2000 (0x07D0)
            "5005": 2000,
            # Present Voltage 5008 "0.01V": 52.99 V is 5299 (0x14B3)
            "5008": 5299,
            # Present Current 5009 "0.1amp", signed: -3.5 A is -35 = 0xFFDD
            "5009": 0xFFDD,
            # 5010: State of Charge 86 % in the low byte, State of Health 100 % in the high byte
            "5010": 0x6456,
            # Cycles 5011: 325
            "5011": 325,
            # Max Cell Temperature 5012 "0.1DegC": 12.0 degC is 120
            "5012": 120,
            # Max Cell Voltage 5014 "0.001V": 3.313 V is 3313 (0x0CF1)
            "5014": 3313,
        }
    }
    expected = {
        "design_capacity": 280,
        "charge_max_current": 200.0,
        "present_voltage": 52.99,
        "present_current": -3.5,
        "state_of_charge": 86,
        "cycles": 325,
        "max_cell_temp": 12.0,
        "max_cell_voltage": 3.313,
    }
    table, ini = SOLAR / "eg4_18kpv_battery_reg_map.xlsx", SOLAR / "eg4_18kpv_battery.ini"
    proc, fns = check_table(tmp_path, sim_factory, table, ini, registers, expected)
    err = proc.stderr
    assert "read sheet 'Sheet1': the only one, though no header of it looks like an address column" in err
    # the merged address cells are read on both their rows, and said
    assert "covers several rows: its text is read on each of them, as is every such cell's" in err
    # a unit with no number is scale 1, said; the others carry their scale
    assert "'ah' on line 5 (a unit with no number before it" in err
    assert (fns["present_voltage"]["multiplier"], fns["present_voltage"]["units"]) == ("0.01", "V")
    assert fns["present_current"]["format"] == "INT16"
    assert "state_of_charge: bits 0-7 from [function state_of_charge]" in err
    assert "40 rows read, 0 skipped; 8 functions matched, 0 unmatched" in err


def test_eg4_merged_cell_note_names_the_first(tmp_path):
    """EG4 18kPV battery map: ten merged address cells (A12:A13 is the topmost, 5010 holding SOC and
    SOH). docs/csv2xml.md: "a merged cell over several rows is read on each of them (a note names the
    first)"; the note names Sheet1!A32:A33, the 6th from the top (and not the first in the file either)."""
    table, ini = SOLAR / "eg4_18kpv_battery_reg_map.xlsx", SOLAR / "eg4_18kpv_battery.ini"
    proc, _, _ = convert(tmp_path, table, ini)
    assert proc.returncode == 0, proc.stderr
    assert "merged cell Sheet1!A12:A13 covers several rows" in proc.stderr


def test_sungrow_units_column_carries_the_scale_without_a_multiplier_key(tmp_path):
    """Sungrow (openWB's table): the "Einheit" column holds "0.1 kWh", "-1 W", "0.1 %", "0.001" and
    once "ja/nein". ini-reference.md: "A `units` column whose cells are scales written before their
    unit (`0.01V`, `0,1A`, `1W`) with no scale column named or found is read as the multiplier too (a
    note says so)", and a unit alone in such a column is scale 1. With `units = Einheit` and no
    `multiplier` key the column must be read as the scale (or the refusal said): today the scales are
    dropped without a word (units '0.1 %', SoC 85.3 % reads 853)."""
    ini = tmp_path / "sungrow_units_only.ini"
    text = (SOLAR / "sungrow_sh_sg_openwb.ini").read_text()
    ini.write_text(text.replace("multiplier  = Einheit\n", ""))
    proc, fns, _ = convert(tmp_path, SOLAR / "sungrow_sh_sg_openwb.md", ini)
    assert proc.returncode == 0, proc.stderr
    scaled = fns["battery_soc"].get("multiplier") == "0.1" and fns["grid_power"].get("multiplier") == "-1"
    said = "Einheit" in proc.stderr and ("warning" in proc.stderr or "holds scales" in proc.stderr)
    assert scaled and said, (fns["battery_soc"], proc.stderr)
