"""Corpus, HVAC: heat pumps, ventilation units and boiler gateways, from the register tables their
vendors (or the open-source projects that drive them) publish. Each table goes through `mdl csv2xml`
with an INI written from docs/ alone; `mdl sim` serves raw registers computed by hand from the
vendor's documented encoding and `mdl read` must give the vendor's values. Sources, commits and
licences: tests/data/corpus/README.md (section "hvac")."""

from __future__ import annotations

from support.corpus import CORPUS, check_table, convert

HVAC = CORPUS / "hvac"


def test_nibe_f1155_modbusmanager_export(tmp_path, sim_factory):
    """NIBE F1155/F1255 heat pump, a NIBE ModbusManager 1.0.9 export: four title lines before the
    header, semicolons with a trailing one on every row, cp1252 (`°C`), register numbers 40004 that
    are Modicon numbers (holding register 3), a "Factor" that divides, u32/s32 values sent low word
    first, and a writable signed 32-bit "Degree Minutes"."""
    table, ini = HVAC / "nibe_f1155_f1255.csv", HVAC / "nibe_f1155_f1255.ini"
    registers = {
        "holding": {
            "3": 65451,  # 40004 BT1 outdoor: -8.5 °C is -85 (s16, factor 10)
            "12": 482,  # 40013 BT7 hot water top: 48.2 °C
            "82": 123,  # 40083 EB100-BE1 current, u32 factor 10, low word first: 12.3 A
            "83": 0,
            "939": 61036,  # 40940 degree minutes, s32 factor 10: -450.0 is -4500 = 0xFFFF_EE6C
            "940": 65535,
            "3415": 57920,  # 43416 compressor starts, s32: 123456 = 0x0001_E240
            "3416": 1,
            "3419": 4464,  # 43420 compressor hours, s32: 70000 h = 0x0001_1170
            "3420": 1,
        }
    }
    expected = {
        "outdoor_temperature": -8.5,
        "hot_water_top": 48.2,
        "be1_current": 12.3,
        "degree_minutes": -450.0,
        "compressor_starts": 123456,
        "compressor_hours": 70000,
    }
    proc, fns = check_table(tmp_path, sim_factory, table, ini, registers, expected)
    # the three guesses this export forces, each said
    assert "not UTF-8 (byte 0xb0 on line 7" in proc.stderr and "'°'" in proc.stderr
    assert "cells separated by semicolons" in proc.stderr
    assert "addresses read as Modicon register numbers" in proc.stderr
    assert fns["degree_minutes"].get("access") in (None, "read_write")  # R/W: writable
    assert fns["outdoor_temperature"]["access"] == "read"


def test_nibe_f1155_limit_columns(tmp_path):
    """NIBE F1155 ModbusManager export with its Min/Max columns left to csv2xml: NIBE writes them
    in raw units, before the factor ("Degree Minutes (32 bit)": factor 10, -30000 to 30000, that
    is -3000.0 to 3000.0 DM; "Degree Minutes (16 bit)" says so: "-32768 < x < 32767"), and 0/0
    for "no limit". csv2xml writes -30000/30000 as the function's limits (so `mdl write` accepts
    -20000 DM) and 0/0 on every read-only row, without a word."""
    ini = tmp_path / "limits.ini"
    text = (HVAC / "nibe_f1155_f1255.ini").read_text()
    ini.write_text(text.replace("minimum     =\n", "").replace("maximum     =\n", ""))
    proc, fns, _ = convert(tmp_path, HVAC / "nibe_f1155_f1255.csv", ini)
    assert proc.returncode == 0, proc.stderr
    said = [line for line in proc.stderr.splitlines() if "minimum" in line and "columns found" not in line]
    limits = (fns["degree_minutes"].get("minimum"), fns["degree_minutes"].get("maximum"))
    assert limits == ("-3000", "3000") or any("raw" in line for line in said), limits
    assert "maximum" not in fns["outdoor_temperature"] or any("0/0" in line for line in said)


