"""readers/ods.py on content.xml as LibreOffice writes it: repeats of empty cells and rows cost nothing,
repeats of a cell with text are read, a cell over several rows is read on each of them."""

from __future__ import annotations

import zipfile

from mdl.formats.table.readers.ods import read_ods

HEAD = (
    '<?xml version="1.0"?><office:document-content xmlns:office="urn:oasis:names:tc:opendocument:xmlns:office:1.0" '
    'xmlns:table="urn:oasis:names:tc:opendocument:xmlns:table:1.0" '
    'xmlns:text="urn:oasis:names:tc:opendocument:xmlns:text:1.0"><office:body><office:spreadsheet>'
)
TAIL = "</office:spreadsheet></office:body></office:document-content>"


def ods(tmp_path, body: str):
    path = tmp_path / "t.ods"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("content.xml", HEAD + body + TAIL)
    return read_ods(path)


def cell(text: str, extra: str = "") -> str:
    return f"<table:table-cell {extra}><text:p>{text}</text:p></table:table-cell>"


def test_repeats_of_empty_cells_and_rows_cost_nothing_and_numbers_read_as_shown(tmp_path):
    row = (
        "<table:table-row>"
        + '<table:table-cell table:number-columns-repeated="2"/>'
        + cell("7", 'office:value-type="float" office:value="7.0"')
        + '<table:table-cell table:number-columns-repeated="16000"/></table:table-row>'
    )
    empty = '<table:table-row table:number-rows-repeated="1048570"><table:table-cell/></table:table-row>'
    (sheet,) = ods(tmp_path, f'<table:table table:name="Map">{row}{empty}{row}</table:table>')
    assert sheet.name == "Map"
    assert sheet.rows == [(1, ["", "", "7"]), (1048572, ["", "", "7"])]


def test_a_cell_over_several_rows_is_read_on_each(tmp_path):
    body = (
        '<table:table table:name="R"><table:table-row>'
        + cell("Block A", 'table:number-rows-spanned="2"')
        + cell("0010")
        + "</table:table-row><table:table-row><table:covered-table-cell/>"
        + cell("0011")
        + "</table:table-row></table:table>"
    )
    (sheet,) = ods(tmp_path, body)
    assert sheet.rows == [(1, ["Block A", "0010"]), (2, ["Block A", "0011"])]
    assert sheet.merged == ["A1:A2"]


def test_empty_padding_and_spans_count_against_the_limit(tmp_path):
    """The review's bombs: a text cell after 16,000 empty columns in a row repeated a million times, and
    one spanning a billion rows: refused by the count, never made."""
    import pytest

    from mdl.diagnostics import MdlError

    wide = '<table:table-cell table:number-columns-repeated="16000"/>'
    rows = f'<table:table-row table:number-rows-repeated="999990">{wide}{cell("7")}</table:table-row>'
    span = f"<table:table-row>{wide}{cell('7', 'table:number-rows-spanned=' + chr(34) + '999999999' + chr(34))}"
    for body in (rows, span + "</table:table-row>"):
        with pytest.raises(MdlError, match="more than 1,000,000 cells"):
            ods(tmp_path, f'<table:table table:name="B">{body}</table:table>')
