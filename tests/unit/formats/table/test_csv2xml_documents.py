"""csv2xml on tables as vendors publish them (SPEC 4.1): Markdown pipe tables, HTML tables and Excel
workbooks give the MDL their CSV gives; the table or sheet with an address column is the one read
(--table / --sheet choose another, and a note says which); cells read as the page shows them; errors
name the file and where."""

from __future__ import annotations

import csv
import html
import json
import shutil
import zipfile
from pathlib import Path

import pytest

from support.common import DATA, ROOT  # noqa: E402
from support.run import assert_clean_error, run_mdl

TEMCO = ROOT / "examples" / "temco_tstat"
INI = TEMCO / "temco_tstat.ini"

openpyxl = pytest.importorskip("openpyxl")


def temco_rows() -> list[list[str]]:
    with open(TEMCO / "temco_tstat.csv", encoding="utf-8", newline="") as f:
        return list(csv.reader(f))


def header_at(rows: list[list[str]]) -> int:
    return next(i for i, r in enumerate(rows) if r[0] == "Register")


def md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", "<br>")


def to_markdown(rows: list[list[str]]) -> str:
    """The register list as a README shows it: the title as prose, a table of revisions (no address
    column) first, then the register table with emphasis and code marks that are not part of the text."""
    h = header_at(rows)
    out = [f"# {rows[0][0]}", "", rows[1][0], "", "| Revision | Date |", "|---|---|", "| 1 | 2024 |", ""]
    table = rows[h:]
    out.append("| " + " | ".join(f"**{md_cell(c)}**" for c in table[0]) + " |")
    out.append("|" + "|".join(":---" for _ in table[0]) + "|")
    for r in table[1:]:
        cells = [md_cell(c) for c in r]
        cells[0] = f"`{cells[0]}`" if cells[0] else ""
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def to_html(rows: list[list[str]]) -> str:
    h = header_at(rows)

    def cell(tag: str, text: str) -> str:
        return f"<{tag}>" + "<br>".join(f"<span>{html.escape(part)}</span>" for part in text.split("\n")) + f"</{tag}>"

    body = "\n".join("  <tr>" + "".join(cell("td", c) for c in r) + "</tr>" for r in rows[h + 1 :])
    return (
        f"<!DOCTYPE html>\n<html><head><title>x</title><style>td {{ color: red }}</style></head><body>\n"
        f"<h1>{html.escape(rows[0][0])}</h1>\n<table><tr><th>Revision</th><th>Date</th></tr>"
        "<tr><td>1</td><td>2024</td></tr></table>\n"
        "<table class='regs'>\n  <thead><tr>" + "".join(cell("th", c) for c in rows[h]) + "</tr></thead>\n"
        f"  <tbody>\n{body}\n  </tbody>\n</table>\n</body></html>\n"
    )


def to_xlsx(rows: list[list[str]], path: Path) -> None:
    """The workbook a vendor sends: a title sheet first, then the registers with numbers as numbers."""
    book = openpyxl.Workbook()
    first = book.active
    first.title = "Read me"
    first.append(["Revision", "Date"])
    first.append([1, "2024"])
    regs = book.create_sheet("Registers")
    for r in rows:
        regs.append([_number(c) for c in r])
    book.save(path)


ODS_HEAD = (
    '<?xml version="1.0" encoding="UTF-8"?>\n<office:document-content '
    'xmlns:office="urn:oasis:names:tc:opendocument:xmlns:office:1.0" '
    'xmlns:table="urn:oasis:names:tc:opendocument:xmlns:table:1.0" '
    'xmlns:text="urn:oasis:names:tc:opendocument:xmlns:text:1.0"><office:body><office:spreadsheet>'
)


