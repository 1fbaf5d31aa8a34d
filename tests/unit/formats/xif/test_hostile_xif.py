"""Hostile SmartServer XIF (`.mod`) input and output through the CLI (issues 27 and 28): bounded
messages, stated limits instead of tracebacks, every refused cell at its line and column, export cells
a spreadsheet does not run as formulas and that never start a row or a product line, and block
labels starting with `#` kept by the round trip."""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import pytest
from lxml import etree

from mdl.formats.mdl.load import tree_to_device
from mdl.formats.mdl.parse import secure_parser
from mdl.formats.xif.read import MAX_BYTES, MAX_DATAPOINTS, MAX_ERRORS
from mdl.formats.xif.records import MAX_CELLS
from support.common import device_xml, fn_xml
from support.run import assert_clean_error, cli, run_mdl

HEAD = "#filetype,Modbus_xif\n#program_ID,9F0096052804DB01\n"
HEADING = "Block Name,Datapoint Name,Modicon,Address,Function Code,Native Type,Write Enable,Description"
WIDTH = len(HEADING.split(","))
TRIGGERS = ("=", "+", "-", "@", "\t", "\r")
LINE_BREAKS = ("\n", "\r", "\r\n", "\x85", "\u2028", "\u2029")  # those MDL (XML) can hold; U+000B, U+000C and
# U+001C-U+001E, which no MDL document holds, are refused by the same check


def write(tmp_path: Path, text: str, name: str = "device.mod") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8", newline="")
    return path


def rows(n: int, extra: str = "", start: int = 0) -> str:
    return "".join(f"B,p{i},N,{i},FC03,UINT16,-,d{i}{extra}\n" for i in range(start, start + n))


def functions_of(xml: str) -> list[tuple]:
    device = tree_to_device(etree.fromstring(xml.encode("ascii"), secure_parser()).getroottree())
    return [(fn.name, fn.description, fn.addresses, fn.block_labels) for fn in device.functions]


def stderr_lines(proc) -> list[str]:
    """What the import said, less its `wrote FILE` line."""
    return [line for line in proc.stderr.splitlines() if not line.startswith("wrote ")]


