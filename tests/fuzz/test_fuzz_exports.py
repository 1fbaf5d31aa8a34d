"""Fuzzing every export with hostile text (issue 27): random device names, function names, descriptions, units
and enumeration labels, biased to what ends a comment, a string, a line or a cell early (line breaks of every
kind, quotes, backslashes, `]]`, `#`, `=`, `;`, `,`, formula characters...). Each export is parsed by its
format's own parser and must have the structure meant with every text back (tests/unit/exports/test_hostile_exports.py's
checks), or the description is refused cleanly (exit 1, no traceback) by validate and every export alike.

A longer run by hand: MDL_FUZZ_EXPORTS=3000 python -m pytest tests/fuzz/test_fuzz_exports.py --exhaustive
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from support.hostile_exports import FORMULA, HOSTILE, Fn, export, run_all, write_device
from support.run import assert_clean_error, cli

PIECES = [
    "\n",
    "\r",
    "\r\n",
    "\x85",
    "\u2028",
    "\u2029",
    "\x0b",
    "\x0c",
    '"',
    "'",
    "\\",
    "\\n",
    "]]",
    "[[",
    "[",
    "]",
    "#",
    "=",
    ";",
    ",",
    ":",
    "- ",
    "!",
    "&",
    "{{",
    "%",
    "\t",
    " ",
    "\x7f",
    "\x9b",
    "\ufeff",
    "\u202e",
    "\xa0",
    "é",
    "°C",
    "\U0001f600",
    "[Coils]",
    "numberOfR=",
    "[[outputs.exec]]",
    "shell_command:",
    *FORMULA,
    *HOSTILE,
]


# characters an XML 1.0 document can hold (as character references): no surrogates, no U+FFFE/U+FFFF, of C0 only
# tab, line feed and carriage return; astral ones too
CHARS = st.characters(min_codepoint=0x20, max_codepoint=0xFFFD, blacklist_categories=("Cs",)) | st.sampled_from(
    "\t\n\r\U0001f600\U000e0001\U0010fffd"
)
TEXT = st.lists(st.one_of(st.sampled_from(PIECES), st.text(CHARS, max_size=3)), max_size=5).map("".join)
FUNCTION = st.builds(
    Fn, name=TEXT, description=TEXT, units=st.none() | TEXT, values=st.dictionaries(st.integers(0, 9), TEXT, max_size=2)
)
DEVICES = st.tuples(TEXT, st.lists(FUNCTION, min_size=1, max_size=4, unique_by=lambda f: f.name))


def _check(name: str, functions: list[Fn]) -> str:
    """'exported' when every export read back as meant, 'refused' when the description was refused cleanly."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = write_device(folder / "d.xml", name, functions)
        if cli("validate", path).returncode != 0:
            for fmt in ("telegraf", "homeassistant", "senml", "wise", "esphome", "thingsboard"):
                assert_clean_error(export(path, fmt), 1, str(path))
            return "refused"
        run_all(path, folder)
        return "exported"


@settings(
    max_examples=int(os.environ.get("MDL_FUZZ_EXPORTS", "150")),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(DEVICES)
@example(("a\x85\n[[outputs.exec]]", [Fn("=1+1", "-x", "\u2028", {1: '"]]\\'})]))
@example(("", [Fn("", "", "")]))
def test_fuzz_every_export_reads_back(device):
    event(_check(*device))


def test_fuzz_controls():
    """Both outcomes happen: a hostile description exports, a description with two functions of one name is
    refused (exit 1) by validate and every export alike."""
    assert _check("Dev\n#", [Fn("a\x85b", "=x", "\r")]) == "exported"
    assert _check("Dev", [Fn("same"), Fn("same")]) == "refused"