def to_ods(rows: list[list[str]], path: Path) -> None:
    """The spreadsheet LibreOffice saves: a title sheet first, numbers as floats with their text, empty
    cells and the million empty rows at the end as repeats."""

    def cell(text: str) -> str:
        if not text:
            return "<table:table-cell/>"
        value = _number(text)
        kind = f'office:value-type="float" office:value="{value}"' if isinstance(value, (int, float)) else ""
        return f"<table:table-cell {kind}><text:p>{html.escape(text)}</text:p></table:table-cell>"

    def sheet(name: str, table: list[list[str]]) -> str:
        end = '<table:table-cell table:number-columns-repeated="16000"/>'  # to the sheet's last column
        body = "".join("<table:table-row>" + "".join(map(cell, r)) + end + "</table:table-row>" for r in table)
        tail = '<table:table-row table:number-rows-repeated="1048000"><table:table-cell/></table:table-row>'
        return f'<table:table table:name="{name}">{body}{tail}</table:table>'

    content = ODS_HEAD + sheet("Read me", [["Revision", "Date"], ["1", "2024"]]) + sheet("Registers", rows)
    content += "</office:spreadsheet></office:body></office:document-content>"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("mimetype", "application/vnd.oasis.opendocument.spreadsheet")
        archive.writestr("content.xml", content)


def _number(text: str) -> object:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text if text else None


def convert(source: Path, *args: object):
    return run_mdl("csv2xml", source, "--ini", INI, *args)


@pytest.fixture(scope="module")
def from_csv():
    proc = convert(TEMCO / "temco_tstat.csv")
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.mark.parametrize("suffix", [".md", ".html", ".htm", ".xlsx", ".ods", ".xls"])
def test_each_format_gives_the_mdl_its_csv_gives(tmp_path, from_csv, suffix):
    """The same table as Markdown, HTML, an .xlsx, an .ods (LibreOffice) and an .xls (Excel 97-2003, saved
    once with xlwt from the same rows: tests/data/csv2xml/temco_tstat.xls) gives the MDL of the CSV."""
    source = tmp_path / f"temco_tstat{suffix}"
    rows = temco_rows()
    if suffix == ".md":
        source.write_text(to_markdown(rows), encoding="utf-8")
    elif suffix == ".xlsx":
        to_xlsx(rows, source)
    elif suffix == ".ods":
        to_ods(rows, source)
    elif suffix == ".xls":
        shutil.copy(DATA / "csv2xml" / "temco_tstat.xls", source)
    else:
        source.write_text(to_html(rows), encoding="utf-8")
    proc = convert(source)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == from_csv
    assert "Traceback" not in proc.stderr
    which = "sheet 'Registers'" if suffix in (".xlsx", ".ods", ".xls") else "table 2"
    assert f"note: read {which}" in proc.stderr, proc.stderr
    assert "the first whose header holds the INI's column names" in proc.stderr  # the INI names its columns


