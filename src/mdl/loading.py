"""Load any device description a command accepts: MDL XML, or a Toolkit YAML file."""

from __future__ import annotations

from pathlib import Path

from mdl.mdlxml import load_device
from mdl.model import Device


def is_yaml(path) -> bool:
    return Path(path).suffix.lower() in (".yaml", ".yml")


def load_any(path) -> Device:
    if is_yaml(path):
        from mdl.formats.toolkit import import_schema

        return import_schema(path)
    return load_device(path)
