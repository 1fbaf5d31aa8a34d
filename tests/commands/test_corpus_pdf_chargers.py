"""Corpus: EV chargers' register tables inside their vendors' PDF manuals (issue 36, SPEC 4.2), as in
test_corpus_pdf.py: each manual converted with the INI a user wrote from docs/ alone, served by `mdl sim`
with raw registers worked out by hand from the manual's own text, read back with `mdl read`
(tests/support/corpus.py). Sources, licences and what was read: tests/data/corpus/README.md ("pdf").

Raw values, by hand from the manuals' words:
- MENNEKES (page 2: "Register Word order: LowWord / HighWord", "Big Endian HighByte / LowByte"): a float
  is IEEE 754 single, its low 16 bits at the first address. 230.5 = 1.80078125 x 2^7 = 0x43668000, so
  0x8000 (32768) then 0x4366 (17254); 16.0 = 0x41800000: 0, 16768; -5.5 = -1.375 x 2^2 = 0xC0B00000: 0,
  49328; 1234.5 = 1.2055664 x 2^10 = 0x449A5000: 0x5000 (20480), 0x449A (17562). A uint32 alike:
  70000 = 0x0001_1170: 4464, 1. ASCII "1.5.0": '1' '.' = 0x312E (12590), '5' '.' = 0x352E (13614), '0'
  NUL = 0x3000 (12288), NULs after.
- Heidelberg: "1 = 0.1 Arms" (160 is 16.0 A), "325 = +32.5 °C / -145 = -14.5 °C" in an int16 (-145 is
  65536 - 145 = 65391), "238 = 238 Vrms", "[High byte]" "1 --> 2^16 VAh" (printed 216, the exponent's
  superscript lost) and "[Low byte]" "1000 --> 1000VAh" (1 and 1000 are 65536 + 1000 = 66536 VAh),
  "10000 = 10 sec." of a timeout "in ms", "100 = 10A"."""

from __future__ import annotations

import pytest

from support.corpus import CORPUS, check_table, convert

PDF = CORPUS / "pdf"

pytest.importorskip("pdfplumber")


def words(first: int, *values: int) -> dict[str, int]:
    return {str(first + i): v for i, v in enumerate(values)}


MENNEKES = PDF / "mennekes_amtron_compact.ini"


def test_mennekes_amtron_compact(tmp_path, sim_factory):
    """MENNEKES AMTRON Compact 2.0s Modbus RTU specification 1.2: the register map is one table per
    section (pages 2-8), each under the same header and some going on over the next page without it
    (Temperature's header at the foot of page 5, its row on page 6; Statistic's header on page 7, its
    rows on page 8), so each section is converted on its own; hex address ranges broken over two lines
    (`0x0506 -` / `0x0507`), sizes in bytes, floats and a uint32 low word first, a 16-byte ASCII text,
    units only in the Range column."""
    sections = [
        # (what csv2xml is told, raw holding registers, expected)
        ((), {**words(1, 12590, 13614, 12288, 0, 0, 0, 0, 0)}, {"firmware_version": "1.5.0"}),  # p2, 0x0001-0x0008
        (("--pages", "5"), words(0x0506, 32768, 17254), {"voltage_l1": 230.5}),  # Output Measurements
        (("--pages", "5-6", "--table", "3"), words(0x0900, 0, 49328), {"temperature": -5.5}),  # header p5, row p6
        (("--pages", "7-8", "--table", "3"), words(0x1000, 20480, 17562), {"energy_total": 1234.5}),  # p7-8
    ]
    for n, (args, holding, expected) in enumerate(sections):
        where = tmp_path / str(n)
        where.mkdir()
        proc, fns = check_table(where, sim_factory, MENNEKES, None, {"holding": holding}, expected, *args)
        assert "Traceback" not in proc.stderr
        if n == 0:
            assert fns["firmware_version"]["format"] == "STRING" and fns["firmware_version"]["count"] == "8"
        if n == 1:
            assert fns["voltage_l1"]["format"] == "FLOAT32" and fns["voltage_l1"]["word_order"] == "little"
            assert fns["voltage_l1"]["addresses"] == "1286 1287"
        if n == 2:
            assert "read table 3 (pp5-6)" in proc.stderr  # the header on page 5, its one row on page 6
        if n == 3:
            assert "read table 3 (pp7-8)" in proc.stderr


