"""Jinja environment, filters that make input text safe in generated code, write-if-changed."""

from __future__ import annotations

import hashlib
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import jinja2
import jinja2.bccache

from mdl import __version__
from mdl.diagnostics import error
from mdl.dsl.cfrag.cemit import float_literal, literal
from mdl.fileio import remove_leftovers, would_change, write_atomic
from mdl.ir.steps import MAX_EXPONENT

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


# Characters a comment must not hold as they are, beyond control characters and line breaks (which
# become a space): the bidirectional controls (Trojan Source, gcc's -Wbidi-chars), the invisible
# format characters (zero-width spaces and joiners, word joiner, BOM, soft hyphen, interlinear
# annotations, tag characters) and the surrogates and noncharacters. A fixed list rather than
# Python's Unicode tables, so that the same input prints the same bytes under every Python version.
_HIDDEN = re.compile(
    "[\u00ad\u061c\u180e\u200b-\u200f\u202a-\u202e\u2060-\u206f\ufeff\ufff9-\ufffb"
    "\ufffe\uffff\ud800-\udfff\U000e0000-\U000e007f]"
)


# printable ASCII that starts and ends with a visible character other than a backslash
_PLAIN = re.compile(r"(?:[!-~][ -~]*)?[!-\[\]-~]")


def ccomment(text: object) -> str:
    """Text for a C or C++ comment (`//` or `/* */`), as written (UTF-8) on one line, that cannot end
    the comment, splice the next line into it or reorder what a reader sees: control characters and
    line breaks become a space, a hidden character (_HIDDEN: bidirectional controls, zero-width ones)
    becomes its code point as text (`<U+202E>`), `*/`, `/*` and the `??/` trigraph get a space
    inside, and a backslash that ends the text becomes U+FF3C (a fullwidth backslash)."""
    text = str(text)
    if _PLAIN.fullmatch(text) and "*/" not in text and "/*" not in text and "??/" not in text:
        return text  # printable ASCII between two visible characters, as most are: nothing to change
    return _ccomment(text)


def _ccomment(text: str) -> str:
    """ccomment of any text (the way every text could take)."""
    text = re.sub(r"\s*[\x00-\x1f\x7f-\x9f\u2028\u2029]+\s*", " ", text).strip()
    text = _HIDDEN.sub(lambda m: f"<U+{ord(m.group()):04X}>", text)
    text = text.replace("*/", "* /").replace("/*", "/ *").replace("??/", "?? /")
    return text[:-1] + "\uff3c" if text.endswith("\\") else text


def _escaped(data: bytes) -> str:
    """Bytes inside a C or C++ string literal: printable ASCII as is, everything else as octal escapes."""
    out = []
    for byte in data:
        ch = chr(byte)
        if ch in '"\\?':
            out.append("\\" + ch)
        elif 0x20 <= byte < 0x7F:
            out.append(ch)
        else:
            out.append(f"\\{byte:03o}")
    return "".join(out)


def cstring(text: object) -> str:
    """A C or C++ string literal: printable ASCII as is, everything else as octal escapes of its UTF-8."""
    return '"' + _escaped(str(text).encode("utf-8")) + '"'


# The longest string literal (in bytes, after concatenation, without its NUL) each language's
# compilers must accept: C99 5.2.4.1 (gcc and clang refuse longer ones under -Wpedantic), and
# C++17 Annex B (clang++ -Wpedantic refuses longer ones).
STRING_LIMIT = {"c": 4095, "c++": 65536}
_CHARS_PER_LINE = 16


def _char(byte: int) -> str:
    """A byte as a C or C++ character constant."""
    if byte in b"'\\":
        return "'\\" + chr(byte) + "'"
    return f"'{chr(byte)}'" if 0x20 <= byte < 0x7F else f"'\\{byte:03o}'"


def ctext(text: str, name: str, lang: str) -> tuple[list[str], str]:
    """Text for C (`lang` "c") or C++ ("c++") code: ([], its string literal) when the literal is
    within STRING_LIMIT; else a declaration of `static const char name[]` initialised character by
    character (no string literal, so no limit applies: every byte of the text is kept) and `name`,
    which the code uses where it would use the literal (it decays to `const char *` alike)."""
    data = text.encode("utf-8")
    if len(data) <= STRING_LIMIT[lang]:
        return [], cstring(text)
    chars = [_char(byte) for byte in data] + ["0"]
    rows = [", ".join(chars[i : i + _CHARS_PER_LINE]) for i in range(0, len(chars), _CHARS_PER_LINE)]
    qualifier = "constexpr" if lang == "c++" else "const"
    return [f"static {qualifier} char {name}[{len(data) + 1}] = {{", *(f"    {row}," for row in rows), "};"], name


