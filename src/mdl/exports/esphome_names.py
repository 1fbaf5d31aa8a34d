"""Text as ESPHome reads it, for `mdl export --to esphome` (docs/fleet.md, "ESPHome").

ESPHome expands `$name`, `${...}` and `<% ... %>` in every string of a configuration (its substitutions
and Jinja pass runs on every file, with no escape for a literal `$`), refuses `/` in a name and names
longer than 120 bytes, reads the names `None`/`none` as no name, and refuses two entities of one
platform whose object ids (the name in lower case, spaces and every character but ASCII letters,
digits, `-` and `_` as `_`: esphome.helpers snake_case and sanitize) are equal. `Names` writes each
entity's name so that ESPHome keeps it, and says every change with a warning naming the function.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mdl.exports.base import Notes
    from mdl.resolver import ResolvedFunction

NAME_MAX_BYTES = 120  # esphome.config_validation NAME_MAX_LENGTH, and FRIENDLY_NAME_MAX_LEN
UNIT_MAX_BYTES = 63  # esphome.core.config UNIT_OF_MEASUREMENT_MAX_LENGTH
NODE_NAME_MAX = 31  # esphome.core.config validate_hostname
_NOT_ID = re.compile(r"[^a-zA-Z0-9\-_]")
_EXPANDED = re.compile(r"\$|<%")  # what ESPHome's substitution pass reads (esphome/expression.py)


def object_id(name: str) -> str:
    """The object id ESPHome checks names of one platform by (esphome.helpers snake_case, sanitize)."""
    return _NOT_ID.sub("_", name.replace(" ", "_").lower())


def inert(text: str) -> str:
    """`text` with nothing ESPHome's substitution pass expands: `$` as U+FF04 (＄), `<%` as `<％`."""
    return _EXPANDED.sub(lambda m: "\uff04" if m.group(0) == "$" else "<\uff05", text)


def fit_bytes(text: str, limit: int) -> str:
    """`text` cut to at most `limit` UTF-8 bytes, at a character boundary."""
    data = text.encode("utf-8")
    return text if len(data) <= limit else data[:limit].decode("utf-8", "ignore")


def node_name(stem: str) -> str:
    """The node's name (a hostname: a-z, 0-9 and '-', at most 31 characters) from the description's stem."""
    name = re.sub(r"[^a-z0-9]+", "-", stem.lower()).strip("-")[:NODE_NAME_MAX].strip("-")
    return name or "mdl-device"


def display_name(text: str) -> tuple[str, list[str]]:
    """A name or friendly_name as ESPHome keeps it, and what was changed (empty when nothing was)."""
    changes = []
    out = inert(text)
    if out != text:
        changes.append("'$' and '<%' (ESPHome expands them) as '\uff04' and '<\uff05'")
    if "/" in out:
        out = out.replace("/", "\u2215")
        changes.append("'/' (refused in a name) as '\u2215'")
    cut = fit_bytes(out, NAME_MAX_BYTES)
    if cut != out:
        out = cut
        changes.append(f"cut to {NAME_MAX_BYTES} bytes")
    if out in ("None", "none", ""):
        out = f"{out}_" if out else "unnamed"
        changes.append("a name ESPHome reads as no name")
    return out, changes


class Names:
    """Each entity's name, unique by object id within its platform, every change said."""

    def __init__(self, notes: Notes) -> None:
        self.notes = notes
        self.taken: set[tuple[str, str]] = set()

    def name(self, f: ResolvedFunction, platform: str) -> str:
        out, changes = display_name(f.name)
        base, number = out, 1
        while (platform, object_id(out)) in self.taken:
            number += 1
            suffix = f" {number}"
            out = fit_bytes(base, NAME_MAX_BYTES - len(suffix)) + suffix
        if number > 1:
            changes.append(f"numbered: another {platform}'s name has the same object id {object_id(base)!r}")
        self.taken.add((platform, object_id(out)))
        if changes:
            self.notes.warn(f, "its name is written as ESPHome keeps it", f"as {out!r}: " + "; ".join(changes))
        return out
