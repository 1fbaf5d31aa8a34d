"""The profiles mdl ships (data/*.yaml) as plain files: which of some names they hold as keys, found
without PyYAML. `mdl csv2xml` asks whether a function of the INI is named after a role; most INIs name
none, and reading every profile (load.shipped_roles) costs more than the rest of a small conversion."""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

DATA = Path(__file__).resolve().parent / "data"
_KEY = re.compile(r"""(?m)^[ \t]*["']?([a-z][a-z0-9_]*)["']?[ \t]*:""")  # a key at the start of its line


def keyed(names: Iterable[str]) -> set[str]:
    """Those of `names` that begin a line of a shipped profile as a key (`  power_w: {unit: W ...}`).
    Every role is such a key (tests/unit/formats/table/test_csv2xml_lazy.py holds it for each), so a
    name not among these is no shipped profile's role; one among them may be one (or another key)."""
    wanted = set(names)
    found: set[str] = set()
    for path in sorted(DATA.glob("*.yaml")) if wanted else []:
        found |= wanted.intersection(_KEY.findall(path.read_text(encoding="utf-8")))
    return found
