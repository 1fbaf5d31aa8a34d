"""Fuzzing csv2xml's PDF and OpenDocument readers: a real manual with bytes changed, cut or repeated, and
content.xml built from random pieces, give MDL (exit 0) or an error naming the file (exit 1), never a
traceback, a hang or another exit status."""

from __future__ import annotations

import zipfile

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from support.common import DATA
from support.run import cli

MANUAL = (DATA / "corpus" / "pdf" / "noark_ex9em_register_map.pdf").read_bytes()


def _clean(proc) -> None:
    assert proc.returncode in (0, 1), proc.stderr
    assert "Traceback" not in proc.stderr
    if proc.returncode == 1:
        assert "error:" in proc.stderr


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    edits=st.lists(st.tuples(st.integers(0, len(MANUAL) - 1), st.binary(min_size=1, max_size=8)), max_size=6),
    cut=st.integers(64, len(MANUAL)),
)
def test_a_damaged_manual_is_read_or_refused_cleanly(tmp_path, edits, cut):
    data = bytearray(MANUAL[:cut])
    for at, new in edits:
        data[at % len(data) : at % len(data) + len(new)] = new
    path = tmp_path / "manual.pdf"
    path.write_bytes(bytes(data))
    _clean(cli("csv2xml", path, "--all", "-o", tmp_path / "out.xml", timeout=120))


HEAD = (
    '<?xml version="1.0"?><office:document-content xmlns:office="urn:oasis:names:tc:opendocument:xmlns:office:1.0" '
    'xmlns:table="urn:oasis:names:tc:opendocument:xmlns:table:1.0" '
    'xmlns:text="urn:oasis:names:tc:opendocument:xmlns:text:1.0"><office:body><office:spreadsheet>'
    '<table:table table:name="R">'
)
PIECES = [
    "<table:table-row>",
    "</table:table-row>",
    "<table:table-cell>",
    "</table:table-cell>",
    "<table:table-cell/>",
    '<table:table-cell table:number-columns-repeated="70000"/>',
    '<table:table-row table:number-rows-repeated="9">',
    '<table:table-cell table:number-rows-spanned="3">',
    "<table:covered-table-cell/>",
    "<text:p>",
    "</text:p>",
    "Address",
    "Name",
    "0x10",
    "17",
    "Voltage",
    '<table:table-cell office:value-type="float" office:value="x">',
    '<table:table-cell table:number-columns-repeated="-1">',
    "&amp;",
    "&bogus;",
    "<!DOCTYPE x>",
    "\x00",
]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.sampled_from(PIECES), max_size=40))
def test_random_ods_content_is_read_or_refused_cleanly(tmp_path, pieces):
    content = HEAD + "".join(pieces) + "</table:table></office:spreadsheet></office:body></office:document-content>"
    path = tmp_path / "t.ods"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("content.xml", content)
    _clean(cli("csv2xml", path, "--all", "-o", tmp_path / "out.xml"))
