"""Jinja environment, filters that make input text safe in generated code, write-if-changed."""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Callable, Iterable
from functools import cache
from pathlib import Path
from typing import Any

import jinja2
import jinja2.bccache

from mdl import __version__
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


def _memoized(function: Callable[[object], str]) -> Callable[[object], str]:
    """`function` of a string, computed once per distinct string (for as long as the environment lives)."""
    done: dict[object, str] = {}

    def memoized(text: object) -> str:
        if not isinstance(text, str):
            return function(text)
        found = done.get(text)
        if found is None:
            found = done[text] = function(text)
        return found

    return memoized


def each(items: Iterable[object], pattern: str, sep: str) -> str:
    """Each item through a %-pattern, joined by sep: `[0, 1] | each("raw[%d]", ", ")` is
    `raw[0], raw[1]` (one filter call where a loop would cost one step per item)."""
    return sep.join([pattern % (item,) for item in items])


# how the templates are read: the compiled templates in the cache depend on it too
_OPTIONS: dict[str, Any] = dict(trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True, autoescape=False)


class _TemplateCache(jinja2.FileSystemBytecodeCache):
    """Compiled templates kept between runs (compiling them took 0.07 s per target at every `mdl
    gen`). Jinja checks each one against its template's source and the Python version; the folder
    is named for mdl's and Jinja's versions and the options. A cache that cannot be read or written
    is no cache: nothing fails for it."""

    def load_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        try:
            super().load_bytecode(bucket)
        except OSError:
            bucket.reset()

    def dump_bytecode(self, bucket: jinja2.bccache.Bucket) -> None:
        try:
            super().dump_bytecode(bucket)
        except OSError:
            pass


@cache
def _template_cache() -> _TemplateCache | None:
    """`$XDG_CACHE_HOME/mdl/templates/<key>` (`~/.cache/...` without it), made if need be; None
    where it cannot be."""
    try:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
        key = hashlib.sha256(repr((__version__, jinja2.__version__, sorted(_OPTIONS.items()))).encode()).hexdigest()
        folder = base / "mdl" / "templates" / key[:16]
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
    except (OSError, RuntimeError):  # RuntimeError: no home directory
        return None
    return _TemplateCache(str(folder))


def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TARGETS_DIR)),
        undefined=jinja2.StrictUndefined,
        bytecode_cache=_template_cache(),
        **_OPTIONS,
    )
    # `a.b` in a template is Python's own attribute lookup, done in C: the contexts hold objects
    # (dataclasses, tuples), never dicts read with a dot. Jinja's lookup, a Python method that falls
    # back to `a["b"]`, was a tenth of rendering a large device. A missing attribute still fails.
    env.getattr = getattr  # type: ignore[method-assign, assignment]
    env.filters["pyrepr"] = pyrepr
    env.filters["pycomment"] = pycomment
    env.filters["ccomment"] = _memoized(ccomment)  # a description goes into several comments
    env.filters["cstring"] = cstring
    env.filters["each"] = each
    return env


class SharedRendering:
    """A template macro that prints part of one function from its arguments alone (the steps of its
    IR and a few facts about it, never its name or addresses), called once per distinct argument
    list: a device's functions repeat a few shapes of IR (10,000 functions of a meter are some ten
    shapes), so each shape is printed once, not once per function.

    Called as `shared(shape, steps, *rest)`: `shape` is the steps as text
    (`ResolvedFunction.decode_shape`/`encode_shape`), None to print without sharing (a fragment or
    an expression); the rest must be values whose repr says all the macro prints from them (strings,
    numbers, None, bools, lists of them, small dataclasses of them)."""

    def __init__(self, macro: Callable[..., str]) -> None:
        self.macro = macro
        self.cache: dict[tuple[str, str], str] = {}

    def __call__(self, shape: str | None, steps: object, *rest: object) -> str:
        if shape is None:
            return self.macro(steps, *rest)
        key = (shape, repr(rest))
        text = self.cache.get(key)
        if text is None:
            text = self.cache[key] = self.macro(steps, *rest)
        return text


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
