"""Regular expressions compiled when first used. Compiling the notations the table readers know (units,
scale forms, address forms, clause marks) costs every run more than reading a table of a hundred
rows, and most tables need few of them."""

from __future__ import annotations

import re
from collections.abc import Callable
from functools import cache


def lazy(pattern: str, flags: int = 0) -> Callable[[], re.Pattern[str]]:
    """`pattern` as a function that compiles it on the first call and returns it from then on."""
    return cache(lambda: re.compile(pattern, flags))
