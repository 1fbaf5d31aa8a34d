"""Markdown pipe tables as a page shows them: every table of a `.md` file (a header line, a `|---|` rule
under it, its rows up to a blank line or a line that starts another block: an HTML comment or tag, a
heading, a quote, a fence), cells split at `|` (not at `\\|`), `<br>` a line break, emphasis, code
marks, links, inline tags and HTML comments dropped."""

from __future__ import annotations

import html
import re
from bisect import bisect_left
from collections.abc import Callable
from pathlib import Path

from mdl.formats.table.readers.delimited import MAX_CELL_CHARS, Row, cell_too_long

_RULE_CELL = re.compile(r"^\s*:?-+:?\s*$")
_BREAK = re.compile(r"(?i)<br\s*/?>")
_TAG = re.compile(r"</?[A-Za-z][^<>]*>")
_COMMENT = re.compile(r"<!--.*?(?:-->|$)", re.S)  # an HTML comment shows nothing
# a line that starts another block (an HTML comment or block, a heading, a quote, a fence) ends a table
_BLOCK_START = re.compile(r"^ {0,3}(?:<!--|<[A-Za-z/!?]|#{1,6}(?:\s|$)|>|`{3,}|~{3,})")
_TICKS = re.compile(r"`+")
# emphasis as (where a mark may open, where it may close), each naming the mark: `**x**`, `__x__`,
# `~~x~~`, then `*x*`, then `_x_` (not inside a word: fan_speed keeps its underscore). Each finds
# positions only (a lookaround of a character or two): pairing them is _unwrap's, in one pass.
_EMPHASIS = (
    (re.compile(r"(?=(\*\*|__|~~)\S)"), re.compile(r"(?<=\S)(?=(\*\*|__|~~))")),
    (re.compile(r"(?=(\*)[^\s*])"), re.compile(r"(?<=[^\s*])(?=(\*))")),
    (re.compile(r"(?<![A-Za-z0-9_])(?=(_)[^\s_])"), re.compile(r"(?<=[^\s_])(?=(_)(?![A-Za-z0-9_]))")),
)
_ESCAPE = re.compile(r"\\([!-/:-@\[-`{-~])")
_HOLD = "\x00{}\x00"  # a code span or an escaped character, kept out of the emphasis rules
_MARKS = re.compile(r"[`*_~<\[&\\\x00]")  # a cell without these is its text
_FENCE = re.compile(r"^ {0,3}(`{3,}|~{3,})")
_HELD = re.compile("\x00([0-9]+)\x00")


def split_row(line: str) -> list[str]:
    """The raw cells of a table line: split at each `|` not escaped, without the outer pipes."""
    text = line.strip()
    if "\\" not in text:
        cells = text.split("|")
    else:
        cells = _split_escaped(text)
    if text.startswith("|"):
        cells = cells[1:]
    if text.endswith("|") and not text.endswith("\\|") and len(text) > 1 and cells:
        cells = cells[:-1]
    return cells


def _split_escaped(text: str) -> list[str]:
    cells, cell, i = [], [], 0
    while i < len(text):
        ch = text[i]
        if ch == "\\" and i + 1 < len(text) and text[i + 1] == "|":
            cell.append("|")
            i += 2
            continue
        if ch == "|":
            cells.append("".join(cell))
            cell = []
        else:
            cell.append(ch)
        i += 1
    cells.append("".join(cell))
    return cells


def shown(cell: str) -> str:
    """A cell's text as the page shows it."""
    if not _MARKS.search(cell):
        return " ".join(cell.split())
    held: list[str] = []

    def hold(text: str) -> str:
        held.append(text)
        return _HOLD.format(len(held) - 1)

    text = _code_spans(cell.replace("\x00", ""), hold)
    text = _ESCAPE.sub(lambda m: hold(m.group(1)), text)
    text = _COMMENT.sub("", text)
    text = _BREAK.sub("\n", text)
    text = _links(text)
    text = _TAG.sub("", text)
    for opens, closes in _EMPHASIS:
        for _ in range(4):  # nested emphasis (***x***) unwraps a level each pass
            text, n = _unwrap(text, opens, closes)
            if not n:
                break
    text = html.unescape(text)
    text = _HELD.sub(lambda m: held[int(m.group(1))], text)
    return "\n".join(" ".join(part.split()) for part in text.split("\n")).strip()