def test_nibe_s1155_register_types_share_numbers(tmp_path, sim_factory):
    """NIBE S1155/S1255 heat pump (S-series), its tab-separated register list: wire addresses in the
    table the `MODBUS_INPUT_REGISTER`/`MODBUS_HOLDING_REGISTER` column names, so input 227 (a u32
    compressor hour counter) and holding 227 ("Night cooling 1", u8) are different registers; a
    "Division factor" that divides; s32 degree minutes low word first."""
    table, ini = HVAC / "nibe_s1155_s1255.tsv", HVAC / "nibe_s1155_s1255.ini"
    registers = {
        "input": {
            "1": 65451,  # Current outdoor temperature (BT1): -8.5 °C
            "8": 482,  # Hot water top (BT7): 48.2 °C
            "50": 123,  # Current (BE1), u32 /10, low word first: 12.3 A
            "51": 0,
            "227": 4464,  # Compressor, total time pool, heat pump 4 (EP15), u32: 70000 h
            "228": 1,
        },
        "holding": {
            "11": 61036,  # Degree minutes, s32 /10: -450.0
            "12": 65535,
            "104": 2,  # Ventilation mode (u8, 0-4)
            "227": 1,  # Night cooling 1 (u8, 0-1): on
        },
    }
    expected = {
        "outdoor_temperature": -8.5,
        "hot_water_top": 48.2,
        "be1_current": 12.3,
        "degree_minutes": -450.0,
        "ventilation_mode": 2,
        "night_cooling": 1,
        "pool_compressor_hours": 70000,
    }
    proc, fns = check_table(tmp_path, sim_factory, table, ini, registers, expected)
    assert "cells separated by tabs" in proc.stderr
    assert "plain addresses read as wire addresses" in proc.stderr
    assert "register_type = column 1 'Register type'" in proc.stderr
    assert fns["pool_compressor_hours"]["register_type"] == "input"
    assert fns["night_cooling"].get("register_type", "holding") == "holding"


def test_stiebel_eltron_isg_data_type_codes(tmp_path, sim_factory):
    """Stiebel Eltron WPM heat pump manager via the ISG gateway, block "system values": registers
    numbered from 1 (501 is wire address 500), input registers, and a "Data type" column of codes
    that give both the format and the scale (2: signed tenths, 7: signed hundredths, 6: unsigned),
    so one column is named as format and multiplier with `[format cells]` and `[multiplier cells]`.
    "SET TEMPERATURE HK 1" is listed twice (509 and 510); the table's own comment says 510 is the
    one the WPM answers, so the INI gives it by `row =`."""
    table, ini = HVAC / "stiebel_wpm_system_values.csv", HVAC / "stiebel_wpm_system_values.ini"
    registers = {
        "input": {
            "506": 65461,  # 507 OUTSIDE TEMPERATURE, type 2: -7.5 °C is -75
            "515": 352,  # 516 ACTUAL RETURN TEMPERATURE: 35.2 °C
            "519": 185,  # 520 HEATING PRESSURE, type 7: 1.85 bar
            "520": 1234,  # 521 FLOW RATE, type 7: 12.34 l/min
            "521": 483,  # 522 ACTUAL TEMPERATURE DHW: 48.3 °C
            "509": 325,  # 510 SET TEMPERATURE HK 1: 32.5 °C
        }
    }
    expected = {
        "outside_temperature": -7.5,
        "return_temperature": 35.2,
        "dhw_temperature": 48.3,
        "heating_pressure": 1.85,
        "flow_rate": 12.34,
        "hk1_set_temperature": 32.5,
    }
    proc, fns = check_table(tmp_path, sim_factory, table, ini, registers, expected)
    assert "format cell '2' on line 2 (and any like it) read as 'INT16'" in proc.stderr
    assert "multiplier cell '7' on line 21 (and any like it) read as '0.01'" in proc.stderr
    assert fns["hk1_set_temperature"]["addresses"] == "509"
    # the ISG's limits are in the value's own units (OUTSIDE TEMPERATURE -60 to 80 °C)
    assert (fns["outside_temperature"]["minimum"], fns["outside_temperature"]["maximum"]) == ("-60", "80")


def test_stiebel_eltron_duplicate_row_is_said(tmp_path):
    """Stiebel Eltron WPM (ISG): without `row =`, "SET TEMPERATURE HK 1" scores 1.0 on lines 10 and
    11 alike. csv2xml takes line 10 (wire 508, which a WPM answers "not available") and says
    nothing; a tie between two exact rows is a guess, and every guess must be said."""
    ini = tmp_path / "no_row.ini"
    text = (HVAC / "stiebel_wpm_system_values.ini").read_text()
    head = text.split("[function hk1_set_temperature]")[0]  # the INI without its `row = 11`
    ini.write_text(head + "[Function Name Search Synonyms]\nhk1_set_temperature = SET TEMPERATURE HK 1\n")
    proc, fns, _ = convert(tmp_path, HVAC / "stiebel_wpm_system_values.csv", ini)
    assert proc.returncode == 0, proc.stderr
    said = [line for line in proc.stderr.splitlines() if "hk1_set_temperature" in line]
    assert any("11" in line for line in said), proc.stderr  # the other exact row is named


