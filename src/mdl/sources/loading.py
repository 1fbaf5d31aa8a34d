"""Load any device description a command accepts (MDL XML, a Toolkit YAML file, a SmartServer XIF
`.mod`, a WISE-Agent `Modbus.ini`) as the document model (`load_any`), or model and resolve step in
one (`load_resolved`), as every command does."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from mdl.diagnostics import error
from mdl.fileio import is_stdin
from mdl.model import Device
from mdl.sources.mdlxml.load import read_device

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.resolve import ResolvedDevice


def is_yaml(path: StrPath) -> bool:
    return Path(path).suffix.lower() in (".yaml", ".yml")


IMPORT_FORMATS = ("xif", "wise", "schema")  # what `mdl import --from` reads


def guess_format(path: StrPath) -> str | None:
    """The format SPEC 1 tells from the file: `.mod` or a first line `#filetype,Modbus_xif` is XIF,
    `.yaml`/`.yml` a Toolkit schema, an INI with a `[Platform]` section WISE-Agent; None otherwise
    (MDL XML, for the commands that read it)."""
    p = Path(path)
    if is_stdin(p):  # read once, by the reader of its format: standard input is MDL XML unless --from says
        return None
    if p.suffix.lower() == ".mod":
        return "xif"
    if is_yaml(p):
        return "schema"
    try:
        with open(p, "rb") as f:
            head = f.read(64 * 1024)
    except OSError:
        return None
    text = head.decode("utf-8-sig", errors="replace")
    first = text.lstrip().split("\n", 1)[0].strip().lower().replace(" ", "")
    if first.startswith("#filetype,modbus_xif"):
        return "xif"
    if any(line.strip().lower() == "[platform]" for line in text.splitlines()):
        return "wise"
    return None


def import_format(path: StrPath) -> str:
    """The format `mdl import` reads the file as (guess_format), or an error saying what the file is
    and which command reads it (a register table is csv2xml's, MDL XML needs no import)."""
    fmt = guess_format(path)
    if fmt is not None:
        return fmt
    give = "give --from xif, wise or schema"
    if is_stdin(path):
        raise error(f"cannot tell the format of standard input; {give}", path)
    from mdl.fileio import read_bytes
    from mdl.sources.mdlxml.sniff import looks_like, starts_with_markup

    data = read_bytes(path, limit=64 * 1024)[:64 * 1024]  # a missing or unreadable file: its own error
    if starts_with_markup(data):
        raise error("cannot tell the format: this looks like XML, and mdl import reads XIF, WISE-Agent and "
                    "Toolkit files, none of them XML; MDL needs no import: every command reads it as it is", path)
    what, advice = looks_like(data, path)
    raise error(f"cannot tell the format: this looks like {what}; {advice}; or {give}", path)


def load_any(path: StrPath, fmt: str | None = None) -> Device:
    """The document model of the file in format `fmt` (one of IMPORT_FORMATS; None: guessed from the
    file, MDL XML where nothing else fits); MdlError for what its own format refuses (syntax, XSD)."""
    fmt = fmt or guess_format(path)
    if fmt == "schema":
        from mdl.sources.toolkit import read_schema

        return read_schema(path)
    if fmt == "xif":
        from mdl.sources.xif.read import read_xif

        return read_xif(path)
    if fmt == "wise":
        from mdl.sources.wise.read import read_wise

        return read_wise(path)
    return read_device(path)


def load_resolved(path: StrPath, fmt: str | None = None) -> ResolvedDevice:
    """The file's model through `mdl.resolve.resolve`: MdlError with every error (file:line:col), or
    the resolved device with its warnings, for the caller to print once."""
    from mdl.resolve import resolve

    return resolve(load_any(path, fmt), str(path))
