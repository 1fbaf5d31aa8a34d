"""The PDF reader's own steps on rows as pdfplumber gives them (readers/pdf.py): pages as users write
them, a header over several rows made one, a row whose address comes from a cell merged over it joined
to the row above, and columns taken from the narrowest cells with text."""

from __future__ import annotations

import pytest

from mdl.formats.table.readers.pdf import page_range
from mdl.formats.table.readers.pdf_tables import _banded, _columns, _continued


@pytest.mark.parametrize(
    ("spec", "pages"),
    [("3", [3]), ("7-9", [7, 8, 9]), ("3,5-7", [3, 5, 6, 7]), (" 2 , 2-3 ", [2, 3]), ("9-40", [9, 10])],
)
def test_pages_as_users_write_them(spec, pages):
    assert page_range(spec, 10, "--pages") == pages  # a range past the end stops at the last page


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("x", "'x' is not a page or a range of pages"),
        ("0", "pages count from 1"),
        ("5-3", "the first before the last"),
        ("11", "the document has 10 pages"),
        ("1;2", "'1;2' is not a page"),
    ],
)
def test_pages_that_are_not_pages_are_refused(spec, message):
    with pytest.raises(ValueError, match=message):
        page_range(spec, 10, "--pages")


def test_a_header_over_several_rows_is_one_header():
    rows = [
        ["Register", "Resolu-", "Name"],
        ["Address", "tion", "Name"],
        ["4000h", "0.1", "Voltage"],
    ]
    banded, has_header = _banded(rows)
    assert has_header and banded == [["Register Address", "Resolution", "Name"], ["4000h", "0.1", "Voltage"]]
    assert _banded([["0001", "Voltage"]]) == ([["0001", "Voltage"]], False)  # data from the first row


def test_a_row_whose_address_is_merged_from_above_is_the_rest_of_the_row_above():
    rows = [
        [("3200", False), ("Battery status", False), ("D3-D0: 01H Overvolt", False)],
        [("3200", True), ("Battery status", True), ("02H Under Volt", False)],
        [("3201", False), ("Charging status", False), ("", False)],
    ]
    joined, spread = _continued(rows)
    assert joined == [
        ["3200", "Battery status", "D3-D0: 01H Overvolt 02H Under Volt"],
        ["3201", "Charging status", ""],
    ]
    assert spread == 0
    label = [[("0010", False), ("Block A", False)], [("0011", False), ("Block A", True)]]
    assert _continued(label) == ([["0010", "Block A"], ["0011", "Block A"]], 1)  # a block label: read on each row


def test_columns_come_from_the_narrowest_cells_with_text():
    """A header cell over two columns does not merge them; cells in slivers go to the column over them."""
    grid = [
        [((0, 0, 100, 10), "Register Address", False), ((100, 0, 150, 10), "Unit", False)],
        [((0, 10, 40, 20), "0001", False), ((40, 10, 100, 20), "Voltage", False), ((100, 10, 150, 20), "V", False)],
    ]
    assert _columns(grid) == [
        [("", False), ("Register Address", False), ("Unit", False)],
        [("0001", False), ("Voltage", False), ("V", False)],
    ]


def test_messages_name_a_pdf_row_by_its_place():
    """csv2xml's Report names a PDF table's rows by page and row: the diagnostic's place and the lines its
    message names; a line that is no row of the table, and other files, keep their numbers."""
    from mdl.diagnostics import Diagnostic
    from mdl.formats.table.report import Report

    report = Report(printing=False)
    report.located("m.pdf", {12: "p3:r4", 13: "p3:r5"})
    placed = report.placed(Diagnostic("m.pdf", 12, None, "lines 12 and 13 match it alike; `row = 13` takes line 13"))
    assert str(placed) == "m.pdf:p3:r4: error: p3:r4 and p3:r5 match it alike; `row = p3:r5` takes p3:r5"
    assert str(report.placed(Diagnostic("m.pdf", 99, 2, "line 99"))) == "m.pdf:99:2: error: line 99"
    assert report.placed(Diagnostic("d.ini", 12, None, "line 12")).file == "d.ini"
    assert report.row_name(13) == "p3:r5" and report.row_name(7) == "line 7"


def test_bits_under_an_address_merged_over_their_rows_stay_rows_of_their_own():
    """A register's bits, one a row, under one address cell: the address is read on each (the review's
    t3.pdf read four bits as one function)."""
    rows = [
        [("0x0010", False), ("Bit 0", False), ("Fan fault", False), ("BOOL", False)],
        [("0x0010", True), ("Bit 1", False), ("Pump fault", False), ("BOOL", False)],
    ]
    assert _continued(rows) == (
        [["0x0010", "Bit 0", "Fan fault", "BOOL"], ["0x0010", "Bit 1", "Pump fault", "BOOL"]],
        1,
    )


@pytest.mark.parametrize("cell", ["0x0103.b8", "40001.3", "hr:101", "4000h", "5017～5018", "30101 (100)"])
def test_rows_of_any_address_csv2xml_reads_are_data_not_header(cell):
    """A table whose first rows are bit addresses: they are rows, not a header over four rows."""
    banded, has_header = _banded([["Address", "Name"], [cell, "Fan"], ["0x0104", "Pump"]])
    assert has_header and banded == [["Address", "Name"], [cell, "Fan"], ["0x0104", "Pump"]]