# -- bounded messages ----------------------------------------------------------------------------
def test_cells_past_the_heading_are_one_warning_naming_the_rows(tmp_path):
    path = write(tmp_path, HEAD + HEADING + "\n" + rows(3000, ",x,y"))
    proc = cli("import", path, "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr
    col = rows(1, ",x,y").index(",x") + 2
    assert stderr_lines(proc) == [
        f"{path}:4:{col}: warning: cells beyond the heading's {WIDTH} columns, ignored, "
        "on 3,000 rows (first at lines 4, 5, 6, ...)"
    ]


def test_a_few_cells_past_the_heading_are_each_said_at_their_cell(tmp_path):
    path = write(tmp_path, HEAD + HEADING + "\n" + rows(1, ",x,y") + rows(1, start=1))
    proc = cli("import", path)
    assert proc.returncode == 0, proc.stderr
    col = rows(1, ",x,y").index(",x") + 2
    assert f"{path}:4:{col}: warning: 2 cells beyond the heading's {WIDTH} columns (the first 'x')" in proc.stderr


def test_every_kind_of_warning_is_bounded(tmp_path):
    heading = HEADING + ",Bit Order,Junk1,Junk2,Junk3,Junk4"
    row = "#x,,\n,p{i},N,{i},FC03,uint32,,d,big\n"  # unknown product line, lower case type, blank write, bit order
    text = HEAD + heading + "\n" + "".join(row.format(i=2 * i) for i in range(2000))
    path = write(tmp_path, text)
    proc = cli("import", path, "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr
    lines = stderr_lines(proc)
    assert len(lines) == 5, lines
    assert "columns 'Junk1', 'Junk2', 'Junk3' and 1 more are not Modbus XIF columns; ignored" in lines[0]
    assert all(re.search(r"on 2,000 rows \(first at lines \d+, \d+, \d+, \.\.\.\)$", line) for line in lines[1:])


def test_errors_stop_being_listed_after_the_first_hundred(tmp_path):
    path = write(tmp_path, HEAD + HEADING + "\n" + "".join(f"B,p{i},N,x{i},FC03,UINT16,-,\n" for i in range(5000)))
    proc = cli("import", path, "-o", tmp_path / "out.xml")
    assert_clean_error(
        proc,
        1,
        f"{path}:4:8: error: Address 'x0' is not a whole number",
        f"{path}:{4 + MAX_ERRORS}:10: error: {5000 - MAX_ERRORS:,} more errors not shown (first at "
        f"lines {4 + MAX_ERRORS}, {5 + MAX_ERRORS}, {6 + MAX_ERRORS}, ...)",
    )
    assert len(stderr_lines(proc)) == MAX_ERRORS + 1
    assert not (tmp_path / "out.xml").exists()


# -- stated limits, never a traceback ------------------------------------------------------------
@pytest.mark.hostile  # seconds of work to prove a limit: the hostile tier (docs/testing.md)
def test_more_datapoints_than_the_limit_are_refused_at_the_first_row_past_it(tmp_path):
    text = (
        HEAD
        + "Datapoint Name,Modicon,Address,Function Code,Native Type,Write Enable\n"
        + "".join(f"p{i},N,{i % 65536},FC0{3 + i // 65536},,-\n" for i in range(MAX_DATAPOINTS + 5))
    )
    path = write(tmp_path, text, "big.mod")
    proc = run_mdl("import", path, "-o", tmp_path / "out.xml", timeout=300)
    assert_clean_error(proc, 1, f"{path}:{MAX_DATAPOINTS + 4}:1: error: more than {MAX_DATAPOINTS:,} datapoints")
    assert not (tmp_path / "out.xml").exists()


def test_a_file_over_the_size_limit_is_refused_from_a_path_and_from_standard_input(tmp_path):
    text = HEAD + HEADING + "\n" + "," * (MAX_BYTES - len(HEAD) - len(HEADING))
    path = write(tmp_path, text, "big.mod")
    assert path.stat().st_size == MAX_BYTES + 1
    proc = run_mdl("import", path, "-o", tmp_path / "out.xml")
    assert_clean_error(proc, 1, f"{path}: error: larger than 16 MiB")
    proc = run_mdl("import", "-", "--from", "xif", input=text)
    assert_clean_error(proc, 1, "<stdin>: error: larger than 16 MiB")
    assert not (tmp_path / "out.xml").exists()


def test_a_file_just_under_the_size_limit_is_read(tmp_path):
    body = HEAD + HEADING + "\n" + rows(2)
    path = write(tmp_path, body + "\n" * (MAX_BYTES - len(body)))
    assert path.stat().st_size == MAX_BYTES
    proc = run_mdl("import", path)
    assert proc.returncode == 0, proc.stderr
    assert "<name>p1</name>" in proc.stdout


def test_a_row_of_more_cells_than_excel_has_columns_is_refused_at_the_cell(tmp_path):
    path = write(tmp_path, HEAD + HEADING + "\n" + "B,p,N,1,FC03,UINT16,-" + "," * MAX_CELLS + "\n")
    proc = cli("import", path)
    assert_clean_error(proc, 1, f"{path}:4:{22 + MAX_CELLS + 1 - 7}: error: more than 16,384 cells in one row")
    assert len(stderr_lines(proc)) == 1


@pytest.mark.hostile  # seconds of work to prove a limit: the hostile tier (docs/testing.md)
def test_a_large_file_imports_from_a_path_and_from_standard_input(tmp_path):
    text = HEAD + HEADING + "\n" + rows(5000)
    path = write(tmp_path, text, "big.mod")
    out = tmp_path / "out.xml"
    proc = run_mdl("import", path, "-o", out, timeout=300)
    assert proc.returncode == 0 and proc.stderr == f"wrote {out}\n", proc.stderr
    piped = run_mdl("import", "-", "--from", "xif", input=text, timeout=300)
    assert piped.returncode == 0 and piped.stderr == "", piped.stderr
    assert functions_of(out.read_text()) == functions_of(piped.stdout)
    assert len(functions_of(piped.stdout)) == 5000


# -- every refused cell at its position ----------------------------------------------------------
@pytest.mark.parametrize("column", ["Block Name", "Datapoint Name", "Description"])
@pytest.mark.parametrize("char", ["\x0c", "\x00", "\x1b", "\ufffe"])
def test_a_text_cell_xml_cannot_carry_is_refused_at_its_cell(tmp_path, column, char):
    cells = ["B", "name", "N", "1", "FC03", "UINT16", "-", "d"]
    at = HEADING.split(",").index(column)
    cells[at] = f"a{char}b"
    path = write(tmp_path, HEAD + HEADING + "\n" + ",".join(cells) + "\n")
    col = len(",".join(cells[:at])) + (2 if at else 1)
    proc = cli("import", path)
    assert_clean_error(
        proc, 1, f"{path}:4:{col}: error: 'a", f"holds the character U+{ord(char):04X}, which MDL (XML) cannot carry"
    )


def test_a_product_line_xml_cannot_carry_is_refused_at_its_cell(tmp_path):
    path = write(tmp_path, "#filetype,Modbus_xif\n#manufacturer,Ac\x0cme\n" + HEADING + "\n" + rows(1))
    proc = cli("import", path)
    assert_clean_error(proc, 1, f"{path}:2:15: error: 'Ac\\x0cme' holds the character U+000C")


# -- export: spreadsheets and line breaks ---------------------------------------------------------
def hostile_device(texts: list[str]) -> str:
    """A function named and labelled with each text, and one described with each (a description is
    stripped of spaces at its ends, by every reader: those starting with a tab are not compared)."""
    fns = "".join(fn_xml(xml_text(f"{t}n{i}"), i, block_label=xml_text(f"{t}b")) for i, t in enumerate(texts))
    fns += "".join(
        fn_xml(f"plain{i}", 100 + i, block_label="B").replace(
            f"<description>plain{i}</description>", f"<description>{xml_text(t)}d</description>"
        )
        for i, t in enumerate(texts)
        if not t[:1].isspace()
    )
    return device_xml(fns)


def xml_text(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in " _" else f"&#{ord(ch)};" for ch in text)


def test_formula_cells_are_written_behind_a_quote_mark_and_read_back_without_it(tmp_path):
    texts = [*TRIGGERS[:-1], "'=", "''", "'+", '=HYPERLINK("http://x","y")', "-2+3"]
    source = tmp_path / "hostile.xml"
    source.write_text(hostile_device(texts))
    mod = tmp_path / "hostile.mod"
    proc = cli("export", source, "--to", "xif", "-o", mod)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("its name written behind a '") == 1, proc.stderr  # one warning names them all
    for i, t in enumerate(texts):
        name = f"{t}n{i}".replace("\t", "\\t")
        assert f"'{name}' (''{name}')" in proc.stderr, (name, proc.stderr)
    records = list(csv.reader(io.StringIO(mod.read_bytes().decode("utf-8"))))
    heading = records[3]
    for record in records[4:]:
        for column in ("Block Name", "Datapoint Name", "Description"):
            cell = record[heading.index(column)]
            assert not cell.startswith(TRIGGERS), (column, cell)
    again = cli("import", mod)
    assert again.returncode == 0, again.stderr
    assert functions_of(again.stdout) == functions_of(source.read_text())
    assert (
        "a leading ' (the mark mdl export puts before a text a spreadsheet would run as a formula) removed"
        in again.stderr
    )


def test_identity_starting_with_a_formula_is_marked_and_comes_back(tmp_path):
    source = tmp_path / "d.xml"
    source.write_text(
        device_xml(fn_xml("a", 1)).replace(
            "<description>test</description>",
            "<description>=1+1</description><manufacturer>@SUM(A1)</manufacturer><product>+x</product>",
        )
    )
    mod = tmp_path / "d.mod"
    proc = cli("export", source, "--to", "xif", "-o", mod)
    assert proc.returncode == 0, proc.stderr
    assert "warning: its #manufacturer written behind a '" in proc.stderr and "(''@SUM(A1)')" in proc.stderr
    text = mod.read_bytes().decode()
    assert "#description,'=1+1\r\n" in text and "#manufacturer,'@SUM(A1)\r\n" in text
    xml = cli("import", mod).stdout
    assert "<description>=1+1</description>" in xml and "<manufacturer>@SUM(A1)</manufacturer>" in xml


@pytest.mark.parametrize("brk", LINE_BREAKS)
@pytest.mark.parametrize("where", ["name", "block_label", "manufacturer"])
def test_a_line_break_in_a_name_label_or_identity_is_refused_naming_it(tmp_path, brk, where):
    text = f"a{xml_text(brk)}#program_ID,0"
    fn = fn_xml(text if where == "name" else "f", 1, block_label=text if where == "block_label" else "B")
    xml = device_xml(fn)
    if where == "manufacturer":
        xml = xml.replace("</description>", f"</description><manufacturer>{text}</manufacturer>", 1)
    source = tmp_path / "d.xml"
    source.write_text(xml)
    out = tmp_path / "d.mod"
    proc = cli("export", source, "--to", "xif", "-o", out)
    subject = "its #manufacturer" if where == "manufacturer" else f"function '{'f' if where != 'name' else 'a'}"
    assert_clean_error(proc, 1, subject, f"holds a line break (U+{ord(brk[0]):04X}), which would start a new row")
    assert not out.exists()


def test_commas_quotes_and_line_breaks_never_make_a_row_or_a_cell(tmp_path):
    nasty, maker = 'x,"y",\n#program_ID,1\u2028z', 'A, "B"'
    source = tmp_path / "d.xml"
    fns = fn_xml('a,"b"', 1, block_label='" ,#c') + fn_xml("two", 2, block_label="B").replace(
        "<description>two</description>", f"<description>{xml_text(nasty)}</description>"
    )
    source.write_text(
        device_xml(fns).replace(
            "<description>test</description>",
            f"<description>{xml_text(nasty)}</description><manufacturer>{xml_text(maker)}</manufacturer>",
        )
    )
    mod = tmp_path / "d.mod"
    proc = cli("export", source, "--to", "xif", "-o", mod)
    assert proc.returncode == 0, proc.stderr
    assert "function 'two' (U+000A): its description holds line breaks: written on one line" in proc.stderr
    raw = mod.read_bytes().decode("utf-8")
    assert len(raw.split("\r\n")) == 8 and not any(ch in raw.replace("\r\n", "") for ch in "\r\n\u2028")
    records = list(csv.reader(io.StringIO(raw)))
    assert [r[0] for r in records[:4]] == ["#filetype", "#program_ID", "#manufacturer", "#description"]
    assert all(len(r) == len(records[4]) for r in records[5:])
    xml = cli("import", mod).stdout
    device = tree_to_device(etree.fromstring(xml.encode("ascii"), secure_parser()).getroottree())
    assert device.manufacturer == 'A, "B"' and device.description == 'x,"y", #program_ID,1 z'
    assert [(fn.name, fn.block_labels, fn.description) for fn in device.functions] == [
        ('a,"b"', ['" ,#c'], 'a,"b"'),
        ("two", ["B"], 'x,"y", #program_ID,1 z'),
    ]


# -- issue 28: block labels starting with # --------------------------------------------------------
def test_block_labels_starting_with_hash_survive_the_round_trip(tmp_path):
    labels = ["#", "#Block", "#version", "#filetype", "# x", "#program_ID"]
    source = tmp_path / "d.xml"
    source.write_text(device_xml("".join(fn_xml(f"f{i}", i, block_label=label) for i, label in enumerate(labels))))
    mod = tmp_path / "d.mod"
    proc = cli("export", source, "--to", "xif", "-o", mod)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("starts with #: written in quotes") == 1  # one note naming them all (issue 20)
    assert (
        f"functions {', '.join(repr(f'f{i}') for i in range(len(labels)))}: its Block Name starts with #" in proc.stderr
    ), proc.stderr
    again = cli("import", mod)
    assert again.returncode == 0 and "warning" not in again.stderr, again.stderr
    assert functions_of(again.stdout) == functions_of(source.read_text())
    twice = tmp_path / "twice.mod"
    assert cli("export", mod, "--to", "xif", "-o", twice).returncode == 0
    assert twice.read_bytes() == mod.read_bytes()


@pytest.mark.parametrize("line", ["#Block,p,N,1,FC03,UINT16,-,d", "#,p,N,1,FC03,UINT16,-,d", "#"])
def test_an_unknown_product_line_is_skipped_with_a_warning(tmp_path, line):
    path = write(tmp_path, HEAD + HEADING + "\n" + rows(1) + line + "\n")
    proc = cli("import", path)
    assert proc.returncode == 0, proc.stderr
    assert (
        f"{path}:5:1: warning: '{line.split(',')[0]}' is not a product line of a Modbus XIF file; the line is "
        "ignored" in proc.stderr
    )


def test_a_quoted_hash_before_the_heading_is_still_a_product_line(tmp_path):
    path = write(tmp_path, '"#filetype","Modbus_xif"\n"#manufacturer","Acme"\n' + HEADING + "\n" + rows(1))
    proc = cli("import", path)
    assert proc.returncode == 0, proc.stderr
    assert "<manufacturer>Acme</manufacturer>" in proc.stdout


def test_a_lone_surrogate_from_a_toolkit_file_is_a_clean_refusal_on_export(tmp_path):
    """YAML can spell a lone surrogate (\\ud800), which no UTF-8 file can hold: the export names it, exit 1,
    and leaves no file (a review found a UnicodeEncodeError traceback)."""
    schema = tmp_path / "s.yaml"
    schema.write_text(
        'description: "W\\ud800x"\nblocks:\n  - id: b\n    fields:\n'
        '      - id: f\n        description: "d"\n        expression: "uint16(hr:0)"\n'
    )
    out = tmp_path / "out.mod"
    proc = run_mdl("export", schema, "--to", "xif", "-o", out)
    assert_clean_error(proc, 1, f"{schema}: error: its #description holds U+D800, which a .mod cell cannot carry")
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml"]


def test_a_nul_in_a_toolkit_description_is_refused_by_the_xif_export(tmp_path):
    """YAML can spell NUL (\\x00), which MDL cannot carry and mdl import refuses in a .mod cell: the export
    names it instead of writing it raw into the #description line."""
    schema = tmp_path / "n.yaml"
    schema.write_text(
        'description: "W\\x00x"\nblocks:\n  - id: b\n    fields:\n'
        '      - id: f\n        description: "d"\n        expression: "uint16(hr:0)"\n'
    )
    out = tmp_path / "n.mod"
    proc = run_mdl("export", schema, "--to", "xif", "-o", out)
    assert_clean_error(proc, 1, "holds U+0000, which a .mod cell cannot carry")
    assert not out.exists()


def test_write_atomic_refuses_text_no_file_can_hold(tmp_path):
    """The last guard for every writer: a lone surrogate is an error naming the file, and nothing is left."""
    from mdl.diagnostics import MdlError
    from mdl.fileio import write_atomic

    with pytest.raises(MdlError, match="cannot write: the text holds U\\+D800, which no file can carry"):
        write_atomic(tmp_path / "x.txt", "a\ud800")
    assert list(tmp_path.iterdir()) == []
