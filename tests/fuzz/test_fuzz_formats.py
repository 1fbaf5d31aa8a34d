"""Fuzzing the formats' registry (issue 19): SPEC 1's guess of a file's format, which `mdl import` (and every
command, through mdl.formats.loading) asks mdl.formats for. Random file names and random starts of files, built
from the lines each format is told by (biased to both of them in one file, in any case, after blanks and a
BOM), are guessed as the rule below says: a file name ending `.mod` is XIF and `.yaml`/`.yml` a Toolkit schema
whatever the file holds, else a first line `#filetype,Modbus_xif` is XIF and then a `[Platform]` line
WISE-Agent; nothing else is guessed. `mdl import` without --from then says it cannot tell exactly when the
rule gives nothing, and never fails otherwise than cleanly.

A longer run by hand: MDL_FUZZ_FORMATS=3000 python -m pytest tests/fuzz/test_fuzz_formats.py --exhaustive
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from hypothesis import event, given, settings
from hypothesis import strategies as st

from mdl import exports, formats
from support.run import cli

EXAMPLES = int(os.environ.get("MDL_FUZZ_FORMATS", "150"))
SUFFIXES = [
    ".mod",
    ".MOD",
    ".Mod",
    ".yaml",
    ".YML",
    ".yml",
    ".ini",
    ".INI",
    ".xml",
    ".csv",
    ".txt",
    "",
    ".mod.ini",
    ".yaml.mod",
]
LINES = [
    "#filetype,Modbus_xif",
    "# FileType , MODBUS_XIF",
    "#filetype,modbus_xi",
    "#filetype;Modbus_xif",
    "[Platform]",
    "  [PLATFORM]  ",
    "[Platform",
    "[Coils]",
    "Name=x",
    "<?xml version='1.0'?>",
    "description: x",
    "",
    " ",
    "\t",
    "\ufeff",
    "é",
    "\x00",
    "\xff\xfe",
]
TEXTS = st.lists(st.sampled_from(LINES) | st.text(max_size=12), max_size=6).map("\n".join)
PREFIXES = st.sampled_from([b"", b"\xef\xbb\xbf", b"\n\n", b"  ", b"\xff"])


def rule(name: str, data: bytes) -> str | None:
    """SPEC 1's guess, restated: the file name's ending first, then the file's first line and sections."""
    suffix = Path(name).suffix.lower()
    if suffix == ".mod":
        return "xif"
    if suffix in (".yaml", ".yml"):
        return "schema"
    text = data[: 64 * 1024].decode("utf-8-sig", errors="replace")
    first = text.lstrip().split("\n", 1)[0].strip().lower().replace(" ", "")
    if first.startswith("#filetype,modbus_xif"):
        return "xif"
    if any(line.strip().lower() == "[platform]" for line in text.splitlines()):
        return "wise"
    return None


@settings(max_examples=EXAMPLES, deadline=None)
@given(st.sampled_from(SUFFIXES), PREFIXES, TEXTS)
def test_the_registry_guesses_as_spec_1_says(suffix, prefix, text):
    data = prefix + text.encode("utf-8", errors="surrogatepass")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"device{suffix}"
        path.write_bytes(data)
        expected = rule(path.name, data)
        event(f"guessed {expected}")
        assert formats.guess_format(path) == expected
        proc = cli("import", str(path), "-o", str(Path(tmp) / "out.xml"))
    assert proc.returncode in (0, 1) and "Traceback" not in proc.stderr, (proc.returncode, proc.stderr)
    assert ("cannot tell the format" in proc.stderr) == (expected is None), proc.stderr


def test_a_file_name_decides_before_the_file_and_xif_before_wise(tmp_path):
    """A control of the rule's order, which the random files reach only now and then."""
    both = b"#filetype,Modbus_xif\n[Platform]\n"
    cases = {
        "a.yaml": (both, "schema"),
        "a.mod": (b"[Platform]\n", "xif"),
        "a.ini": (both, "xif"),
        "b.ini": (b"; x\n[platform]\n", "wise"),
        "a.xml": (b"<device/>", None),
    }
    for name, (data, expected) in cases.items():
        (tmp_path / name).write_bytes(data)
        assert formats.guess_format(tmp_path / name) == expected == rule(name, data), name
    assert formats.guess_format(tmp_path / "missing.mod") == "xif"  # the name alone: the reader says it is missing
    assert formats.guess_format(tmp_path / "missing.txt") is None
    assert formats.guess_format("-") is None  # standard input is read once, by the format --from names


def test_the_registry_gives_import_and_export_their_choices():
    """`mdl import --from` offers every format, `mdl export --to` the formats that write and then the engines."""
    assert formats.names() == ["xif", "wise", "schema", "sunspec", "wot"]
    assert list(exports.outputs()) == [
        "xif",
        "wise",
        "senml",
        "volttron",
        "homeassistant",
        "telegraf",
        "esphome",
        "thingsboard",
        "wot",
        "nodered",
    ]
    for command, names in (("import", formats.names()), ("export", list(exports.outputs()))):
        proc = cli(command, "--help")
        assert f"[{'|'.join(names)}]" in " ".join(proc.stdout.split()), proc.stdout
