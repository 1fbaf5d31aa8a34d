"""Corpus: more vendors' PDF manuals (issue 36, SPEC 4.2), as tests/commands/test_corpus_pdf.py reads them:
each manual converted with the INI a user wrote from docs/ alone, served by `mdl sim` with raw registers
worked out by hand from the manual's own text, and read back with `mdl read` (tests/support/corpus.py).
Sources, licences and what was read: tests/data/corpus/README.md (section "pdf")."""

from __future__ import annotations

import pytest

from support.corpus import CORPUS, check_table, convert

PDF = CORPUS / "pdf"

pytest.importorskip("pdfplumber")


def words(first: int, *values: int) -> dict[str, int]:
    return {str(first + i): v for i, v in enumerate(values)}


def test_lambda_heat_pump(tmp_path, sim_factory):
    """Lambda EU-L heat pump "Modbus Beschreibung und Protokoll" (German prose, English tables): one table per
    module over pages 10-13, each with its header, the third the heat pump's; an address is printed as
    three columns (Index + Subindex + Number: "1 1 04 = 1104"), so each function's address is given in
    its section and the Number column only picks the row; scales in brackets before the unit
    (`[0.01°C]`, `[0.1kW]`), `[0.1K]` (a K after a number is refused as a thousand: mapped), signed
    INT16 temperatures, and an INT32 whose two registers are two drawn rows under one name."""
    registers = {
        "holding": {
            **words(1004, 3550),  # T-flow 35.50 °C ([0.01°C])
            **words(1007, 64986),  # T-EQin -5.50 °C (INT16: 65536 - 550)
            **words(1010, 7550),  # Compressor-Rating 75.50 % (UINT16, [0.01%])
            **words(1011, 85),  # Qp heating 8.5 kW ([0.1kW])
            **words(1016, 450),  # Request flow line temp 45.0 °C (RW, [0.1°C])
            **words(1018, 50),  # Request heat sink temp. diff 5.0 K ([0.1K])
            # Statistic VdA E since last reset, INT32 on Numbers 20 and 21: 1 * 65536 + 1 Wh. The manual
            # does not say which word comes first; [1, 1] is the same value either way.
            **words(1020, 1, 1),
        }
    }
    expected = {
        "flow_temperature": 35.5,
        "source_inlet_temperature": -5.5,
        "compressor_rating": 75.5,
        "heating_capacity": 8.5,
        "flow_temperature_request": 45.0,
        "sink_temperature_difference": 5.0,
        "electrical_energy": 65537,
    }
    proc, fns = check_table(tmp_path, sim_factory, PDF / "lambda_heatpump.ini", None, registers, expected)
    assert "read table 3 (p11): the one table = 3 in the INI names" in proc.stderr
    assert fns["flow_temperature"]["units"] == "\u00b0C" and fns["heating_capacity"]["units"] == "kW"
    assert fns["electrical_energy"]["format"] == "INT32"
    assert "electrical_energy: addresses 1020 from [function electrical_energy] instead of the table's '20 21'" in (
        proc.stderr
    )
    assert ": warning:" not in proc.stderr, proc.stderr


def test_senseair_s8_input_registers(tmp_path, sim_factory):
    """Senseair S8 "Modbus on S8" TDE2067, Table 2 (input registers): two address columns (IR4, the
    register number, and 3, the address), bit-field rows drawn as a grid of sixteen DI cells (read as
    two rows, the first taken), no type, scale or unit column (ppm only in the worked example), and
    page 6 drawn without header or grid, read as a table of its own (--table 2); its names carry
    footnote marks, set small above the line: read `Sensor ID High^5`, the name its words."""
    ini = PDF / "senseair_s8.ini"
    registers = {
        "input": {
            **words(0, 33),  # MeterStatus 0x0021: DI 1 (bit 0) and DI 6 "Out Of Range" (bit 5) set
            **words(3, 400),  # Space CO2 400 ppm (page 13: reply 01 90, "400 ppm = 0x190")
        }
    }
    proc, fns = check_table(
        tmp_path, sim_factory, ini, None, registers, {"co2": 400, "out_of_range": 1}, "--table", "1"
    )
    assert "read table 1 (pp4-5)" in proc.stderr
    assert fns["co2"]["addresses"] == "3" and fns["out_of_range"]["bits"] == "5"
    # Sensor ID High / Low (IR30 + IR31, High first): 0x0001_86A0 = 100000
    registers = {"input": words(29, 1, 34464)}
    (tmp_path / "p6").mkdir()
    proc, fns = check_table(
        tmp_path / "p6", sim_factory, ini, None, registers, {"serial_number": 100000}, "--table", "2"
    )
    assert "read table 2 (p6)" in proc.stderr
    assert "similarity only" not in proc.stderr  # 'Sensor ID High^5' holds the phrase 'Sensor ID High'
    assert fns["serial_number"]["addresses"] == "29"


def test_senseair_s8_holding_registers(tmp_path, sim_factory):
    """Senseair S8 Table 3 (holding registers): page 6 holds HR1-HR4 under the header, page 7 HR5-HR32
    without it (table 3 as read); the acknowledgement register is a grid of CI bits whose name wraps
    inside its cell without a hyphen ('Acknowled gement register': matched by similarity); ABC Period
    is in hours (page 16: 0x00B4 = 180 hours, 7.5 days)."""
    ini = PDF / "senseair_s8_holding.ini"
    proc, fns = check_table(tmp_path, sim_factory, ini, None, {"holding": words(31, 180)}, {"abc_period": 180})
    assert "read table 3 (p7)" in proc.stderr and fns["abc_period"]["units"] == "h"
    (tmp_path / "p6").mkdir()
    registers = {"holding": words(0, 32)}  # HR1 0x0020 (page 15's reply: CI6, bit 5, set)
    proc, _ = check_table(
        tmp_path / "p6", sim_factory, ini, None, registers, {"background_calibrated": 1}, "--table", "2"
    )
    assert "--table 2 is read instead of the INI's table = 3" in proc.stderr


# A footnote mark is set small above the line (the '5' of 'Sensor ID High⁵' is 6.5 pt, its word 9.96 pt, its
# bottom 5.7 pt above the word's). Run into the word ('Sensor ID High5'), the synonym was no phrase of the
# cell, and the function's own name 'sensor id' took 'Sensor ID Low5': address 30, with no warning.
def test_senseair_s8_footnote_marks_are_not_part_of_names(tmp_path):
    """A name with a footnote mark (`Sensor ID High⁵`) is its words: `sensor_id = Sensor ID High` takes
    IR30 (address 29), not the row that its function's own name finds first."""
    ini = tmp_path / "s8.ini"
    pdf = PDF / "senseair_s8_modbus.pdf"
    ini.write_text(
        f"[Modbus Device]\nregister_type = input\n\n[Input/Output]\naddress_map_csv_file = {pdf}\n"
        "pages = 4-6\ntable = 2\n\n[Column/Field Indices]\naddresses = 1\ndescription = 2\n\n"
        "[Function Name Search Synonyms]\nsensor_id = Sensor ID High\n"
    )
    proc, fns, _ = convert(tmp_path, ini, None)
    assert proc.returncode == 0, proc.stderr
    assert fns["sensor_id"]["addresses"] == "29", proc.stderr  # IR30, "Sensor ID High"
