"""The document readers of `mdl csv2xml` are linear (issue 34): each pattern that once made one of
them quadratic (an emphasis mark or bracket left open in a Markdown cell, an HTML tag, quoted value
or comment left open, a rowspan layout over many columns) is read at a size N and at 8N; the work
(the best of three runs) may grow by 8, not by the 64 a quadratic reader takes. No clock limit: a
ratio between two sizes of the same input, with room for a noisy machine."""

from __future__ import annotations

import time
import tracemalloc
from collections.abc import Callable

import pytest

from mdl.formats.table.readers.html import grid, html_tables
from mdl.formats.table.readers.markdown import shown

GROWTH = 8  # the larger input is this many times the smaller
ALLOWED = 20  # linear work grows by about GROWTH; quadratic by GROWTH**2
TABLE = "<table><tr><td>x</td></tr></table>"


def _rowspans(n: int) -> object:
    rows = 40
    return html_tables(
        "<table><tr><td>a" + f"<td rowspan={rows}>x<td>z" * (n // 20) + "<tr><td>y" * (rows - 1) + "</table>"
    )[0]


# (name, the input of size n, what reads it)
PATTERNS: list[tuple[str, Callable[[int], object], Callable[[object], object]]] = [
    ("markdown **a", lambda n: "**a " * (n // 4), shown),
    ("markdown *a", lambda n: "*a " * (n // 3), shown),
    ("markdown _a", lambda n: " _a" * (n // 3), shown),
    ("markdown [", lambda n: "[" * n, shown),
    ("markdown [x](", lambda n: "[x](" * (n // 4), shown),
    ("markdown backticks", lambda n: "`" * (n // 2) + "a" * (n // 2), shown),
    ("html <a", lambda n: TABLE + "<a " * (n // 3), html_tables),
    ('html <td a="', lambda n: "<table><tr>" + '<td a="' * (n // 7), html_tables),
    ("html <!--", lambda n: TABLE + "<!-- x >" * (n // 8), html_tables),
    ("html <![CDATA[", lambda n: TABLE + "<![CDATA[ x" * (n // 11), html_tables),
    ("html attributes", lambda n: "<table><tr><td " + 'a="b" ' * (n // 6), html_tables),
    ("html rowspan layout", _rowspans, grid),
]


def _work(read: Callable[[object], object], given: object) -> float:
    """The best of three runs, each long enough for the clock to resolve."""
    best = float("inf")
    for _ in range(3):
        start, runs = time.perf_counter(), 0
        while True:
            read(given)
            runs += 1
            spent = time.perf_counter() - start
            if spent > 0.02:
                break
        best = min(best, spent / runs)
    return best


@pytest.mark.parametrize("name, make, read", PATTERNS, ids=[p[0] for p in PATTERNS])
def test_reading_grows_linearly(name, make, read):
    n = 2000
    small, large = make(n), make(GROWTH * n)
    ratios = []
    for _ in range(2):  # a busy machine can slow one measurement: a linear reader passes the second
        ratios.append(_work(read, large) / _work(read, small))
        if ratios[-1] < ALLOWED:
            return
    assert min(ratios) < ALLOWED, f"{name}: {GROWTH}x the input took {min(ratios):.1f}x the time"


def _peak(read: Callable[[object], object], given: object) -> int:
    """The most memory reading `given` holds at once (tracemalloc's peak), in bytes."""
    tracemalloc.start()
    try:
        read(given)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("name, make, read", PATTERNS, ids=[p[0] for p in PATTERNS])
def test_memory_grows_linearly(name, make, read):
    """The memory a reader holds grows with its input, not with its square (a count of bytes: no noise)."""
    n = 2000
    small, large = make(n), make(GROWTH * n)
    ratio = _peak(read, large) / max(_peak(read, small), 1)
    assert ratio < ALLOWED, f"{name}: {GROWTH}x the input held {ratio:.1f}x the memory"


class _Scanned(str):
    """A page that adds up the stretches its line searches are given (count, rfind): each stretch once
    means linear work, whatever the search finds."""

    looked = 0

    def count(self, sub, start=0, end=None):  # type: ignore[override]
        _Scanned.looked += (len(self) if end is None else end) - start
        return super().count(sub, start, end)

    def rfind(self, sub, start=0, end=None):  # type: ignore[override]
        _Scanned.looked += (len(self) if end is None else end) - start
        return super().rfind(sub, start, end)


@pytest.mark.parametrize("lines", [1, 1000], ids=["one line (minified)", "a line per cell"])
def test_positions_look_at_each_character_once(lines):
    """Every cell's line and column is worked out without searching the page before it again: on a
    minified page of one line, searching back to the line's start for each cell was quadratic (2.3 MB:
    11 s)."""
    page = "<table><tr>" + ("<td>x" * 5000 if lines == 1 else "\n<td>x" * 5000)
    _Scanned.looked = 0
    tables = html_tables(_Scanned(page))
    assert len(tables[0].rows[0]) == 5000
    assert _Scanned.looked <= 3 * len(page), f"searched {_Scanned.looked:,} characters of a page of {len(page):,}"