def test_ectocontrol_boiler_adapter_markdown(tmp_path, sim_factory):
    """Ectocontrol OpenTherm Modbus Adapter v2 (a gas-boiler gateway), the Markdown protocol
    reference of the ecto_modbus_devs project: twenty pipe tables in one page (the register list is
    Appendix A, `--table 19`), hexadecimal addresses, scales written `÷10`, `÷256` and `×10`
    (stored ten times larger), and an outdoor temperature that is the signed upper byte of its
    register (`i8 MSB`)."""
    table, ini = HVAC / "ectocontrol_opentherm_v2.md", HVAC / "ectocontrol_opentherm_v2.ini"
    registers = {
        "holding": {
            "24": 291,  # 0x0018 CH Temperature, i16 ÷10: 29.1 °C
            "25": 425,  # 0x0019 DHW Temperature, u16 ÷10: 42.5 °C
            "32": 0xF812,  # 0x0020 Outdoor Temp, i8 MSB: 0xF8 is -8 °C (the page's own example)
            "38": 11520,  # 0x0026 CH Setpoint Active, i16 ÷256: 45.0 °C
            "30": 40,  # 0x001E Main Error, u16
        }
    }
    expected = {
        "ch_temperature": 29.1,
        "dhw_temperature": 42.5,
        "outdoor_temperature": -8,
        "ch_setpoint_active": 45.0,
        "main_error": 40,
    }
    proc, fns = check_table(tmp_path, sim_factory, table, ini, registers, expected, "--table", "19")
    assert "read table 19 (line 929)" in proc.stderr
    assert "a Markdown table" in proc.stderr
    # Appendix A's plain `u8` rows do not say which byte: said on each row, not guessed
    assert "md:950: warning: column 2 'Type' length cell 'u8'" in proc.stderr
    assert "multiplier cell '×10' on line 948 (and any like it) read as '0.1'" in proc.stderr
    # 0x0031 CH Setpoint is write-only ("WO"): not read back, but stored ten times larger
    assert fns["ch_setpoint"]["addresses"] == "49"
    assert fns["ch_setpoint"]["multiplier"] == "0.1"
    assert fns["ch_setpoint"]["access"] == "write"


def test_ectocontrol_format_cells_without_a_format_column(tmp_path):
    """Ectocontrol OpenTherm Adapter v2: a user who names the "Type" column as `length` (its cells
    say which byte: `i8 MSB`) and forgets `format = Type` loses the header-guessed format column
    (a guess never takes a column the INI assigns), so every `[format cells]` mapping applies to
    nothing and "CH Temperature" (`i16`) becomes UINT16: -15.0 °C would read 6538.6. The INI's
    own section says what the user meant; csv2xml should say it went unused."""
    ini = tmp_path / "no_format.ini"
    ini.write_text((HVAC / "ectocontrol_opentherm_v2.ini").read_text().replace("format = Type\n", ""))
    proc, fns, _ = convert(tmp_path, HVAC / "ectocontrol_opentherm_v2.md", ini, "--table", "19")
    assert proc.returncode == 0, proc.stderr
    assert fns["ch_temperature"]["format"] == "UINT16"  # what it becomes
    assert "[format cells]" in proc.stderr  # ... and must not become silently


def test_enervent_eair_md_workbook(tmp_path, sim_factory):
    """Enervent eAir MD ventilation-unit controller, Enervent's public Excel register list: eleven
    lines of prose before the header, a second header row before the coils, addresses written
    `hreg 6` and `coil 1` (holding register 6, coil 1), a "Multiplier" that is how much the value
    was multiplied by before it was stored (so it divides), `bitfield` and `enumeration` types."""
    table, ini = HVAC / "enervent_eair_md.xlsx", HVAC / "enervent_eair_md.ini"
    registers = {
        "holding": {
            "6": 65411,  # hreg 6 Fresh air, int16, multiplier 10: -12.5 °C is -125
            "13": 45,  # hreg 13 Exhaust air humidity, %RH
            "44": 0x0010,  # hreg 44 HREG_MODE, bitfield: bit 4 = away
            "46": 217,  # hreg 46 Room temperature average: 21.7 °C
            "135": 195,  # hreg 135 Supply air setpoint: 19.5 °C
            "599": 114,  # hreg 599 MD SW version, multiplier 100: 1.14
        },
        "coil": {"1": 1},  # coil 1 Away mode
    }
    expected = {
        "fresh_air_temperature": -12.5,
        "extract_humidity": 45,
        "unit_status": 16,
        "room_temperature": 21.7,
        "supply_air_setpoint": 19.5,
        "software_version": 1.14,
        "away_mode": True,
    }
    check_table(tmp_path, sim_factory, table, ini, registers, expected)
