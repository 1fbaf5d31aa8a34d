"""Corpus: inverters' register tables inside their vendors' PDF manuals (issue 36, SPEC 4.2), as in
test_corpus_pdf.py: each manual converted with the INI a user wrote from docs/ alone, served by `mdl sim`
with raw registers worked out by hand from the manual's own text, read back with `mdl read`
(tests/support/corpus.py). Sources, licences and what was read: tests/data/corpus/README.md ("pdf").

Raw values, by hand from the manuals' words:
- Growatt (page 5: "16bits (two bytes) unsigned integer for each holding and input register"; a 32-bit
  value is two rows, "(high)" at the first address, "(low)" at the next): 10000.0 W in 0.1W is 100000 =
  0x0001_86A0, so 1 then 34464; 100000 s in 0.5s is 200000 = 0x0003_0D40: 3, 3392; -1500.0 in 0.1 of an
  Int32 is -15000 = 0xFFFF_C568: 65535, 50536; 50.02 Hz in 0.01Hz is 5002; 45.2 in 0.1C is 452; 150.0 V
  in 0.1V is 1500; the serial number "AB12345678", "Serial number 1-2" at 23: 'A' 'B' = 0x4142 (16706),
  '1' '2' = 0x3132 (12594), 0x3334 (13108), 0x3536 (13622), 0x3738 (14136).
- SolaX (page 20: "32bit data use little endian format", "0x46:LSB,0x47:MSB"): -12.5 A in 0.1A is -125,
  65536 - 125 = 65411; 49.98 Hz in 0.01Hz is 4998; -5 in 1℃ (int16) is 65531; feed-in -1500 W ("Negative
  mean consumed power", int32) is 0xFFFF_FA24: 0xFA24 (64036) at 0x46, 0xFFFF at 0x47; 12345.6 kWh in
  0.1kWh is 123456 = 0x0001_E240: 57920 at 0x52, 1 at 0x53; 264.5 V in 0.1V is 2645. The serial number
  is "14Chars, MSB=SN[14]", which does not say which character a register's high byte holds: the value
  served, HH33XX55XX33HH, reads the same whichever way (each register holds one character twice, and
  the registers read backwards are the same registers).
- SRNE (page 9: "If the magnification is 0.1, the actual value is the register value multiplied by 0.1";
  page 8: 32-bit data "in small-endian mode", 0x12345678 at 0x0001/0x0002 is 0x5678 then 0x1234): 48.5 V
  is 485 (the manual's own example); a charging current of 50.0 A ("less than 0 indicates charging",
  Signed) is -500: 65036; 49.98 Hz in 0.01 is 4998; -5.0 °C in 0.1 (Signed) is -50: 65486; -1000 W
  drawn from the grid ("Less than 0 for power of grid consumption", Signed) is 64536; 230.0 V in 0.1 is
  2300; 123456.7 kWh in 0.1 is 1234567 = 0x0012_D687: 0xD687 (54919) at F032, 0x0012 (18) at F033."""

from __future__ import annotations

import pytest

from support.corpus import CORPUS, check_table

PDF = CORPUS / "pdf"

pytest.importorskip("pdfplumber")


def words(first: int, *values: int) -> dict[str, int]:
    return {str(first + i): v for i, v in enumerate(values)}


