"""Hostile vendor documents for `mdl csv2xml` (issue 34): a few kilobytes of workbook, HTML or
Markdown must not take gigabytes or minutes. Each runs as a user would, capped at 1 GB of address
space and 20 s (as tests/hostile/test_limits.py does), and ends with its MDL or a clear error naming the
limit, never a traceback: the workbook's merges, cells, unzipped size and parts are measured before
openpyxl reads them; the page readers are linear (tests/fuzz/test_fuzz_table_growth.py measures it)."""

from __future__ import annotations

import io
import struct
import zipfile
from pathlib import Path

import openpyxl
import pytest

from mdl.formats.table.readers.delimited import MAX_CELL_CHARS
from mdl.formats.table.readers.document import MAX_CELLS, MAX_PAGE_BYTES
from mdl.formats.table.readers.xlsx import MAX_ELEMENTS, MAX_UNZIPPED
from support.capped import run_capped
from support.run import assert_clean_error

INI = "[Function Name Search Synonyms]\nroom_temperature = room temperature\n"
HEAD = "| Register | Description |\n|---|---|\n| 16 | Room temperature |\n"
PAGE = "<table><tr><th>Register<th>Description<tr><td>16<td>Room temperature</table>\n"


def convert(tmp_path: Path, source: Path):
    ini = tmp_path / "map.ini"
    ini.write_text(INI)
    return run_capped("csv2xml", source, "--ini", ini)


def workbook(tmp_path: Path, edit=lambda name, data: data) -> Path:
    """A register table as openpyxl writes it, each part of the zip passed through `edit`."""
    book = openpyxl.Workbook()
    book.active.title = "Map"
    book.active.append(["Register", "Description"])
    book.active.append([16, "Room temperature"])
    buffer = io.BytesIO()
    book.save(buffer)
    path = tmp_path / "map.xlsx"
    with zipfile.ZipFile(buffer) as source, zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as out:
        for info in source.infolist():
            out.writestr(info.filename, edit(info.filename, source.read(info)))
    return path


def sheet(rows: str = "", after: str = ""):
    """An edit of the sheet's part: `rows` at the end of its rows, `after` after them (merges)."""

    def edit(name: str, data: bytes) -> bytes:
        if name != "xl/worksheets/sheet1.xml":
            return data
        return data.replace(b"</sheetData>", f"{rows}</sheetData>{after}".encode())

    return edit


def merge(ref: str):
    return sheet(after=f'<mergeCells count="1"><mergeCell ref="{ref}"/></mergeCells>')


