"""Corpus: register tables inside vendors' PDF manuals (issue 36, SPEC 4.2). Each manual is converted
with the INI a user wrote from docs/ alone, served by `mdl sim` with raw registers worked out by hand
from the manual's own text, and read back with `mdl read` (tests/support/corpus.py). Sources, licences
and what was read: tests/data/corpus/README.md (section "pdf")."""

from __future__ import annotations

import pytest

from support.corpus import CORPUS, check_table, convert
from support.run import assert_clean_error, cli

PDF = CORPUS / "pdf"

pytest.importorskip("pdfplumber")


def words(first: int, *values: int) -> dict[str, int]:
    return {str(first + i): v for i, v in enumerate(values)}


def test_sungrow_hybrid_inverter(tmp_path, sim_factory):
    """Sungrow SH hybrid inverter protocol V1.1.15: the input-register table runs over pages 6-12 (6-7 read) with
    its header repeated on each page, pdfplumber splits each column in three, names wrap over two
    lines, ranges are written `5017～5018` (full-width tilde) and `5214-5215`, the scale stands before
    the unit (`0.01Hz`), the printed numbers count from 1 and 32-bit values come low word first."""
    registers = {
        "input": {
            **words(5241, 5002),  # Grid Frequency 50.02 Hz (0.01Hz; printed 5242)
            **words(5034, 65036),  # Power factor -0.5 (S16, 0.001)
            **words(5018, 2305),  # A-B line voltage/phase A voltage 230.5 V (a name over two lines)
            **words(5016, 4464, 1),  # Total DC power 70000 W (U32, low word first: 0x0001_1170)
            **words(5213, 63036, 65535),  # Battery power -2500 W (S32, low word first)
        }
    }
    expected = {
        "grid_frequency": 50.02,
        "power_factor": -0.5,
        "phase_a_voltage": 230.5,
        "total_dc_power": 70000,
        "battery_power": -2500,
    }
    proc, fns = check_table(tmp_path, sim_factory, PDF / "sungrow_sh_hybrid.ini", None, registers, expected)
    assert "read table 1 (pp6-7)" in proc.stderr  # the header repeated on page 7 is dropped
    assert fns["total_dc_power"]["format"] == "UINT32" and fns["total_dc_power"]["word_order"] == "little"
    # every row is named by its page and row; the row the INI chose by its place is said
    assert "sungrow_sh_hybrid_protocol_v1.1.15.pdf:p6:r2: warning: row skipped" not in proc.stderr  # ~ is read
    assert "grid_frequency: p7:r26 of the table, as [function grid_frequency] row says" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_abb_terra_ac_charger(tmp_path, sim_factory):
    """ABB Terra AC wallbox Modbus v1.7: one table on page 6 with its header over two rows (`Register` /
    `Address`, `Resolu-` / `tion`), hex addresses with an h suffix (4016h), sizes in registers and a
    data type that gives no width (`Unsigned`): a 2-register row is a UINT32, said in a note."""
    registers = {
        "holding": {
            **words(16406, 0, 2305),  # Voltage L1 230.5 V (0.1)
            **words(16400, 0, 16000),  # Charging Current L1 16 A (0.001)
            **words(16412, 1, 34464),  # Active Power 100000 W
            **words(16416, 60),  # Communication timeout 60 s
            **words(16640, 0, 10000),  # Set Charging Current Limit 10 A (0.001)
        }
    }
    expected = {
        "voltage_l1": 230.5,
        "current_l1": 16.0,
        "active_power": 100000,
        "communication_timeout": 60,
        "current_limit": 10.0,
    }
    proc, fns = check_table(tmp_path, sim_factory, PDF / "abb_terra_ac.ini", None, registers, expected)
    assert fns["voltage_l1"]["format"] == "UINT32"
    assert "says no width and the row is 4 registers: read as UINT64" in proc.stderr  # the serial number


def test_pace_bms(tmp_path, sim_factory):
    """PACE BMS protocol V1.3: a table over pages 7-9 whose page 9 starts with the end of a row wrapped
    over the page break, access and type in one cell (`RW/UINT16`, mapped in [format cells]), scales
    before units (`10mA`, `25uS`), and the version string rescued by `[function version] format =
    STRING 10` (its 10-register range disagrees with the type cell)."""
    registers = {
        "holding": {
            **words(0, 65036),  # Current -5000 mA (10mA; charging positive)
            **words(1, 5321),  # Voltage of pack 53210 mV (10mV)
            **words(2, 87),  # SOC 87 %
            **words(63, 20),  # Pack OV protection delay time 2 s (0.1S)
            **words(111, 8),  # Short circuit protect delay time 200 us (25uS)
            **words(150, 20529, 13907, 12592, 12353),  # Version information 'P16S100A'
        }
    }
    expected = {
        "current": -5000,
        "pack_voltage": 53210,
        "soc": 87,
        "ov_delay": 2.0,
        "short_circuit_delay": 200,
        "version": "P16S100A",
    }
    proc, _ = check_table(tmp_path, sim_factory, PDF / "pace_bms.ini", None, registers, expected)
    assert "read table 3 (pp7-9): the first whose header holds the INI's column names" in proc.stderr
    assert "version: p9:r28 read with format STRING 10 from [function version]" in proc.stderr
    assert "no row matched version" not in proc.stderr


