"""Fuzzing csv2xml's Markdown and HTML readers through the CLI: random and mutated pages give MDL
(exit 0) or errors with the file and a position (exit 1), never a traceback or another exit status."""

from __future__ import annotations

import os
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from support.run import cli

INI = "[Function Name Search Synonyms]\nroom_temperature = room temperature\nfan_speed = fan speed\n"

HTML_SEED = (
    "<html><body><h1>Map</h1><table>\n<tr><th>Register</th><th>Description</th><th>Type</th><th>Scale</th></tr>\n"
    "<tr><td>0x10</td><td rowspan=2>Room <b>temperature</b><br>tenths</td><td>int16</td><td>0.1</td></tr>\n"
    "<tr><td colspan=2>17</td><td>UINT16</td><td>*10</td></tr>\n<tr><td>18</td><td>Fan speed</td></tr>\n"
    "</table></body></html>\n"
)
MD_SEED = (
    "# Map\n\n| Register | Description | Type | Scale |\n|---|:--|--:|---|\n"
    "| `0x10` | **Room** temperature<br>tenths \\| x | int16 | 0.1 |\n| 17 | _Fan_ speed | UINT16 | *10 |\n"
)
PIECES = [
    "<table>", "</table>", "<tr>", "</tr>", "<td>", "</td>", "<th>", "<td rowspan=0>", "<td colspan=999>",
    "<td rowspan=x>", "<br>", "<script>", "</script>", "<p>", "&amp;", "&#0;", "&bogus", "<!--", "-->", "<![CDATA[",
    "|", "\\|", "`", "**", "_", "*", "~~", "<br>", "|---|", "\n", "\r\n", "\x00", "40001", "0x10", "1 to 3",
    "Register", "Address", "Description", "Room temperature", "\u00e9", "\ufeff", "\t", " ",
]  # fmt: skip

EXAMPLES = int(os.environ.get("MDL_FUZZ_DOCUMENTS", "150"))  # a long run: MDL_FUZZ_DOCUMENTS=5000


@st.composite
def mutated(draw: st.DrawFn, seed: str) -> str:
    text = seed
    for _ in range(draw(st.integers(0, 6))):
        at = draw(st.integers(0, len(text)))
        action = draw(st.sampled_from(["insert", "delete", "duplicate"]))
        if action == "insert":
            text = text[:at] + draw(st.sampled_from(PIECES) | st.text(max_size=4)) + text[at:]
        elif action == "delete":
            text = text[:at] + text[at + draw(st.integers(1, 20)) :]
        else:
            text = text[:at] + text[at : at + draw(st.integers(1, 60))] * 2 + text[at:]
    return text


pages = st.one_of(
    st.tuples(st.just(".html"), mutated(HTML_SEED)),
    st.tuples(st.just(".md"), mutated(MD_SEED)),
    st.tuples(st.sampled_from([".html", ".md"]), st.lists(st.sampled_from(PIECES), max_size=40).map("".join)),
)


@settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(page=pages, table=st.sampled_from([None, "1", "2"]))
def test_pages_convert_or_are_refused_with_positions(tmp_path_factory, page, table):
    folder: Path = tmp_path_factory.mktemp("page")
    suffix, text = page
    source = folder / f"map{suffix}"
    source.write_text(text, encoding="utf-8", errors="surrogatepass")
    ini = folder / "map.ini"
    ini.write_text(INI)
    proc = cli("csv2xml", source, "--ini", ini, *(["--table", table] if table else []))
    assert proc.returncode in (0, 1), (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr
    if proc.returncode == 0:
        assert proc.stdout.startswith("<?xml")
    else:
        errors = [line for line in proc.stderr.splitlines() if ": error: " in line]
        assert errors and all(line.startswith(str(source)) for line in errors), proc.stderr


values = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**40), 2**40),
    st.floats(allow_nan=False, allow_infinity=False),
    st.dates(),
    st.sampled_from([p for p in PIECES if "\x00" not in p]),  # what a worksheet can hold: no control characters
    st.text(alphabet=st.characters(blacklist_categories=("Cs", "Cc")), max_size=12),
)


@settings(max_examples=max(EXAMPLES // 3, 20), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    header=st.lists(st.sampled_from(["Register", "Description", "Type", "Scale", "Units", None]), max_size=5),
    rows=st.lists(st.lists(values, max_size=5), max_size=6),
    merge=st.booleans(),
)
def test_workbooks_convert_or_are_refused(tmp_path_factory, header, rows, merge):
    import openpyxl

    folder: Path = tmp_path_factory.mktemp("book")
    book = openpyxl.Workbook()
    for r in [header, *rows]:
        book.active.append(r)
    if merge and len(rows) > 1:
        book.active.merge_cells("A2:A3")
    source = folder / "map.xlsx"
    book.save(source)
    ini = folder / "map.ini"
    ini.write_text(INI)
    proc = cli("csv2xml", source, "--ini", ini)
    assert proc.returncode in (0, 1), (proc.returncode, proc.stderr)
    if proc.returncode == 1:
        errors = [line for line in proc.stderr.splitlines() if ": error: " in line]
        assert errors and all(line.startswith(str(source)) for line in errors), proc.stderr