def _code_spans(text: str, hold: Callable[[str], str]) -> str:
    """Each code span held: a run of backticks up to the next run of as many (its text trimmed unless
    all blank); a run that no such run follows is text. One pass over the runs."""
    runs = [(m.start(), m.end()) for m in _TICKS.finditer(text)]
    if len(runs) < 2:
        return text
    of_length: dict[int, list[int]] = {}  # a run's length -> the indexes of the runs that long
    for k, (a, b) in enumerate(runs):
        of_length.setdefault(b - a, []).append(k)
    out, pos = [], 0
    for k, (a, b) in enumerate(runs):
        if a < pos:
            continue
        same = of_length[b - a]
        nxt = bisect_left(same, k + 1)
        if nxt == len(same):
            continue
        c, d = runs[same[nxt]]
        code = text[b:c]
        out += [text[pos:a], hold(code.strip() or code)]
        pos = d
    return "".join(out) + text[pos:]


def _links(text: str) -> str:
    """`[text](address)` and `![text](address)` as their text."""
    if "[" not in text:
        return text
    closing = [m.start() for m in re.finditer(r"\]", text)]
    parens = [m.start() for m in re.finditer(r"\)", text)]
    out, pos = [], 0
    for m in re.finditer(r"\[", text):
        i = m.start()
        if i < pos:
            continue
        k = bisect_left(closing, i)
        if k == len(closing) or text[closing[k] + 1 : closing[k] + 2] != "(":
            continue
        e = bisect_left(parens, closing[k] + 2)
        if e == len(parens):
            continue
        start = i - 1 if i > pos and text[i - 1] == "!" else i
        out += [text[pos:start], text[i + 1 : closing[k]]]
        pos = parens[e] + 1
    return "".join(out) + text[pos:]


def _unwrap(text: str, opens: re.Pattern[str], closes: re.Pattern[str]) -> tuple[str, int]:
    """The text with each emphasis its marks enclose (on one line, at least one character) as that
    text, taken from the left as a regular expression's substitution would, and how many: each opening
    mark pairs with the first closing one after it (found by bisection), so the work is linear."""
    closers: dict[str, list[int]] = {}
    for m in closes.finditer(text):
        closers.setdefault(m.group(1), []).append(m.start())
    if not closers:
        return text, 0
    newlines = [m.start() for m in re.finditer("\n", text)]
    out, pos, n = [], 0, 0
    for m in opens.finditer(text):
        i, mark = m.start(), m.group(1)
        at = closers.get(mark)
        if i < pos or not at:
            continue
        k = bisect_left(at, i + len(mark) + 1)
        line_end = newlines[bisect_left(newlines, i)] if newlines and newlines[-1] >= i else len(text)
        if k == len(at) or at[k] > line_end:
            continue
        out += [text[pos:i], text[i + len(mark) : at[k]]]
        pos, n = at[k] + len(mark), n + 1
    return "".join(out) + text[pos:], n


def _is_rule(line: str) -> bool:
    cells = split_row(line)
    return "|" in line and bool(cells) and all(_RULE_CELL.match(c) for c in cells)


def _cells(line: str, number: int, path: Path) -> list[str]:
    """The cells of a table line as the page shows them; one longer than MAX_CELL_CHARS is refused at
    the column where it starts."""
    raw = split_row(line)
    cells = [shown(c) for c in raw]
    for k, cell in enumerate(cells):
        if len(cell) > MAX_CELL_CHARS:
            stripped = line.strip()
            column = len(line) - len(line.lstrip()) + (1 if stripped.startswith("|") else 0) + 1
            column += sum(len(c) + c.count("|") + 1 for c in raw[:k])  # a `|` in a cell was written `\|`
            raise cell_too_long(path, number, column, len(cell))
    return cells


def markdown_tables(text: str, path: Path) -> list[tuple[int, list[Row]]]:
    """Each pipe table of the text: (its header's line, its rows with their lines, the header first)."""
    lines = text.splitlines()
    tables: list[tuple[int, list[Row]]] = []
    i = 0
    fence = ""  # inside a fenced code block: the fence that ends it (what it shows is code, not a table)
    while i + 1 < len(lines):
        head = lines[i]
        opening = _FENCE.match(head)
        if fence or opening:
            if not fence and opening:
                fence = opening.group(1)
            elif head.strip().startswith(fence) and not head.strip().strip(fence[0]):
                fence = ""
            i += 1
            continue
        if "|" not in head or not head.strip() or not _is_rule(lines[i + 1]) or _is_rule(head):
            i += 1
            continue
        rows = [Row(i + 1, _cells(head, i + 1, path))]
        j = i + 2
        while j < len(lines) and lines[j].strip() and not _BLOCK_START.match(lines[j]):
            cells = _cells(lines[j], j + 1, path)
            if any(cells):
                rows.append(Row(j + 1, cells))
            j += 1
        tables.append((i + 1, rows))
        i = j
    return tables
