"""`mdl csv2xml --explain FUNCTION`: a function's nearest rows, their scores and why, so that an INI
can be fixed without reading the code; and the short form the unmatched-functions warning uses."""

from __future__ import annotations

from collections.abc import Callable

from mdl.formats.table.match import Candidate, Index, best, candidates
from mdl.formats.table.scoring import TIER_NAMES, FunctionName, normalize, score_pair, why

TOP = 10
BUDGET = 2000  # ratios computed at most to find an unmatched function's best row


def _one_line(text: str, width: int = 60) -> str:
    text = " ".join(text.split())
    return text if len(text) <= width else text[: width - 3] + "..."


def _reason(phrases: list[str], index: Index, row: int) -> str:
    pairs = [
        (score_pair(p, t), p, t.raw, source)
        for p in phrases
        for t, source in zip(index.texts[row], index.sources[row], strict=True)
    ]
    if not pairs:
        return "the row has no text to compare"
    _, phrase, text, source = max(pairs, key=lambda item: item[0])
    cell = "the description cell" if source == 0 else "the name cell"
    return f"on {cell} '{_one_line(text)}': {why(phrase, text)}"


def _line(line: int) -> str:
    return f"line {line}"


def explain(
    names: tuple[str, ...],
    functions: dict[str, list[str]],
    index: Index,
    lines: list[int],
    chosen: dict[str, Candidate],
    threshold: float,
    skipped: dict[int, str] | None = None,
    lost: dict[str, Candidate] | None = None,
    named: Callable[[int], str] | None = None,
) -> None:
    """Print, for each name, its synonyms and its best rows with score, tier, line, text, whether it was
    chosen (or which function took it, or why the row was skipped) and why it scores so. `named` says
    a row as messages do (`line 12`, a PDF's `p14:r7`)."""
    named = named or _line
    skipped, lost = skipped or {}, lost or {}
    taken = {c.row_index: name for name, c in chosen.items()}
    for n, name in enumerate(names):
        if n:
            print()
        phrases = functions.get(name)
        if phrases is None:
            print(f"'{name}' is not a function of the INI or the bundled list: scoring it as a synonym")
            phrases = [name]
        distinct: dict[str, str] = {}
        for p in phrases:
            distinct.setdefault(normalize(p), p)
        shown = ", ".join(
            f"'{p}'" + (" (its name)" if isinstance(p, FunctionName) else "") for key, p in distinct.items() if key
        )
        print(f"function '{name}': synonyms {shown}; threshold {threshold:g}")
        mine = chosen.get(name)
        if mine is not None:
            print(f"  chosen: {named(lines[mine.row_index])} (score {mine.score})")
        elif name in lost:
            print(f"  chosen: no row (its best row, {named(lines[lost[name].row_index])}, was skipped)")
        elif name in functions:
            print("  chosen: no row (none reached the threshold, or a stronger function took it)")
        for rank, c in enumerate(best(name, phrases, index, None, TOP), 1):
            text = index.texts[c.row_index][0].raw if index.texts[c.row_index] else ""
            if c.row_index in skipped:
                status = f"  (skipped: {_one_line(skipped[c.row_index], 70)})"
            elif taken.get(c.row_index) == name:
                status = "  <- chosen"
            elif c.row_index in taken:
                status = f"  (taken by {taken[c.row_index]})"
            elif c.score.value < threshold:
                status = "  (below the threshold)"
            else:
                status = ""
            print(
                f"  {rank:2}. {c.score} {TIER_NAMES[c.score.tier]:6} {named(lines[c.row_index])}: "
                f"{_one_line(text)}{status}"
            )
            print(f"        {_reason(phrases, index, c.row_index)}")


def nearest(
    name: str,
    phrases: list[str],
    index: Index,
    lines: list[int],
    chosen: dict[str, Candidate],
    named: Callable[[int], str] = _line,
) -> str:
    """`name (best 0.45, line 12)`, `name (best 0.97, line 3, taken by other)`, or the name alone when
    finding its best row would take long."""
    first = next(candidates(name, phrases, index, 0.0, BUDGET), None)
    if first is None:
        return name
    taken = next((other for other, c in chosen.items() if c.row_index == first.row_index), None)
    by = f", taken by {taken}" if taken else ""
    return f"{name} (best {first.score}, {named(lines[first.row_index])}{by})"
