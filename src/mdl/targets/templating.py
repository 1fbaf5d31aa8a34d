"""Jinja environment, filters that make input text safe in generated code, write-if-changed."""

from __future__ import annotations

import re
from pathlib import Path

import jinja2

from mdl.diagnostics import error
from mdl.fileio import would_change, write_atomic

# each target's templates are under <target>/templates/ here
TARGETS_DIR = Path(__file__).resolve().parent


def pyrepr(value: object) -> str:
    """A Python literal; strings are pure ASCII with escapes."""
    if isinstance(value, str):
        return ascii(value)
    return repr(value)


def _ascii_line(text: object) -> str:
    """The text as one line of ASCII: other characters as backslash escapes, control characters as spaces."""
    escaped = str(text).encode("ascii", "backslashreplace").decode("ascii")
    return re.sub(r"[\x00-\x1f\x7f]+", " ", escaped).strip()


def pycomment(text: object) -> str:
    """Text safe inside a one-line comment or a docstring: ASCII, no line breaks, no quotes run."""
    return _ascii_line(text).replace('"""', "'''").replace("\\", "\\\\")


def ccomment(text: object) -> str:
    """Text for a C or C++ comment (`//` or `/* */`), as written (UTF-8) on one line, that cannot end
    the comment or splice the next line into it: control characters and line breaks become a space,
    `*/`, `/*` and the `??/` trigraph get a space inside, and a backslash that ends the text becomes
    U+FF3C (a fullwidth backslash)."""
    text = re.sub(r"\s*[\x00-\x1f\x7f-\x9f\u2028\u2029]+\s*", " ", str(text)).strip()
    text = text.replace("*/", "* /").replace("/*", "/ *").replace("??/", "?? /")
    return text[:-1] + "\uff3c" if text.endswith("\\") else text


def cstring(text: object) -> str:
    """A C or C++ string literal: printable ASCII as is, everything else as octal escapes of its UTF-8."""
    out = []
    for byte in str(text).encode("utf-8"):
        ch = chr(byte)
        if ch in '"\\?':
            out.append("\\" + ch)
        elif 0x20 <= byte < 0x7F:
            out.append(ch)
        else:
            out.append(f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TARGETS_DIR)),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters["pyrepr"] = pyrepr
    env.filters["pycomment"] = pycomment
    env.filters["ccomment"] = ccomment
    env.filters["cstring"] = cstring
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
