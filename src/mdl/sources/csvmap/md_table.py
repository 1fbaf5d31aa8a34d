"""Markdown pipe tables as a page shows them: every table of a `.md` file (a header line, a `|---|` rule
under it, its rows up to a blank line or a line that starts another block: an HTML comment or tag, a
heading, a quote, a fence), cells split at `|` (not at `\\|`), `<br>` a line break, emphasis, code
marks, links, inline tags and HTML comments dropped."""

from __future__ import annotations

import html
import re

from mdl.sources.csvmap.table import Row

_RULE_CELL = re.compile(r"^\s*:?-+:?\s*$")
_CODE = re.compile(r"(`+)(.+?)\1", re.S)
_BREAK = re.compile(r"(?i)<br\s*/?>")
_TAG = re.compile(r"</?[A-Za-z][^<>]*>")
_COMMENT = re.compile(r"<!--.*?(?:-->|$)", re.S)  # an HTML comment shows nothing
# a line that starts another block (an HTML comment or block, a heading, a quote, a fence) ends a table
_BLOCK_START = re.compile(r"^ {0,3}(?:<!--|<[A-Za-z/!?]|#{1,6}(?:\s|$)|>|`{3,}|~{3,})")
_LINK = re.compile(r"!?\[([^\]]*)\]\([^)]*\)")
_EMPHASIS = (
    re.compile(r"(\*\*|__|~~)(?=\S)(.+?)(?<=\S)\1"),
    re.compile(r"\*(?=[^\s*])(.+?)(?<=[^\s*])\*"),
    re.compile(r"(?<![A-Za-z0-9_])_(?=[^\s_])(.+?)(?<=[^\s_])_(?![A-Za-z0-9_])"),
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

    text = _CODE.sub(lambda m: hold(m.group(2).strip() if m.group(2).strip() else m.group(2)), cell.replace("\x00", ""))
    text = _ESCAPE.sub(lambda m: hold(m.group(1)), text)
    text = _COMMENT.sub("", text)
    text = _BREAK.sub("\n", text)
    text = _LINK.sub(r"\1", text)
    text = _TAG.sub("", text)
    for rule in _EMPHASIS:
        for _ in range(4):  # nested emphasis (***x***) unwraps a level each pass
            text, n = rule.subn(lambda m: m.group(m.lastindex or 0), text)
            if not n:
                break
    text = html.unescape(text)
    text = _HELD.sub(lambda m: held[int(m.group(1))], text)
    return "\n".join(" ".join(part.split()) for part in text.split("\n")).strip()


def _is_rule(line: str) -> bool:
    cells = split_row(line)
    return "|" in line and bool(cells) and all(_RULE_CELL.match(c) for c in cells)


def markdown_tables(text: str) -> list[tuple[int, list[Row]]]:
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
        rows = [Row(i + 1, [shown(c) for c in split_row(head)])]
        j = i + 2
        while j < len(lines) and lines[j].strip() and not _BLOCK_START.match(lines[j]):
            cells = [shown(c) for c in split_row(lines[j])]
            if any(cells):
                rows.append(Row(j + 1, cells))
            j += 1
        tables.append((i + 1, rows))
        i = j
    return tables
