"""Load any device description a command accepts (MDL XML, or a format of mdl.formats: a Toolkit YAML
file, a SmartServer XIF `.mod`, a WISE-Agent `Modbus.ini`) as the document model (`load_any`), or model
and resolve step in one (`load_resolved`), as every command does."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mdl.diagnostics import error
from mdl.fileio import is_stdin
from mdl.formats import by_name, guess_format, names
from mdl.formats.mdl.load import read_device

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.model import Device
    from mdl.resolver import ResolvedDevice


def import_format(path: StrPath) -> str:
    """The format `mdl import` reads the file as (guess_format), or an error saying what the file is
    and which command reads it (a register table is csv2xml's, MDL XML needs no import)."""
    fmt = guess_format(path)
    if fmt is not None:
        return fmt
    *first, last = names()
    give = f"give --from {', '.join(first)} or {last}"
    if is_stdin(path):
        raise error(f"cannot tell the format of standard input; {give}", path)
    from mdl.fileio import read_bytes
    from mdl.formats.sniff import looks_like, starts_with_markup

    data = read_bytes(path, limit=64 * 1024)[: 64 * 1024]  # a missing or unreadable file: its own error
    if starts_with_markup(data):
        raise error(
            "cannot tell the format: this looks like XML, and mdl import reads XIF, WISE-Agent and "
            "Toolkit files, none of them XML; MDL needs no import: every command reads it as it is",
            path,
        )
    what, advice = looks_like(data, path)
    raise error(f"cannot tell the format: this looks like {what}; {advice}; or {give}", path)


def load_any(path: StrPath, fmt: str | None = None) -> Device:
    """The document model of the file in format `fmt` (one of mdl.formats.names(); None: guessed from the
    file, MDL XML where nothing else fits); MdlError for what its own format refuses (syntax, XSD)."""
    fmt = fmt or guess_format(path)
    return by_name(fmt).read(path) if fmt is not None else read_device(path)


def load_resolved(path: StrPath, fmt: str | None = None) -> ResolvedDevice:
    """The file's model through `mdl.resolver.resolve`: MdlError with every error (file:line:col), or
    the resolved device with its warnings, for the caller to print once."""
    from mdl.resolver import resolve

    return resolve(load_any(path, fmt), str(path))