def test_mennekes_amtron_compact_headers_broken_without_a_hyphen(tmp_path, sim_factory):
    """MENNEKES pages 4, 6 and 7 print their header's `Bytes` as `Byte` / `s` (and page 6 `Range` as `Rang` /
    `e`) in a column too narrow for the word, and page 7's `Type` cell overlaps another that holds the same
    characters: each header must read as the one on the other pages, or `count = Bytes` finds no column
    there. Configuration (p4: a float the energy manager writes) and Charging Session (p6: a uint32 low word
    first, named with the manual's typo `Duration Seession`).
    Read otherwise, page 4 and page 6 convert the wrong table (`count = Bytes: no such column`, or the
    next table whose header holds it)."""
    sections = [
        (("--pages", "4-5"), words(0x0302, 0, 16768), {"current_limit": 16.0}),  # R/W, "6…xA"
        (("--pages", "6"), words(0x0B04, 4464, 1), {"session_duration": 70000}),  # 19 h 26 min 40 s
    ]
    for n, (args, holding, expected) in enumerate(sections):
        where = tmp_path / str(n)
        where.mkdir()
        proc, fns = check_table(where, sim_factory, MENNEKES, None, {"holding": holding}, expected, *args)
        assert "Traceback" not in proc.stderr
    assert fns["session_duration"]["format"] == "UINT32" and fns["session_duration"]["word_order"] == "little"
    # every section's header now holds the INI's column names (Version, Status, ... Statistic: nine)
    proc, _, _ = convert(tmp_path, MENNEKES, None)
    assert "read table 1 (pp2-3): the first whose header holds the INI's column names (8 more hold them)" in (
        proc.stderr
    )


def test_mennekes_a_row_wrapped_over_a_page_break_ends_on_the_next_page(tmp_path):
    """MENNEKES page 3's last row (0x0108 CP-State) wraps its description over the page break, and only that
    cell goes on at the top of page 4 (`charge) 28 = C2 (charging) 29 = D2`): it ends the row, not a table of
    one column of its own (which cut the description and counted as table 3 of the document)."""
    proc, fns, xml = convert(tmp_path, MENNEKES, None, "--pages", "3-4", "--all")
    assert proc.returncode == 0, proc.stderr
    assert "read table 2 (pp3-4)" in proc.stderr
    assert "27 = B2 (EVSE ready to charge) 28 = C2 (charging) 29 = D2" in xml.read_text()


def test_heidelberg_wallbox_energy_control(tmp_path, sim_factory):
    """Heidelberg (Amperfied) Wallbox Energy Control register table: an Excel sheet printed onto one
    portrait page (/Rotate 270) on which the table stands sideways. Read as the /Rotate turns it, every
    row comes out a column and every cell's text reversed ('.rdA-suB' for 'Bus-Adr.'); read the way its
    text runs, it is the vendor's table. Input and holding registers told by a
    `ModBus-Function` column in words (`04 - readInputRegister`, mapped in the INI), scales only in
    the examples (`1 = 0.1 Arms`), an int16 temperature, and a 32-bit energy in two rows, "[High byte]"
    and "[Low byte]" (words, high first).
    The page is read the way its text runs (readers/pdf_layout.py), whatever its /Rotate says."""
    registers = {
        "input": {
            **words(5, 7),  # Charging State 7 (C2: "Vehicle plugged with charging request", "Wallbox allows charging")
            **words(6, 160),  # L1 - Current RMS 16.0 A ("1 = 0.1 Arms")
            **words(9, 65391),  # PCB-Temperatur -14.5 °C (int16 -145, "-145 = -14.5 °C")
            **words(10, 230),  # Voltage L1 - N 230 V ("238 = 238 Vrms")
            **words(15, 1, 1000),  # Energy since PowerOn [High byte], [Low byte]: 65536 + 1000 VAh
        },
        "holding": {
            **words(257, 10000),  # ModBus-Master WatchDog Timeout in ms ("10000 = 10 sec.")
            **words(261, 100),  # Maximal current command 10 A ("100 = 10A")
        },
    }
    expected = {
        "charging_state": 7,
        "current_l1": 16.0,
        "pcb_temperature": -14.5,
        "voltage_l1": 230,
        "energy_since_power_on": 66536,
        "watchdog_timeout": 10000,
        "max_current": 10.0,
    }
    ini = PDF / "heidelberg_wallbox_energy_control.ini"
    proc, fns = check_table(tmp_path, sim_factory, ini, None, registers, expected)
    assert "read table 1 (p1)" in proc.stderr
    assert fns["pcb_temperature"]["format"] == "INT16"
    assert fns["energy_since_power_on"]["format"] == "UINT32" and "word_order" not in fns["energy_since_power_on"]
    assert fns["current_l1"]["register_type"] == "input" and fns["max_current"].get("register_type", "holding") == (
        "holding"
    )
    # the rows the sheet packs (102 … 133: 32 registers of char[2] in one cell) are said, not guessed
    assert "p1:r19: warning: row skipped" in proc.stderr
    assert "Traceback" not in proc.stderr