def test_noark_ex9em_meter(tmp_path, sim_factory):
    """NOARK Ex9EM energy meter: a printed spreadsheet, three tables side by side on one page (the INI's
    columns choose), a header cell with rotated text, lower-case bare hex addresses (002b) and scales
    only in prose (each given in its [function] section)."""
    registers = {
        "holding": {
            **words(0, 2335),  # Voltage 233.5 V ("devide by 10")
            **words(1, 123),  # Current 12.3 A
            **words(3, 1500),  # Active power 1500 W
            **words(7, 0, 1234),  # Active energy 12.34 kWh (2 registers, high word first)
            **words(43, 100),  # Meter ID (002b) 100
        }
    }
    expected = {"voltage": 233.5, "current": 12.3, "active_power": 1500, "active_energy": 12.34, "meter_id": 100}
    proc, fns = check_table(tmp_path, sim_factory, PDF / "noark_ex9em.ini", None, registers, expected)
    assert fns["meter_id"]["addresses"] == "43"
    assert "read table 1 (p1): the first whose header holds the INI's column names" in proc.stderr


def test_epever_tracer_charge_controller(tmp_path, sim_factory):
    """EPEver Tracer protocol V2.3: bare hex addresses (3100), a Times column (stored 100 times larger)
    and a unit column with the degree-Celsius sign (U+2103)."""
    registers = {"input": {**words(0x3100, 3456), **words(0x3101, 250), **words(0x3110, 2550)}}
    expected = {"pv_voltage": 34.56, "pv_current": 2.5, "battery_temperature": 25.5}
    _, fns = check_table(tmp_path, sim_factory, PDF / "epever_tracer.ini", None, registers, expected)
    assert fns["battery_temperature"]["units"] == "\u2103"


# --- what cannot be read is said -------------------------------------------------------------------


def test_a_scanned_manual_is_an_error_naming_its_pages(tmp_path):
    """A PDF whose pages are images (a scan) has no text to read: exit 1, the pages named, nothing written."""
    scanned = PDF / "hdhk_16ch_ac_module_scanned.pdf"
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", scanned, "-o", out)
    assert_clean_error(proc, 1, f"{scanned}: error: pages 1-3 hold no text (a scanned manual?)", "OCR")
    assert not out.exists()


def test_a_file_that_is_not_a_pdf_is_an_error(tmp_path):
    fake = tmp_path / "manual.pdf"
    fake.write_bytes(b"register,description\n0,Voltage\n")
    proc = cli("csv2xml", fake, "-o", tmp_path / "out.xml")
    assert_clean_error(proc, 1, f"{fake}: error: not a PDF")


def test_pages_out_of_the_manual_and_pages_of_a_csv_are_errors(tmp_path):
    proc, _, _ = convert(tmp_path, PDF / "pace_bms_modbus_v1.3.pdf", None, "--pages", "40-41")
    assert_clean_error(proc, 1, "--pages 40-41: the document has 12 pages")
    proc, _, _ = convert(tmp_path, PDF / "pace_bms_modbus_v1.3.pdf", None, "--pages", "x")
    assert_clean_error(proc, 1, "--pages x: 'x' is not a page or a range of pages")
    table = tmp_path / "t.csv"
    table.write_text("Address,Name\n0,Voltage\n")
    proc, _, _ = convert(tmp_path, table, None, "--pages", "3", "--all")
    assert_clean_error(proc, 1, "--pages 3 chooses pages of a PDF manual; t.csv has no pages")


def test_row_places_name_the_rows_of_a_pdf_only(tmp_path):
    """`row = p14:r7` in [function NAME] names a PDF table's row; on a CSV it is an error at its INI line."""
    table = tmp_path / "t.csv"
    table.write_text("Address,Name\n0,Voltage\n1,Current\n")
    ini = tmp_path / "t.ini"
    ini.write_text("[Input/Output]\naddress_map_csv_file = t.csv\n\n[function voltage]\nrow = p1:r2\n")
    proc = cli("csv2xml", ini, "-o", tmp_path / "out.xml")
    assert_clean_error(proc, 1, "row = p1:r2: only a PDF table's rows are named so")


def test_explain_names_a_pdf_row_by_its_place(tmp_path):
    """--explain on a PDF names rows as every message does (`p7:r11`), never by a hidden line number."""
    proc = cli("csv2xml", PDF / "pace_bms.ini", "--explain", "soc", "-q")
    assert proc.returncode == 0, proc.stderr
    assert "  chosen: p7:r11 (score 1.00)" in proc.stdout
    assert " line " not in proc.stdout.split("\n", 1)[1].split("on the description cell")[0]
