"""What a file given where MDL XML was expected looks like, and which command reads it: a CSV table
is `mdl csv2xml`'s, a device INI too, an XIF `.mod`, a Toolkit YAML or a WISE-Agent INI `mdl import`'s.
Asked only when the XML parser has refused a file that does not start with markup."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from mdl.fileio import is_stdin

if TYPE_CHECKING:
    from _typeshed import StrPath

_HEAD = 64 * 1024  # bytes looked at
_ZIP = b"PK\x03\x04"  # an .xlsx workbook (or any zip)
_TABLE_SUFFIXES = (".csv", ".tsv")
_DEVICE_INI = {"[input/output]", "[modbus device]", "[column/field indices]"}  # the sections csv2xml's INI has


def starts_with_markup(data: bytes) -> bool:
    """Whether the bytes begin (after a BOM and blanks) with `<`, as every XML document does."""
    for bom, encoding in ((b"\xef\xbb\xbf", "utf-8"), (b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be")):
        if data.startswith(bom):
            return data[len(bom) :].decode(encoding, errors="replace").lstrip().startswith("<")
    return data.lstrip().startswith(b"<")


def not_xml(data: bytes, path: StrPath) -> str:
    """`not MDL XML: this looks like …; …` for a file that does not start with markup."""
    what, advice = looks_like(data, path)
    return f"not MDL XML (it does not start with '<'): this looks like {what}; {advice}"


def looks_like(data: bytes, path: StrPath) -> tuple[str, str]:
    """What the file looks like, and advice naming the command that reads it."""
    import shlex  # here and json below: only a file that is not what it was given as is looked at so

    name = "-" if is_stdin(path) else shlex.quote(str(path))
    importable = _importable(path)
    if importable is not None:
        return importable, f"`mdl import {name}` converts it to MDL (gen, sim, read and export read it as it is)"
    if not data.strip():
        return "an empty file", "give an MDL document (`mdl csv2xml` makes one from a vendor's register table)"
    head = data[:_HEAD]
    if head.startswith(_ZIP):
        return (
            "a zip archive (an Excel .xlsx workbook?)",
            "save the register table as CSV and convert it with `mdl csv2xml TABLE.csv`",
        )
    text = head.decode("utf-8", errors="replace").lstrip("\ufeff")
    if "\x00" in text:
        return "binary data", "give an MDL document (`mdl csv2xml` makes one from a vendor's register table)"
    first = next((line.strip() for line in text.splitlines() if line.strip() and line.strip()[0] not in "#;"), "")
    if first.startswith("[") and first.endswith("]"):
        sections = {line.strip().lower() for line in text.splitlines() if line.strip().startswith("[")}
        if sections & _DEVICE_INI:
            return "a device INI (csv2xml's)", f"`mdl csv2xml {name}` converts the register table it names"
        return (
            "an INI file",
            f"a device INI goes to `mdl csv2xml {name}`, a WISE-Agent Modbus.ini to `mdl import {name} --from wise`",
        )
    if first[:1] in "{[" and _is_json(text):
        return "a JSON document", "give an MDL document (raw registers in JSON go to `mdl sim --registers`)"
    from mdl.formats.table.readers.delimited import DELIMITER_NAMES, table_delimiter  # what is not MDL: a rare path

    delimiter = table_delimiter(text)
    if delimiter is not None or Path(str(path)).suffix.lower() in _TABLE_SUFFIXES:
        cells = f" (cells separated by {DELIMITER_NAMES[delimiter]}s)" if delimiter else ""
        return (f"a register table{cells}", f"`mdl csv2xml {name} [--ini DEVICE.ini]` converts it to MDL")
    return "plain text", "give an MDL document (`mdl csv2xml` makes one from a vendor's register table)"


def _importable(path: StrPath) -> str | None:
    """What `mdl import` would read this file as (its own guess: mdl.formats.guess_format)."""
    from mdl.formats import guess_format

    return {
        "xif": "an XIF file (SmartServer .mod)",
        "schema": "a Modbus Schema Toolkit YAML file",
        "wise": "a WISE-Agent Modbus.ini",
        "wot": "a W3C WoT Thing Description",
    }.get(guess_format(path) or "")


def _is_json(text: str) -> bool:
    import json

    try:
        json.loads(text)
    except ValueError:
        return False
    return True