def c_int64(value: int) -> str:
    """An int64_t literal for C and C++ (<stdint.h>/<cstdint>): INT64_MIN as `(-INT64_C(...) - 1)`,
    since no literal of it exists (9223372036854775808 is too large for int64_t)."""
    if not -(1 << 63) <= value < 1 << 63:
        raise ValueError(f"{value} is outside int64_t")  # mdl validate refuses such keys before this
    if value == -(1 << 63):
        return "(-INT64_C(9223372036854775807) - 1)"
    return f"INT64_C({value})" if value >= 0 else f"(-INT64_C({-value}))"


def double_literal(x: float, parenthesized: bool = False) -> str:
    """A C, C++ or Python literal of a finite double: the shortest digits that read back as it
    (Python's repr, mdl.dsl.cfrag.cemit.float_literal), an int with all its digits and `.0`; a
    negative one as `(-d)` where `parenthesized`. ValueError for an infinity or NaN, which no literal
    spells (resolve refuses non-finite numbers before a target prints one)."""
    if not math.isfinite(x):
        raise ValueError(f"{x} cannot be a literal")
    return literal(x, "double") if parenthesized else float_literal(x, "double")


# A generation stamp (docs/cpp-api.md): each C or C++ header defines `generation_macro(stem)` as the
# stamp of its run of mdl gen, each source refuses (#error) to compile with any other. The templates
# print GENERATION where the stamp goes; stamp() puts the hash of the run's files there. No input
# text can print it: every text reaches a generated file escaped, and a NUL never as it is.
GENERATION = "\0mdl-generation\0"
STAMP_DIGITS = 12  # 48 bits of SHA-256: an integer constant of every C preprocessor


def generation_macro(stem: str) -> str:
    return f"MDL_{stem.upper().rstrip('_')}_GENERATION"


def stamp(files: dict[str, str]) -> dict[str, str]:
    """The files of one run with the stamp in place: a hash of their names and content (without
    it), so the same input gives the same bytes (SPEC 5) and another input, another stamp."""
    digest = hashlib.sha256()
    for name in sorted(files):
        digest.update(f"{len(name)}:{name}:{len(files[name])}:".encode())
        digest.update(files[name].encode("utf-8"))
    value = "0x" + digest.hexdigest()[:STAMP_DIGITS]
    return {name: text.replace(GENERATION, value) for name, text in files.items()}


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
    env.globals["generation"] = GENERATION
    env.globals["max_exponent"] = MAX_EXPONENT  # of scale_exponent (docs/bits-and-scale.md)
    return env


@dataclass(frozen=True)
class RuntimePart:
    """A piece of a runtime file a driver carries only if its code calls it: the names it defines,
    its source, the names it uses (of other parts, or none) and the headers it needs."""

    names: tuple[str, ...]
    source: str
    uses: frozenset[str]
    includes: tuple[str, ...] = ()


def pick(parts: Sequence[RuntimePart], names: Iterable[str]) -> list[RuntimePart]:
    """The parts defining `names`, and those they use in turn, in `parts`' order (a part after those
    it uses, as the runtime files put them): every runtime a target carries is picked here."""
    by_name = {name: i for i, part in enumerate(parts) for name in part.names}
    wanted: set[int] = set()
    todo = [by_name[name] for name in names if name in by_name]
    while todo:
        i = todo.pop()
        if i not in wanted:
            wanted.add(i)
            todo += [by_name[name] for name in parts[i].uses if name in by_name]
    return [parts[i] for i in sorted(wanted)]


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
    """Write each file whose content changes; with check, write nothing. Returns the changed ones.
    Writing, the hidden temporary files an earlier run killed while writing them left are removed."""
    changed = [path for path, text in outputs.items() if would_change(path, text)]
    if not check:
        for path in outputs:
            remove_leftovers(path)
        for path in changed:
            write_atomic(path, outputs[path])
    return changed


def require_dir(path: Path) -> None:
    if path.exists() and not path.is_dir():
        raise error("not a directory", path)
