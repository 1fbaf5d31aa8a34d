"""Scoring table rows against function synonyms, and assigning each function its row.

A synonym equal to a row's text scores 1.0; found as a whole phrase inside it, 0.9 plus up to 0.1
for how much of the text it covers, and only a fifth of that bonus when another word follows the
phrase in the same clause, since that word changes what is named ("Total system power factor" is
a factor, "Total system power (sum of phases)" a power); otherwise difflib's SequenceMatcher ratio. Whole-phrase matches
always rank above fuzzy ones: "occupied heating setpoint" never takes "Unoccupied heating
setpoint", whose ratio is high but which does not contain the phrase.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass

EXACT, PHRASE, FUZZY = 2, 1, 0


def normalize(text: str) -> str:
    return " ".join(re.sub(r"[^\w]+", " ", text.lower()).split())


@dataclass(frozen=True, order=True)
class Score:
    tier: int
    value: float

    def __str__(self) -> str:
        return f"{self.value:.2f}"


def score_text(synonym: str, text: str) -> Score:
    syn, txt = normalize(synonym), normalize(text)
    if not syn or not txt:
        return Score(FUZZY, 0.0)
    if syn == txt:
        return Score(EXACT, 1.0)
    pattern = r"[\W_]+".join(re.escape(word) for word in syn.split())
    found = re.search(rf"(?<![^\W_]){pattern}(?![^\W_])", text.lower())
    if found:
        rest = text[found.end():]
        clause_ends = not rest.strip() or re.match(r"\s*[(\[,.;:/\-\u2013\u2014]", rest)
        return Score(PHRASE, 0.9 + (0.1 if clause_ends else 0.02) * len(syn) / len(txt))
    return Score(FUZZY, difflib.SequenceMatcher(None, syn, txt).ratio())


def score_row(synonyms: list[str], texts: list[str]) -> Score:
    return max((score_text(s, t) for s in synonyms for t in texts if t), default=Score(FUZZY, 0.0))


@dataclass
class Candidate:
    function: str
    row_index: int
    score: Score


def rank(functions: dict[str, list[str]], row_texts: list[list[str]]) -> dict[str, list[Candidate]]:
    """For each function, every row with its score, best first (earlier rows win ties)."""
    out = {}
    for name, synonyms in functions.items():
        cands = [Candidate(name, i, score_row(synonyms, texts)) for i, texts in enumerate(row_texts)]
        cands.sort(key=lambda c: (-c.score.tier, -c.score.value, c.row_index))
        out[name] = cands
    return out


def assign(ranked: dict[str, list[Candidate]], threshold: float) -> dict[str, Candidate]:
    """Each function its best row at or above the threshold, each row serving one function at most.
    The strongest pairs are settled first, so a weaker function never takes a stronger one's row."""
    pairs = [c for cands in ranked.values() for c in cands if c.score.value >= threshold]
    order = {name: i for i, name in enumerate(ranked)}
    pairs.sort(key=lambda c: (-c.score.tier, -c.score.value, order[c.function], c.row_index))
    chosen: dict[str, Candidate] = {}
    used: set[int] = set()
    for c in pairs:
        if c.function in chosen or c.row_index in used:
            continue
        chosen[c.function] = c
        used.add(c.row_index)
    return {name: chosen[name] for name in ranked if name in chosen}
