"""Fuzzing the SmartServer XIF (`.mod`) reader and the export round trip through the CLI.

The reader: random and mutated `.mod` text, some rows repeated hundreds of times, gives exit 0 or 1,
never an exception, every error naming the file, and a bounded number of messages whatever the
file holds (one per kind past the first few, at most MAX_ERRORS errors and a count).

The round trip: descriptions whose names, descriptions, block labels and identity hold what a
spreadsheet runs as a formula, `#`, commas, quotes and line breaks of every kind export to a `.mod`
that imports back to the same functions (a description's line breaks as spaces), or are refused
(exit 1, no file written) where a name, block label or identity value holds a line break."""

from __future__ import annotations

import re
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from lxml import etree

from mdl.diagnostics import SHOWN_EACH
from mdl.formats.mdl.load import tree_to_device
from mdl.formats.mdl.parse import secure_parser
from mdl.formats.xif import columns as C
from mdl.formats.xif.read import MAX_ERRORS
from mdl.model import Device
from support.common import DATA, ROOT, device_xml, fn_xml
from support.run import cli

SEEDS = [
    (ROOT / "examples" / "xif_meter" / "meter.mod").read_text(encoding="utf-8"),
    *(p.read_text(encoding="utf-8") for p in sorted((DATA / "xif").glob("*.mod"))),
]
PIECES = [
    ",",
    ",,",
    "\n",
    "\r\n",
    "\r",
    '"',
    '""',
    "#",
    "#x,",
    "#filetype,Modbus_xif\n",
    "#program_ID,",
    "'",
    "'=",
    "=1+1",
    "+",
    "-",
    "@",
    "\t",
    "FC01",
    "FC03",
    "FC05",
    "40001",
    "65536",
    "99999999999999",
    "1e999",
    "BIT",
    "FLOAT",
    "CHAR8",
    "CHAR8_2",
    "uint32",
    "SINT8",
    "++",
    "R",
    "little",
    "big",
    "Y",
    "N",
    "0x10",
    "\x0c",
    "\x00",
    "\x85",
    "\u2028",
    "\ufeff",
    "\u00b2",
    "Datapoint Name",
    "Address",
    "Native Type",
    "Write Enable",
    "Native Value 1",
    "A'",
    "Marker Value",
    "ASCII Length",
    "Bit Order",
    "Junk",
]
ERROR_LINE = re.compile(r"^(?P<file>.+?)(:\d+(:\d+)?)?: error: \S")
# generous: MAX_ERRORS errors and their count, and SHOWN_EACH messages of each of the reader's kinds
BOUND = MAX_ERRORS + 1 + SHOWN_EACH * 40


@st.composite
def mod_texts(draw: st.DrawFn) -> str:
    """A real `.mod` with pieces inserted, deleted or replaced, and one of its rows repeated."""
    text = draw(st.sampled_from(SEEDS))
    for _ in range(draw(st.integers(0, 6))):
        at = draw(st.integers(0, len(text)))
        cut = draw(st.integers(0, 6))
        text = text[:at] + draw(st.sampled_from(PIECES)) + text[at + cut :]
    lines = text.split("\n")
    if draw(st.booleans()) and len(lines) > 1:
        at = draw(st.integers(1, len(lines) - 1))
        lines[at:at] = [lines[at]] * draw(st.integers(1, 400))
    return "\n".join(lines)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(mod_texts(), st.lists(st.sampled_from(PIECES), max_size=40).map("".join)))
def test_the_reader_exits_0_or_1_with_bounded_messages(text):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fuzz.mod"
        path.write_text(text, encoding="utf-8", errors="surrogatepass", newline="")
        proc = cli("import", path, "-o", Path(tmp) / "out.xml")  # an exception would be raised here
        assert proc.returncode in (0, 1), proc
        assert "Traceback" not in proc.stderr
        assert (Path(tmp) / "out.xml").exists() == (proc.returncode == 0)
    lines = proc.stderr.splitlines()
    for line in lines:
        if ": error: " in line:
            m = ERROR_LINE.match(line)
            assert m and m["file"] == str(path), line
    own = [line for line in lines if ": function '" not in line]  # the resolve step's: one per function at most
    assert len(own) <= BOUND, len(own)
    event("imported" if proc.returncode == 0 else "refused")


# -- the round trip ----------------------------------------------------------------------------------
HOSTILE = "=+-@\t'#,\";\n\r\u2028\u2029\x85 a0é"
TEXTS = st.text(alphabet=st.sampled_from(HOSTILE), min_size=1, max_size=8).map(str.strip).filter(bool)


def xml_text(text: str) -> str:
    return "".join(ch if ch.isascii() and ch.isalnum() else f"&#{ord(ch)};" for ch in text)


def device_of(xml: str) -> Device:
    return tree_to_device(etree.fromstring(xml.encode("ascii"), secure_parser()).getroottree())


def one_line(text: str) -> str:
    return " ".join(text.splitlines()).strip()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(TEXTS, TEXTS, TEXTS), min_size=1, max_size=5), TEXTS, TEXTS)
def test_export_then_import_gives_the_same_functions_or_a_refusal(texts, maker, about):
    fns = ""
    for i, (name, description, label) in enumerate(texts):
        body = fn_xml(xml_text(f"{name} n{i}"), i, block_label=xml_text(label))
        fns += body.replace(
            f"<description>{xml_text(f'{name} n{i}')}</description>",
            f"<description>{xml_text(description)}</description>",
        )
    xml = device_xml(fns).replace(
        "<description>test</description>",
        f"<description>{xml_text(about)}</description><manufacturer>{xml_text(maker)}</manufacturer>",
    )
    original = device_of(xml)
    with tempfile.TemporaryDirectory() as tmp:
        source, mod = Path(tmp) / "d.xml", Path(tmp) / "d.mod"
        source.write_text(xml, encoding="ascii")
        proc = cli("export", source, "--to", "xif", "-o", mod)
        refused = [
            text
            for text in [original.manufacturer or ""]
            + [fn.name for fn in original.functions]
            + [label for fn in original.functions for label in fn.block_labels]
            if C.line_break(text)
        ]
        if refused:
            assert proc.returncode == 1 and "holds a line break" in proc.stderr, proc
            assert not mod.exists()
            event("refused")
            return
        assert proc.returncode == 0, proc.stderr
        raw = mod.read_bytes().decode("utf-8")
        assert raw.count("\r\n") == 5 + len(texts) and "\n" not in raw.replace("\r\n", "")
        again = cli("import", mod)
    assert again.returncode == 0, again.stderr
    back = device_of(again.stdout)
    assert back.manufacturer == original.manufacturer and back.description == one_line(original.description)
    assert [(fn.name, fn.block_labels, fn.addresses) for fn in back.functions] == [
        (fn.name, fn.block_labels, fn.addresses) for fn in original.functions
    ]
    assert [fn.description for fn in back.functions] == [
        one_line(fn.description) if one_line(fn.description) != fn.name else fn.name for fn in original.functions
    ]
    event("round trip")