@pytest.mark.commands  # serves or dials a device
def test_a_workbook_served_and_read(tmp_path, sim_factory):
    source = tmp_path / "temco_tstat.xlsx"
    to_xlsx(temco_rows(), source)
    xml = tmp_path / "tstat.xml"
    assert convert(source, "-o", xml).returncode == 0
    sim = sim_factory(xml, "--set", "occupied_setpoint=21.5", "--set", "fan_speed=3")
    proc = run_mdl("read", xml, "--host", "127.0.0.1", "--port", sim.port, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    values = json.loads(proc.stdout)
    assert values["occupied_setpoint"] == pytest.approx(21.5) and values["fan_speed"] == 3


# ---- cells as the page shows them ----------------------------------------------------------------

SIMPLE_INI = "[Function Name Search Synonyms]\nroom_temperature = room temperature\nfan_speed = fan speed\n"


def _ini(tmp_path: Path) -> Path:
    ini = tmp_path / "t.ini"
    ini.write_text(SIMPLE_INI)
    return ini


def _page(tmp_path: Path, name: str, text: str) -> tuple[object, dict[str, dict[str, str]]]:
    """Convert the page `text` saved as `name`: the run, and its functions by name."""
    path = tmp_path / name
    path.write_text(text)
    proc = run_mdl("csv2xml", path, "--ini", _ini(tmp_path))
    assert proc.returncode == 0, proc.stderr
    return proc, _functions(proc.stdout)


def _functions(xml: str) -> dict[str, dict[str, str]]:
    from lxml import etree

    root = etree.fromstring(xml.encode())
    out = {}
    for f in root.iter("{*}function"):
        fields = {etree.QName(c).localname: (c.text or "") for c in f if isinstance(c.tag, str)}
        out[fields["name"]] = fields
    return out


def test_markdown_cells_drop_marks_and_keep_line_breaks(tmp_path):
    proc, fns = _page(
        tmp_path,
        "t.md",
        "Intro text | not a table\n\n"
        "| Addr | Description | Type | Scale |\n|--:|---|:-:|---|\n"
        "| `0x10` | **Room** temperature<br>in _tenths_ \\| sensor | `int16` | *10 |\n"
        "| 17 | Fan_speed ~~old~~ [fan speed](http://x) | UINT16 | 1 |\n",
    )
    assert fns["room_temperature"]["description"] == "Room temperature\nin tenths | sensor"
    assert fns["room_temperature"]["addresses"] == "16" and fns["room_temperature"]["format"] == "INT16"
    assert fns["room_temperature"]["multiplier"] == "10"  # `*10` is a scale cell, not emphasis
    assert "'*10'" in proc.stderr  # ... said ambiguous, as in a CSV
    assert fns["fan_speed"]["description"] == "Fan_speed old fan speed"
    assert "note: a Markdown table" in proc.stderr


def test_html_cells_as_a_browser_shows_them(tmp_path):
    proc, fns = _page(
        tmp_path,
        "t.html",
        "<table><tr><th>Register<th>Group<th colspan=2>Description</tr>\n"
        "<tr><td>0x10<td rowspan=2>Climate<td>Room&nbsp;temperature<br/>in  <b>tenths</b>"
        "<script>ignored()</script><td>x</tr>\n"
        "<tr><td>17<td><p>Fan speed</p><p>0 off<table><tr><td>inner</table>more</p><td></tr>\n</table>",
    )
    assert fns["room_temperature"]["description"] == "Room temperature\nin tenths"
    assert fns["fan_speed"]["description"] == "Fan speed\n0 off\nmore"  # the inner table is apart
    assert "the cell at line 2, column 13 spans 2 rows (rowspan)" in proc.stderr
    assert "Climate" in proc.stdout.split("fan_speed")[1]  # the rowspan cell is the second row's group too


def test_minified_html_names_rows_by_number(tmp_path):
    page = tmp_path / "t.html"
    page.write_text(
        "<table><tr><th>Register</th><th>Description</th><th>Type</th></tr>"
        "<tr><td>0</td><td>Room temperature</td><td>int16</td></tr>"
        "<tr><td>1</td><td>Fan speed</td><td>bogus</td></tr></table>"
    )
    proc = run_mdl("csv2xml", page, "--ini", _ini(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert "share lines of the file: messages name its rows by number" in proc.stderr
    assert f"{page}:3: warning: column 2 'Type' format cell 'bogus'" in proc.stderr


def test_xlsx_cells_formulas_and_merged(tmp_path):
    book = openpyxl.Workbook()
    ws = book.active
    ws.title = "Map"
    ws.append(["Register", "Group", "Description", "Type", "Scale"])
    ws.append([16, "Climate", "Room temperature\nin tenths", "int16", 0.1])
    ws.append([17, None, "Fan speed", "uint16", 1.0])
    ws.merge_cells("B2:B3")
    path = tmp_path / "t.xlsx"
    book.save(path)
    proc = run_mdl("csv2xml", path, "--ini", _ini(tmp_path))
    assert proc.returncode == 0, proc.stderr
    fns = _functions(proc.stdout)
    assert fns["room_temperature"]["description"] == "Room temperature\nin tenths"
    assert fns["room_temperature"]["multiplier"] == "0.1" and fns["fan_speed"]["addresses"] == "17"
    assert "merged cell Map!B2:B3 covers several rows" in proc.stderr
    ws["A3"] = "=A2+1"  # written by a program that does not calculate: no saved value
    book.save(path)
    proc = run_mdl("csv2xml", path, "--ini", _ini(tmp_path))
    assert_clean_error(proc, 1, f"{path}: error: Map!A3: the formula =A2+1 has no saved value")


def test_xlsx_row_warnings_name_the_sheet_row(tmp_path):
    book = openpyxl.Workbook()
    ws = book.active
    ws.title = "My map"
    ws.append(["Title"])
    ws.append(["Register", "Description", "Type"])
    ws.append([0, "Room temperature", "int16"])
    ws.append([1, "Fan speed", "nonsense"])
    path = tmp_path / "t.xlsx"
    book.save(path)
    proc = run_mdl("csv2xml", path, "--ini", _ini(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert f"{path}:4: warning: column 2 'Type' format cell 'nonsense'" in proc.stderr
    assert "line 7 is row 7: 'My map'!A7" in proc.stderr


# ---- choosing the table ---------------------------------------------------------------------------

TWO_TABLES = (
    "```\n| Register | Description |\n|---|---|\n| 7 | Room temperature (an example in code) |\n```\n\n"
    "| Register | Description |\n|---|---|\n| 0 | Room temperature |\n\n"
    "| Register | Description |\n|---|---|\n| 5 | Room temperature |\n"
)


def test_table_option_chooses(tmp_path):
    md = tmp_path / "t.md"
    md.write_text(TWO_TABLES)
    ini = _ini(tmp_path)
    first = run_mdl("csv2xml", md, "--ini", ini)
    assert _functions(first.stdout)["room_temperature"]["addresses"] == "0"
    assert "(1 more hold one); --table chooses another" in first.stderr
    second = run_mdl("csv2xml", md, "--ini", ini, "--table", "2")
    assert second.returncode == 0, second.stderr
    assert _functions(second.stdout)["room_temperature"]["addresses"] == "5"
    assert "read table 2 (line 11): the one --table 2 names" in second.stderr
    assert_clean_error(run_mdl("csv2xml", md, "--ini", ini, "--table", "3"), 1, "--table 3: the file has 2")
    assert_clean_error(run_mdl("csv2xml", md, "--ini", ini, "--sheet", "x"), 1, "--sheet 'x' chooses a sheet")
    assert run_mdl("csv2xml", md, "--ini", ini, "--table", "0").returncode == 2


def test_sheet_option_chooses(tmp_path):
    book = openpyxl.Workbook()
    book.active.title = "A"
    book.active.append(["Register", "Description"])
    book.active.append([0, "Room temperature"])
    other = book.create_sheet("Second")
    other.append(["Register", "Description"])
    other.append([9, "Room temperature"])
    path = tmp_path / "t.xlsx"
    book.save(path)
    ini = _ini(tmp_path)
    proc = run_mdl("csv2xml", path, "--ini", ini, "--sheet", "second")
    assert proc.returncode == 0, proc.stderr
    assert _functions(proc.stdout)["room_temperature"]["addresses"] == "9"
    assert_clean_error(run_mdl("csv2xml", path, "--ini", ini, "--sheet", "Nope"), 1, "its sheets: 'A', 'Second'")
    by_number = run_mdl("csv2xml", path, "--ini", ini, "--table", "2")  # on a workbook, the Nth sheet
    assert _functions(by_number.stdout)["room_temperature"]["addresses"] == "9"


def _ini_with(tmp_path: Path, io: str) -> Path:
    """SIMPLE_INI with lines added to its [Input/Output] section."""
    ini = tmp_path / f"chosen{len(list(tmp_path.glob('chosen*.ini')))}.ini"
    ini.write_text(f"[Input/Output]\n{io}\n" + SIMPLE_INI)
    return ini


def test_the_ini_chooses_the_table_and_the_command_line_wins(tmp_path):
    """`table = N` / `sheet = NAME` in [Input/Output] choose as --table/--sheet do; given both, the
    command line's is read and a note says the INI's was not; a choice the file cannot meet is an
    error at the INI's line."""
    md = tmp_path / "t.md"
    md.write_text(TWO_TABLES)
    ini = _ini_with(tmp_path, "table = 2")
    proc = run_mdl("csv2xml", md, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    assert _functions(proc.stdout)["room_temperature"]["addresses"] == "5"
    assert "read table 2 (line 11): the one table = 2 in the INI names" in proc.stderr
    both = run_mdl("csv2xml", md, "--ini", ini, "--table", "1")
    assert _functions(both.stdout)["room_temperature"]["addresses"] == "0"
    assert f"{ini}:2: note: --table 1 is read instead of the INI's table = 2" in both.stderr
    far = _ini_with(tmp_path, "table = 7")
    assert_clean_error(run_mdl("csv2xml", md, "--ini", far), 1, f"{far}:2: error: table = 7 in the INI: the file has 2")
    bad = _ini_with(tmp_path, "table = second")
    assert_clean_error(run_mdl("csv2xml", md, "--ini", bad), 1, "table must be a table's number, 1 or more")
    csv_path = tmp_path / "t.csv"
    csv_path.write_text("Register,Description\n0,Room temperature\n")
    assert_clean_error(run_mdl("csv2xml", csv_path, "--ini", ini), 1, f"{ini}:2: error:", "read as one CSV table")


def test_the_ini_chooses_the_sheet(tmp_path):
    book = openpyxl.Workbook()
    book.active.title = "A"
    book.active.append(["Register", "Description"])
    book.active.append([0, "Room temperature"])
    other = book.create_sheet("Modbus map")
    other.append(["Register", "Description"])
    other.append([9, "Room temperature"])
    path = tmp_path / "t.xlsx"
    book.save(path)
    proc = run_mdl("csv2xml", path, "--ini", _ini_with(tmp_path, "sheet = Modbus map"))
    assert proc.returncode == 0, proc.stderr
    assert _functions(proc.stdout)["room_temperature"]["addresses"] == "9"
    missing = _ini_with(tmp_path, "sheet = Registers")
    assert_clean_error(
        run_mdl("csv2xml", path, "--ini", missing), 1, f"{missing}:2: error: sheet = 'Registers' in the INI"
    )


def test_quiet_prints_warnings_only(tmp_path):
    """--quiet: no notes, no summary, no 'wrote' line; warnings still print and --strict still counts them."""
    md = tmp_path / "t.md"
    md.write_text(TWO_TABLES + "\n| Register | Description |\n|---|---|\n| 1 | Fan speed |\n| x | Humidity |\n")
    out = tmp_path / "out.xml"
    loud = run_mdl("csv2xml", md, "--ini", _ini(tmp_path), "--table", "3", "-o", out)
    assert loud.returncode == 0 and "note: summary" in loud.stderr and "wrote" in loud.stderr
    quiet = run_mdl("csv2xml", md, "--ini", _ini(tmp_path), "--table", "3", "-o", out, "--quiet")
    assert quiet.returncode == 0, quiet.stderr
    lines = quiet.stderr.splitlines()
    assert lines and all(": warning: " in line for line in lines), quiet.stderr
    assert out.read_text().count("<function>") >= 1
    strict = run_mdl("csv2xml", md, "--ini", _ini(tmp_path), "--table", "3", "-q", "--strict")
    assert_clean_error(strict, 1, "--strict: nothing written")


def test_no_table_with_an_address_column(tmp_path):
    page = tmp_path / "t.html"
    page.write_text("<table><tr><td>a<td>b</table>\n<table><tr><td>c</table>")
    proc = run_mdl("csv2xml", page, "--ini", _ini(tmp_path))
    assert_clean_error(proc, 1, "no HTML table has a header with an address column", "table 2 (line 2, column 1): 'c'")
    page.write_text("<p>no tables</p>")
    assert_clean_error(run_mdl("csv2xml", page, "--ini", _ini(tmp_path)), 1, f"{page}: error: no HTML table")


@pytest.mark.parametrize("data", [b"", b"PK\x03\x04garbage", b"not a zip at all", b"\xd0\xcf\x11\xe0"])
def test_a_damaged_workbook_is_an_error(tmp_path, data):
    path = tmp_path / "t.xlsx"
    path.write_bytes(data)
    assert_clean_error(run_mdl("csv2xml", path, "--ini", _ini(tmp_path)), 1, f"{path}: error:")


def test_a_broken_xls_is_a_clean_error(tmp_path):
    """An .xls is read (issue 36); one cut short after its signature is an error naming the file."""
    path = tmp_path / "t.xls"
    path.write_bytes(b"\xd0\xcf\x11\xe0")
    assert_clean_error(run_mdl("csv2xml", path, "--ini", _ini(tmp_path)), 1, "not a readable Excel 97-2003 workbook")


def test_table_option_on_a_csv_is_an_error(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("Register,Description\n0,Room temperature\n")
    assert_clean_error(run_mdl("csv2xml", path, "--ini", _ini(tmp_path), "--table", "1"), 1, "is read as one CSV table")


def test_a_few_bytes_of_spans_cannot_ask_for_a_huge_grid(tmp_path):
    page = tmp_path / "t.html"
    page.write_text("<table><tr><th>Register<th>Description</tr><tr>" + "<td colspan=1000>x" * 1500 + "</table>")
    assert_clean_error(
        run_mdl("csv2xml", page, "--ini", _ini(tmp_path)), 1, f"{page}:1: error: the table has more than"
    )
