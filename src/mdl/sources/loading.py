"""Load any device description a command accepts: MDL XML, or a Toolkit YAML file."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from mdl.model import Device
from mdl.sources.mdlxml import load_device

if TYPE_CHECKING:
    from _typeshed import StrPath


def is_yaml(path: StrPath) -> bool:
    return Path(path).suffix.lower() in (".yaml", ".yml")


def load_any(path: StrPath) -> Device:
    if is_yaml(path):
        from mdl.sources.toolkit import import_schema

        return import_schema(path)
    return load_device(path)
