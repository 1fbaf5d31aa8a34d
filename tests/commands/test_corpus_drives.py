"""Corpus: a variable-frequency drive's register list as its vendor publishes it, an Excel 97-2003 workbook
(issue 36: .xls through xlrd). Converted with the INI a user wrote from docs/ alone, served by `mdl sim` with
raw registers worked out by hand from the workbook's own cells, and read back with `mdl read`. Source and
licence: tests/data/corpus/README.md (section "drives")."""

from __future__ import annotations

import pytest

from support.corpus import CORPUS, check_table
from support.run import cli

DRIVES = CORPUS / "drives"

pytest.importorskip("xlrd")


def words(first: int, *values: int) -> dict[str, int]:
    return {str(first + i): v for i, v in enumerate(values)}


def test_schneider_altivar_12(tmp_path, sim_factory):
    """Schneider Electric ATV12 "Communication parameters" BBV51917 (the vendor's .xls, sheet Parameters):
    logic addresses as IEC 61131 numbers with their decimal (`16#2136 = 08502`: the two must agree), types
    as `INT (Signed16)` / `UINT (Unsigned16)` / `WORD (BitString16)`, the scale before the unit in the
    Units column (`0.1 Hz`), and the status word's cell naming one address per drive profile (`16#219B =
    8603 (speed)` over `16#0C81 = 3201 (frequency)`): skipped with a warning that says so, and rescued by
    `[function status_word] addresses = 8603`."""
    registers = {
        "holding": {
            **words(8502, 500),  # LFR Frequency setpoint 50.0 Hz (INT, 0.1 Hz)
            **words(3202, 65036),  # RFR Estimated motor frequency -50.0 Hz (INT (Signed16), 0.1 Hz)
            **words(3204, 25),  # LCR Estimated motor current 2.5 A (UINT, 0.1 A)
            **words(3209, 87),  # THD Drive thermal state 87 % (1 %)
            **words(8603, 0x0637),  # ETA Status word (WORD: bits as they come)
        }
    }
    expected = {
        "frequency_setpoint": 50.0,
        "output_frequency": -50.0,
        "motor_current": 2.5,
        "drive_thermal_state": 87,
        "status_word": 0x0637,
    }
    proc, fns = check_table(tmp_path, sim_factory, DRIVES / "schneider_atv12.ini", None, registers, expected)
    assert fns["output_frequency"]["format"] == "INT16" and fns["frequency_setpoint"]["addresses"] == "8502"
    assert "names 2 addresses, one for each of 'speed', 'frequency': one register is meant" in proc.stderr


def test_iec_addresses_that_disagree_with_their_decimal_are_refused(tmp_path):
    """`16#2136 = 08503` says two addresses: the row is skipped with a warning naming both, never read as either."""
    table = tmp_path / "t.csv"
    rows = ["Logic address,Name,Type", "16#2136 = 08503,Frequency setpoint,INT (Signed16)", "16#0C84,Current,UINT"]
    table.write_text("\n".join(rows) + "\n")
    proc = cli("csv2xml", table, "--all", "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr
    assert "16#2136 is 8502, not 8503" in proc.stderr
    assert "<addresses>3204</addresses>" in (tmp_path / "out.xml").read_text()