# -- workbooks: limits before the memory is spent ------------------------------------------------------
def test_the_workbook_as_written_converts(tmp_path):
    proc = convert(tmp_path, workbook(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert "<name>room_temperature</name>" in proc.stdout


@pytest.mark.parametrize("ref", ["A1:XFD1048576", "B2:B1048576", "A3:ZZ2000"])
def test_a_merge_over_the_sheet_is_refused_before_it_is_laid_out(tmp_path, ref):
    path = workbook(tmp_path, merge(ref))
    assert path.stat().st_size < 10_000
    proc = convert(tmp_path, path)
    assert_clean_error(proc, 1, f"{path}: error: the merged cells of sheet 'Map' cover more than {MAX_CELLS:,} cells")


def test_a_merge_over_many_rows_counts_them_with_the_cells(tmp_path):
    path = workbook(tmp_path, merge("C2:C600000"))
    proc = convert(tmp_path, path)
    assert_clean_error(proc, 1, f"{path}: error: sheet 'Map' spans 3 columns by 600,000 rows, more than {MAX_CELLS:,}")


def _rows(rows: int, columns: int) -> str:
    """Rows of number cells as compact as a sheet may write them (no `r`: each follows the last)."""
    return ("<row>" + "<c><v>1</v></c>" * columns + "</row>") * rows


def test_millions_of_cells_in_a_small_file_are_refused_without_loading_them(tmp_path):
    path = workbook(tmp_path, sheet(_rows(3 * MAX_CELLS // 4, 4)))  # 3 million cells, openpyxl's 1.2 GB
    assert path.stat().st_size < 500_000
    proc = convert(tmp_path, path)
    rows = MAX_CELLS // 4 + 1  # the row that passes the limit, after the two openpyxl wrote
    assert_clean_error(proc, 1, f"{path}: error: sheet 'Map' spans 4 columns by {rows:,} rows, more than {MAX_CELLS:,}")


def test_one_far_cell_makes_the_extent(tmp_path):
    path = workbook(tmp_path, sheet('<row r="700000"><c r="XFD700000"><v>1</v></c></row>'))
    proc = convert(tmp_path, path)
    assert_clean_error(proc, 1, "sheet 'Map' spans 16,384 columns by 700,000 rows")
    path = workbook(tmp_path, sheet('<row r="9999999"><c><v>1</v></c></row>'))
    assert_clean_error(convert(tmp_path, path), 1, "sheet 'Map': row 9,999,999, past Excel's 1,048,576 rows")


def test_a_dimension_claiming_the_whole_sheet_is_not_believed(tmp_path):
    def edit(name: str, data: bytes) -> bytes:
        if name != "xl/worksheets/sheet1.xml":
            return data
        start = data.index(b"<dimension")
        return data[:start] + b'<dimension ref="A1:XFD1048576"/>' + data[data.index(b"/>", start) + 2 :]

    proc = convert(tmp_path, workbook(tmp_path, edit))
    assert proc.returncode == 0, proc.stderr


def test_the_unzipped_size_is_bounded_as_declared(tmp_path):
    path = workbook(tmp_path)
    data = bytearray(path.read_bytes())
    entry = data.index(b"PK\x01\x02")  # the central directory's first entry: its declared size at +24
    data[entry + 24 : entry + 28] = struct.pack("<I", MAX_UNZIPPED + 1)
    path.write_bytes(bytes(data))
    assert_clean_error(
        convert(tmp_path, path), 1, f"{path}: error: the workbook unzips to ", f"more than the {MAX_UNZIPPED:,}"
    )


def test_parts_read_whole_are_bounded(tmp_path):
    def styles(name: str, data: bytes) -> bytes:
        return (
            data.replace(b"</styleSheet>", b"<x/>" * (MAX_ELEMENTS + 1) + b"</styleSheet>")
            if name == "xl/styles.xml"
            else data
        )

    path = workbook(tmp_path, styles)
    assert_clean_error(
        convert(tmp_path, path), 1, f"the workbook's part xl/styles.xml holds more than {MAX_ELEMENTS:,}"
    )


def test_a_pivot_cache_openpyxl_never_reads_is_no_reason_to_refuse(tmp_path):
    """A register workbook with a pivot table over a large data set: its cache holds every row, but
    read-only openpyxl never parses it, so it does not count against the parts read whole."""
    records = b"".join(b'<r><n v="%d"/></r>' % i for i in range(MAX_ELEMENTS))
    cache = (
        b'<?xml version="1.0" encoding="UTF-8"?><pivotCacheRecords '
        b'xmlns="http://schemas.openxmlformats.org/spreadsheetml/2006/main">' + records + b"</pivotCacheRecords>"
    )
    path = workbook(tmp_path)
    with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED) as book:
        book.writestr("xl/pivotCache/pivotCacheRecords1.xml", cache)
    proc = convert(tmp_path, path)
    assert proc.returncode == 0, proc.stderr
    assert "<name>room_temperature</name>" in proc.stdout


def test_entities_are_refused(tmp_path):
    bomb = b'<?xml version="1.0"?><!DOCTYPE s [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;">]>'

    def styles(name: str, data: bytes) -> bytes:
        if name != "xl/styles.xml":
            return data
        return bomb + (data.split(b"?>", 1)[1] if data.startswith(b"<?xml") else data)

    path = workbook(tmp_path, styles)
    assert_clean_error(convert(tmp_path, path), 1, f"{path}: error: a part of the workbook declares the XML entity 'a'")


def test_a_long_workbook_cell_is_refused_at_its_cell(tmp_path):
    def strings(name: str, data: bytes) -> bytes:  # openpyxl writes no more than Excel's 32,767 characters
        return data.replace(b"Room temperature", b"x" * (MAX_CELL_CHARS + 1)) if name.startswith("xl/") else data

    path = workbook(tmp_path, strings)
    assert_clean_error(convert(tmp_path, path), 1, f"{path}:2:2: error: a cell of {MAX_CELL_CHARS + 1:,} characters")


# -- pages: linear readers, bounded cells and pages ----------------------------------------------------
PATTERNS = [
    ("map.md", HEAD + "| 17 | " + "**a " * 16000 + "|\n"),
    ("map.md", HEAD + "| 17 | " + "[" * 60000 + "|\n"),
    ("map.md", HEAD + "| 17 | " + "`" * 30000 + "a" * 30000 + "|\n"),
    ("map.html", PAGE + "<a " * 30000),
    ("map.html", PAGE + '<td a="' * 20000),
    ("map.html", PAGE + "<!-- x >" * 20000),
    ("map.html", PAGE.replace("</table>", "<tr><td>17" + "<td " + 'a="x" ' * 20000 + ">y</table>")),
]


@pytest.mark.parametrize("name, text", PATTERNS, ids=[f"{n}-{t[-12:]!r}" for n, t in PATTERNS])
def test_patterns_that_were_quadratic_convert(tmp_path, name, text):
    source = tmp_path / name
    source.write_text(text)
    proc = convert(tmp_path, source)
    assert proc.returncode == 0, proc.stderr
    assert "<name>room_temperature</name>" in proc.stdout


def test_a_rowspan_layout_is_linear(tmp_path):
    rows, columns = 300, 250  # the layout was rows x columns^2: minutes
    source = tmp_path / "map.html"
    source.write_text(
        PAGE.replace("</table>", "<tr><td>17" + f"<td rowspan={rows}>x<td>z" * columns)
        + "".join(f"<tr><td>{18 + k}" for k in range(rows - 1))
        + "</table>"
    )
    proc = convert(tmp_path, source)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize(
    "name, text, where",
    [
        ("map.md", HEAD + "| 17 | " + "**word** " * 14000 + "|\n", ":4:7: error: a cell of 69,999 "),
        ("map.md", HEAD + "|  1\\|2 | " + "x" * (MAX_CELL_CHARS + 1) + "|\n", ":4:10: error: a cell of 65,537 "),
        ("map.html", PAGE + "<table><tr>\n  <td>" + "x " * 40000 + "</table>", ":3:3: error: a cell of 79,999 "),
    ],
)
def test_a_long_cell_is_refused_where_it_starts(tmp_path, name, text, where):
    source = tmp_path / name
    source.write_text(text)
    assert_clean_error(convert(tmp_path, source), 1, f"{source}{where}", f"the limit is {MAX_CELL_CHARS:,}")


@pytest.mark.parametrize("name", ["map.html", "map.md"])
def test_a_page_larger_than_the_bound_is_refused(tmp_path, name):
    source = tmp_path / name
    with source.open("w") as f:
        f.write(PAGE if name.endswith(".html") else HEAD)
        f.truncate(MAX_PAGE_BYTES + 1)
    assert_clean_error(convert(tmp_path, source), 1, f"{source}: error: larger than {MAX_PAGE_BYTES:,} bytes")
