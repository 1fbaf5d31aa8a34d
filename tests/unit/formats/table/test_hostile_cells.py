"""Oversized cells and fields (issue 34, findings 3 and 4): a CSV cell past MAX_CELL_CHARS is refused where
it starts (also past the csv module's own limit of 131,072), an INI line past it too (a 10.5 MB
device_description reached the XML self-check, which died in lxml), and no message repeats a whole
oversized cell or WISE field: it says a prefix and the length. Every case runs through the CLI; how time
grows with such cells is tests/fuzz/test_fuzz_cell_growth.py's."""

from __future__ import annotations

import shutil

import pytest

from mdl.formats.table.readers.delimited import MAX_CELL_CHARS
from support.common import DATA, ROOT
from support.run import assert_clean_error, cli

HEADER = "Modbus Address,Parameter,Data Type,Units\n30001,Phase 1 voltage,Float,V\n"
SEED = ROOT / "examples" / "wise_4012e" / "Modbus.ini"


def table(tmp_path, text: str):
    csv = tmp_path / "t.csv"
    csv.write_text(text)
    shutil.copy(DATA / "meter.ini", tmp_path / "t.ini")
    return csv, tmp_path / "t.ini"


@pytest.mark.parametrize(
    "cell, length",
    [
        ("d" * (MAX_CELL_CHARS + 1), MAX_CELL_CHARS + 1),  # the csv module reads it: refused by mdl's bound
        ('"' + "d\n" * 100_000 + '"', 200_000),  # past the csv module's own limit, over quoted line breaks
        ("d" * 10_500_000, 10_500_000),  # finding 4's size
    ],
    ids=["over-bound", "over-csv-limit", "10.5MB"],
)
def test_csv_cell_over_the_bound_is_refused_where_it_starts(tmp_path, cell, length):
    csv, ini = table(tmp_path, HEADER + "30003,Phase 2 voltage,Float,V\n30005,Thing," + cell + ",V\n")
    proc = cli("csv2xml", csv, "--ini", ini, "-o", tmp_path / "out.xml")
    assert_clean_error(proc, 1, f"t.csv:4:13: error: a cell of {length:,} characters: the limit is {MAX_CELL_CHARS:,}")
    assert not (tmp_path / "out.xml").exists()
    assert len(proc.stderr) < 500


def test_csv_cell_at_the_bound_is_read(tmp_path):
    csv, ini = table(tmp_path, HEADER + '30003,"Phase 2 voltage ' + "d" * (MAX_CELL_CHARS - 16) + '",Float,V\n')
    proc = cli("csv2xml", csv, "--ini", ini, "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr


def test_ini_line_of_ten_megabytes_is_refused_before_it_reaches_the_xml(tmp_path):
    csv, ini = table(tmp_path, HEADER)
    ini.write_text(ini.read_text().replace("Three-phase power meter", "d" * 10_500_000))
    proc = cli("csv2xml", csv, "--ini", ini, "-o", tmp_path / "out.xml")
    line = f"device_description = {'d' * 10_500_000}"
    assert_clean_error(proc, 1, f"t.ini:3: error: a line of {len(line):,} characters: the limit is {MAX_CELL_CHARS:,}")
    assert not (tmp_path / "out.xml").exists()


def test_csv_warning_says_a_prefix_of_a_long_cell(tmp_path):
    csv, ini = table(tmp_path, HEADER + "30003,Phase 2 voltage," + "(" * 20_000 + ",V\n")
    proc = cli("csv2xml", csv, "--ini", ini, "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr
    assert f"format cell '{'(' * 40}...' (20,000 characters)" in proc.stderr, proc.stderr
    assert len(proc.stderr) < 5000


def test_csv_address_error_says_a_prefix_of_a_long_cell(tmp_path):
    csv, ini = table(tmp_path, HEADER + "1" + " " * 20_000 + "x,Phase 2 voltage,Float,V\n")
    proc = cli("csv2xml", csv, "--ini", ini, "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr
    assert "'1 x' is not an address" in proc.stderr, proc.stderr
    assert len(proc.stderr) < 5000


def test_wise_min_of_thirty_thousand_digits_is_said_by_a_prefix(tmp_path):
    ini = tmp_path / "Modbus.ini"
    ini.write_text(SEED.read_text().replace("AI1=1, Voltage1, 0, 5,", "AI1=1, Voltage1, " + "1" * 30_000 + "x, 5,"))
    proc = cli("import", ini, "-o", tmp_path / "out.xml")
    assert_clean_error(
        proc, 1, f"Modbus.ini:25:18: error: AI1: min must be a number, not '{'1' * 40}...' (30,001 characters)"
    )
    assert len(proc.stderr) < 500
