"""Locate schema/: inside an installed wheel (mdl/schema) or a source checkout."""

from __future__ import annotations

from pathlib import Path

_PKG = Path(__file__).resolve().parent


def resource_dir(name: str) -> Path:
    for candidate in (_PKG / name, _PKG.parent.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"mdl installation is missing its {name}/ directory")


def schema_path(version: str) -> Path:
    return resource_dir("schema") / f"mdl-{version}.xsd"
