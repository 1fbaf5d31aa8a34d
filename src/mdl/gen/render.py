"""Jinja environment, filters that make input text safe in generated code, write-if-changed."""

from __future__ import annotations

import re
from pathlib import Path

import jinja2

from mdl.diagnostics import error
from mdl.fileio import would_change, write_atomic
from mdl.resources import resource_dir


def pyrepr(value) -> str:
    """A Python literal; strings are pure ASCII with escapes."""
    if isinstance(value, str):
        return ascii(value)
    return repr(value)


def pycomment(text) -> str:
    """Text safe inside a one-line comment or a docstring: ASCII, no line breaks, no quotes run."""
    text = str(text).encode("ascii", "backslashreplace").decode("ascii")
    text = re.sub(r"[\x00-\x1f\x7f]+", " ", text).strip()
    return text.replace('"""', "'''").replace("\\", "\\\\")


def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(resource_dir("templates"))),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters["pyrepr"] = pyrepr
    env.filters["pycomment"] = pycomment
    return env


def write_outputs(outputs: dict[Path, str], check: bool) -> list[Path]:
    """Write each file whose content changes; with check, write nothing. Returns the changed ones."""
    changed = [path for path, text in outputs.items() if would_change(path, text)]
    if not check:
        for path in changed:
            write_atomic(path, outputs[path])
    return changed


def require_dir(path: Path) -> None:
    if path.exists() and not path.is_dir():
        raise error("not a directory", path)