def test_growatt_pv_inverter(tmp_path, sim_factory):
    """Growatt Modbus RTU protocol v1.24 (85 pages, pages 47-55 and 9-11 read): the input table numbers
    its rows `35.` (a numbered list's dot), starts under the holding table's end on page 47 with a group
    row (`First group`) under its header, goes on over the pages with its Value column empty on some
    (page 48: one column fewer), has no types but an `Int32` in that Value column, and gives 32-bit
    values as a `(high)` and a `(low)` row; scales stand before the unit, one of them 0.5s. The holding
    table's header wraps words mid-word in narrow cells (`Registe` / `rNO.`), the serial number is five
    ASCII rows. The page draws no space between words (a WPS export): pdfminer's text ran them together
    (`Outputpower(high)`, `PacH`), pdfium's generated spaces give them as printed (`Pac H`).

    Read otherwise: `35.` is no address (every input row skipped and each page's first rows taken for a
    header), page 48 (one column fewer) a table of its own, `First group` part of the Value header, and
    `Register NO.` no column (printed `Registe rNO.`)."""
    registers = {
        "input": {
            **words(35, 1, 34464),  # Pac H / Pac L: output power 10000.0 W (0.1W, high word first)
            **words(37, 5002),  # Fac: grid frequency 50.02 Hz (0.01Hz)
            **words(57, 3, 3392),  # Time total H / L: work time 100000 s (0.5s)
            **words(93, 452),  # Temp1: inverter temperature 45.2 (0.1C)
            **words(232, 65535, 50536),  # ReActPowerH / L: -1500.0 (Int32, 0.1W)
        }
    }
    expected = {
        "output_power": 10000.0,
        "grid_frequency": 50.02,
        "work_time_total": 100000.0,
        "inverter_temperature": 45.2,
        "reactive_power": -1500.0,
    }
    proc, fns = check_table(tmp_path, sim_factory, PDF / "growatt_inverter.ini", None, registers, expected)
    assert "read table 2 (pp47-55): the first whose header holds the INI's column names" in proc.stderr
    assert fns["output_power"]["addresses"] == "35" and fns["output_power"]["format"] == "UINT32"
    assert fns["reactive_power"]["format"] == "INT32" and fns["work_time_total"]["multiplier"] == "0.5"
    assert "matched by similarity only" not in proc.stderr  # `Pac H` as printed, not `PacH`
    assert "Traceback" not in proc.stderr

    holding = tmp_path / "holding"
    holding.mkdir()
    registers = {"holding": {**words(17, 1500), **words(23, 16706, 12594, 13108, 13622, 14136)}}
    expected = {"pv_start_voltage": 150.0, "serial_number": "AB12345678"}
    proc, fns = check_table(holding, sim_factory, PDF / "growatt_inverter_holding.ini", None, registers, expected)
    assert "read table 1 (pp9-11)" in proc.stderr
    assert fns["serial_number"]["format"] == "STRING" and fns["serial_number"]["count"] == "5"
    assert "units" not in fns["serial_number"]  # its Unit cell says ASCII: [units cells] ASCII = (none)


def test_solax_hybrid_g4_inverter(tmp_path, sim_factory):
    """SolaX X1/X3 Hybrid G4 Modbus TCP/RTU V3.21 (52 pages; 20-22 and 8 read): a table per function
    code, each under a title drawn across it (`Read Input Register`) over a header of three rows with the
    vendor's spelling (`Decription`, `Lenth`); the function code stands in a cell merged down the table
    whose text is on the first page only, so page 21 draws one column fewer; 32-bit values little endian
    over two address rows whose other cells are merged (one row listing both: pdf.py _next_register);
    the serial number's type cell says uint16 over seven registers (`[function inverter_sn] format =
    STRING 7`) and its Unit cell `14Char` would be a scale of 14 (`[multiplier cells] 14Char =`).

    Read otherwise: the header `Read Input Register Decription` (`description = Decription` no column),
    and pages 21-22 a table of their own without header (feedin_power and Etotal_togrid not found)."""
    registers = {
        "input": {
            **words(0x0001, 65411),  # GridCurrent(X1) -12.5 A (int16, 0.1A)
            **words(0x0007, 4998),  # GridFrequency(X1) 49.98 Hz
            **words(0x0008, 65531),  # Temperature -5 ℃ (int16, 1℃)
            **words(0x0046, 64036, 65535),  # feedin_power -1500 W (int32, LSB first)
            **words(0x0052, 57920, 1),  # Etotal_togrid 12345.6 kWh (uint32, LSB first)
        }
    }
    expected = {
        "grid_current": -12.5,
        "grid_frequency": 49.98,
        "radiator_temperature": -5,
        "feedin_power": -1500,
        "energy_to_grid_total": 12345.6,
    }
    proc, fns = check_table(tmp_path, sim_factory, PDF / "solax_hybrid_g4.ini", None, registers, expected)
    assert "read table 2 (pp20-22): the first whose header holds the INI's column names" in proc.stderr
    assert fns["feedin_power"]["format"] == "INT32" and fns["feedin_power"]["word_order"] == "little"
    assert fns["feedin_power"]["addresses"] == "70 71"  # 0x0046 / 0x0047: one value over two address rows
    assert fns["energy_to_grid_total"]["addresses"] == "82 83"
    assert fns["radiator_temperature"]["units"] == "\u2103"
    assert "Traceback" not in proc.stderr

    holding = tmp_path / "holding"
    holding.mkdir()
    sn = [0x4848, 0x3333, 0x5858, 0x3535, 0x5858, 0x3333, 0x4848]  # HH 33 XX 55 XX 33 HH
    registers = {"holding": {**words(0x0000, *sn), **words(0x001A, 2645)}}
    expected = {"inverter_sn": "HH33XX55XX33HH", "grid_voltage_max": 264.5}
    proc, fns = check_table(holding, sim_factory, PDF / "solax_hybrid_g4_holding.ini", None, registers, expected)
    assert "inverter_sn: p8:r3 read with format STRING 7 from [function inverter_sn]" in proc.stderr
    assert fns["inverter_sn"]["addresses"] == "0 1 2 3 4 5 6" and "multiplier" not in fns["inverter_sn"]
    assert fns["inverter_sn"].get("register_type") is None  # holding: the row's function code cell says 0X03


