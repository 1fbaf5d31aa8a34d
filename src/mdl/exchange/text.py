"""Text in outputs: what MDL (XML 1.0) cannot carry (`unwritable`), and the encoders every writer of
another format uses (docs/fleet.md, "Text in exports": `comment_text`, `toml_string`, `json_text`,
`spreadsheet_cell`; YAML's in mdl.exports.homeassistant), so that no name, unit or description can end a
comment, a string or a cell early and become configuration of its own.

Printable: what str.isprintable() says (every character but the Unicode "Other" and "Separator" ones,
space excepted): so control characters (C0, DEL, C1 with NEL U+0085), the line and paragraph separators
U+2028/U+2029, format characters (bidi overrides, U+FEFF) and unassigned code points are escaped.
"""

from __future__ import annotations

import functools
import json
import re
from collections.abc import Sequence

from mdl.diagnostics import one_line


@functools.cache
def _not_xml() -> re.Pattern[str]:
    """What XML 1.0 cannot carry, not even as a character reference (its production Char); compiled when
    first asked (it takes milliseconds, which commands that write no MDL need not spend)."""
    return re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def unwritable(text: str) -> str | None:
    """The first character of `text` that no MDL (XML 1.0) document can hold, as `U+001B`; None if none."""
    m = _not_xml().search(text)
    return f"U+{ord(m.group(0)):04X}" if m else None


def _escaped(ch: str) -> str:
    return repr(ch)[1:-1]  # \x85, \u2028, \U000e0001: Python's escape of a character that does not print


def comment_text(text: str) -> str:
    """`text` for a comment line of a configuration file (`# ...`, `; ...`): one line that nothing ends
    early. Control characters and line breaks of every kind (one_line's) and anything else that does not
    print are written as Python escapes (`\\n`, `\\x85`, `\\u2028`); the rest as it is."""
    text = one_line(text)
    return text if text.isprintable() else "".join(ch if ch.isprintable() else _escaped(ch) for ch in text)


_TOML_SHORT = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _toml_char(ch: str) -> str:
    short = _TOML_SHORT.get(ch)
    if short is not None:
        return short
    if ch.isprintable():
        return ch
    return f"\\u{ord(ch):04X}" if ord(ch) < 0x10000 else f"\\U{ord(ch):08X}"


def toml_string(text: str) -> str:
    """`text` as a TOML basic string ("..."): quotes, backslashes, control characters and every character
    that does not print (NEL, U+2028, ...) escaped, so that the string ends where it should and reads back
    as `text` exactly."""
    return '"' + "".join(map(_toml_char, text)) + '"'


def _json_char(ch: str) -> str:
    if ch.isprintable() or ch == "\n":  # "\n": json.dumps escapes it in strings; a raw one is indentation
        return ch
    code = ord(ch)
    if code < 0x10000:
        return f"\\u{code:04x}"
    code -= 0x10000
    return f"\\u{0xD800 + (code >> 10):04x}\\u{0xDC00 + (code & 0x3FF):04x}"


def json_text(value: object, indent: int) -> str:
    """`value` as JSON (a last line break included): text as it is, except what does not print (U+2028 and
    U+2029, which end a line in JavaScript, NEL, other controls), which is escaped like the controls
    json.dumps escapes itself."""
    text = json.dumps(value, indent=indent, ensure_ascii=False)
    if not text.replace("\n", "").isprintable():
        text = "".join(map(_json_char, text))
    return text + "\n"


FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")  # what a spreadsheet reads as a formula (OWASP, CSV injection)


def spreadsheet_cell(text: str) -> str:
    """A CSV cell that a spreadsheet shows as text: one starting with a formula character (FORMULA_STARTS)
    gets a single quote in front, as OWASP says (the caller warns: the cell has changed)."""
    return "'" + text if text.startswith(FORMULA_STARTS) else text


@functools.cache
def yaml_dumper() -> type:
    """The YAML dumper of every YAML export (Home Assistant, ESPHome): PyYAML's safe dumper, except that
    text holding a character that does not print is double-quoted. In its other styles PyYAML writes
    NEL, U+2028 and U+2029 as they are, and they read back as line breaks (folded into a space), a
    different text; double-quoted, they are escapes (`\\x85`). Built on first use (PyYAML imported then)."""
    import yaml

    class Dumper(yaml.SafeDumper):
        pass

    def text(dumper: yaml.SafeDumper, data: str) -> yaml.ScalarNode:
        return dumper.represent_scalar("tag:yaml.org,2002:str", data, style=None if data.isprintable() else '"')

    Dumper.add_representer(str, text)
    return Dumper


def aligned(rows: Sequence[Sequence[str]]) -> list[str]:
    """The one table printer of the commands' text output (`mdl read`, `mdl discover`, `mdl profiles`):
    each row a line, its cells two spaces apart, every column but the last padded to its widest cell, the
    last as it is."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]) - 1)] if rows else []
    return ["  ".join([*(c.ljust(w) for c, w in zip(row[:-1], widths, strict=True)), row[-1]]) for row in rows]
