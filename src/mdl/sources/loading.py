"""Load any device description a command accepts (MDL XML, or a Toolkit YAML file) as the document
model (`load_any`), or model and resolve step in one (`load_resolved`), as every command does."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from mdl.model import Device
from mdl.sources.mdlxml.load import read_device

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.resolve import ResolvedDevice


def is_yaml(path: StrPath) -> bool:
    return Path(path).suffix.lower() in (".yaml", ".yml")


def load_any(path: StrPath, fmt: str | None = None) -> Device:
    """The document model of the file (`fmt` "schema": a Toolkit file whatever its name); MdlError for
    what its own format refuses (syntax, XSD)."""
    if fmt == "schema" or is_yaml(path):
        from mdl.sources.toolkit import read_schema

        return read_schema(path)
    return read_device(path)


def load_resolved(path: StrPath, fmt: str | None = None) -> ResolvedDevice:
    """The file's model through `mdl.resolve.resolve`: MdlError with every error (file:line:col), or
    the resolved device with its warnings, for the caller to print once."""
    from mdl.resolve import resolve

    return resolve(load_any(path, fmt), str(path))
