"""The device description formats other than MDL, one package per format (SPEC 7): `xif/` (SmartServer
`.mod`), `wise/` (WISE-Agent `Modbus.ini`), `toolkit/` (Modbus Schema Toolkit YAML, the format
`schema`), `sunspec/` (SunSpec model definitions, read only) and `wot/` (W3C WoT Thing Descriptions with
Modbus forms, read only; the export is mdl.exports.wot), each with its
`read.py` (a file -> the document model) and, where the format is an output too, its `write.py` (a
resolved device -> an mdl.exchange.export.Export).

FORMATS is the one registry of them: it gives `mdl import --from` its choices, `mdl export --to` those of
the formats that write (before the engines'), and SPEC 1's guess of a file's format (`guess_format`,
which every command reading a description uses through mdl.formats.loading). A format's reader and
writer are imported when first called, so that commands start fast.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from mdl.fileio import is_stdin
from mdl.formats import wise, wot, xif
from mdl.records import record
from mdl.registry import Registry, lazy

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.exchange.export import Writer
    from mdl.model import Device
    from mdl.resolver import ResolvedDevice

Reader = Callable[["StrPath"], "Device"]
HEAD_BYTES = 64 * 1024  # what guess_format reads of a file


@record
class Format:
    """A description format: its `--from`/`--to` name, the line `mdl export --help` gives it, its reader,
    its writer (None: read only), how its file is recognised (`suffixes`: file name endings that decide;
    `guess`: whether the start of a file, as text, is this format), and what `mdl import` writes of the
    resolved file (`imported`; None: its model as it is)."""

    name: str
    summary: str
    read: Reader
    write: Writer | None = None
    guess: Callable[[str], bool] | None = None
    suffixes: tuple[str, ...] = ()
    imported: Callable[[ResolvedDevice], Device] | None = None

    def to_mdl(self, resolved: ResolvedDevice) -> Device:
        """The model `mdl import` writes as MDL."""
        return self.imported(resolved) if self.imported is not None else resolved.device


FORMATS: Registry[Format] = Registry(
    Format(
        "xif",
        "SmartServer Modbus XIF (.mod)",
        lazy("mdl.formats.xif.read", "read_xif"),
        lazy("mdl.formats.xif.write", "export_xif"),
        xif.guess,
        (".mod",),
    ),
    Format(
        "wise",
        "WISE-Agent Modbus.ini (the shipped agent's form)",
        lazy("mdl.formats.wise.read", "read_wise"),
        lazy("mdl.formats.wise.write", "export_wise"),
        wise.guess,
    ),
    Format(
        "schema",
        "Modbus Schema Toolkit YAML",
        lazy("mdl.formats.toolkit.read", "read_schema"),
        suffixes=(".yaml", ".yml"),
        imported=lazy("mdl.formats.toolkit.read", "with_registers"),
    ),
    Format(
        "sunspec",
        "SunSpec model definitions (pysunspec2's JSON: model ids or files; SPEC 12)",
        lazy("mdl.formats.sunspec.read", "read_sunspec"),
    ),
    Format(
        "wot",
        "a W3C WoT Thing Description with Modbus forms",
        lazy("mdl.formats.wot.read", "read_wot"),
        guess=wot.guess,
        suffixes=(".jsonld",),
    ),
)


def names() -> list[str]:
    """Every format's name, in the registry's order (`mdl import --from`)."""
    return FORMATS.names()


def by_name(name: str) -> Format:
    """The format called `name` (one of `names()`; KeyError otherwise)."""
    return FORMATS[name]


def guess_format(path: StrPath) -> str | None:
    """The format SPEC 1 tells from the file: a file name ending one format claims (`.mod` XIF, `.yaml`/
    `.yml` a Toolkit schema, `.jsonld` a WoT TD) decides, else the first format whose `guess` takes the
    file's first 64 KiB (a first line `#filetype,Modbus_xif` is XIF, an INI with a `[Platform]` section
    WISE-Agent, a JSON object naming `modbus+tcp://` or `modv:` a TD); None otherwise (MDL XML, for the
    commands that read it)."""
    p = Path(path)
    if is_stdin(p):  # read once, by the reader of its format: standard input is MDL XML unless --from says
        return None
    suffix = p.suffix.lower()
    for f in FORMATS.values():
        if suffix in f.suffixes:
            return f.name
    try:
        with open(p, "rb") as file:
            head = file.read(HEAD_BYTES)
    except OSError:
        return None
    text = head.decode("utf-8-sig", errors="replace")
    for f in FORMATS.values():
        if f.guess is not None and f.guess(text):
            return f.name
    return None