def test_srne_solar_charge_inverter(tmp_path, sim_factory):
    """SRNE MODBUS protocol for energy storage inverters V1.96 (18 pages; the register table on pages 9-14):
    a table drawn without rules, every other row on a shaded band and section titles (`P01 DC Data
    Area`) on dark bands across it; bare hexadecimal addresses (101, 23A, E208); header words broken
    mid-word in narrow cells (`Magnif` / `ication`, `Signed/Unsign` / `ed`); Signed/Unsigned with a Length
    for the width; a 32-bit value low word first, said only in prose on page 8; the unit of one row is
    the vendor's slip (`A` for a power whose display format is `%dW`).

    Read otherwise: only the shaded rows are found, each a table of one row (0x220 and 0x23A, on white
    rows, lost without a word, and the table read the header alone), and `Magnification` and
    `Signed/Unsigned` no columns as printed."""
    registers = {
        "holding": {
            **words(0x101, 485),  # BatVolt 48.5 V (0.1)
            **words(0x102, 65036),  # ChargeCurr -50.0 A (Signed, 0.1): charging
            **words(0x215, 4998),  # GridFreq 49.98 Hz (0.01)
            **words(0x220, 65486),  # Tempera -5.0 °C (Signed, 0.1): a white row
            **words(0x23A, 64536),  # GridActivePowerA -1000 (Signed, 1): a white row
            **words(0xE208, 2300),  # OutputVoltSet 230.0 V (0.1, RW)
            **words(0xF032, 54919, 18),  # GridEnergyTotal 123456.7 kWh (Length 2, 0.1, low word first)
        }
    }
    expected = {
        "battery_voltage": 48.5,
        "battery_current": -50.0,
        "grid_frequency": 49.98,
        "fin_temperature": -5.0,
        "grid_power_a": -1000,
        "output_voltage_setting": 230.0,
        "grid_energy_total": 123456.7,
    }
    proc, fns = check_table(tmp_path, sim_factory, PDF / "srne_inverter.ini", None, registers, expected)
    assert "read table 1 (pp9-14): the only one" in proc.stderr  # one table, not one per shaded band
    assert fns["grid_energy_total"]["format"] == "UINT32" and fns["grid_energy_total"]["word_order"] == "little"
    assert fns["fin_temperature"]["format"] == "INT16" and fns["fin_temperature"]["addresses"] == "544"
    assert fns["grid_power_a"]["units"] == "A"  # as printed (its display format says %dW)
    assert fns["output_voltage_setting"]["addresses"] == "57864" and "access" not in fns["output_voltage_setting"]
    assert "Traceback" not in proc.stderr
