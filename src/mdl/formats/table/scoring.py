"""How well a synonym names a row's text (SPEC 4). One pair, one score; `match.py` finds the best
pairs of a whole table without scoring every one.

Tiers, each above the next whatever the values:

- EXACT 1.0: the text is the synonym (case, spacing and punctuation aside).
- PHRASE 0.9 to 1.0: the synonym's words are whole words of the text, in order, in one clause; up
  to one word fewer than the synonym has may stand between them ("total real power" is found in
  "TOTAL INSTANTANEOUS REAL POWER"). The value is 0.9 plus 0.1 times the share of the text the
  synonym covers, so the text that says the least beyond the synonym ranks first; that bonus is
  a fifth when another word follows the phrase in its clause, since that word names another
  quantity ("TOTAL REAL POWER MAX. DEMAND IMPORT" is a demand; "Total system power factor" a
  factor; "Total system power (sum of phases)" a power). Closing brackets after the phrase are
  passed over (its own bracket closes, the clause goes on: "(System) estimate"), and the clause
  ends where nothing but punctuation follows ("Battery State of Charge (System)").
- NAME_EXACT, NAME_PHRASE: the same, found by the function's own name (a `FunctionName`, the
  fallback every function searches with besides its synonyms): below every exact or phrase match of
  the INI's (or the bundled list's) synonyms, so that a synonym copied word for word from the table
  is never beaten by the name `soc` standing in a short cell ("vebus/Soc").
- FUZZY: difflib's SequenceMatcher ratio of the two normalized texts (synonym first).
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass

from mdl.formats.table.lazy import lazy

EXACT, PHRASE, NAME_EXACT, NAME_PHRASE, FUZZY = 4, 3, 2, 1, 0
TIER_NAMES = {EXACT: "exact", PHRASE: "phrase", NAME_EXACT: "name", NAME_PHRASE: "name-phrase", FUZZY: "fuzzy"}
_WORD = re.compile(r"[^\W_]+")
_CLAUSE_BREAK = lazy(r"[()\[\],.;:/\-\u2013\u2014]")
_CLAUSE_ENDS = lazy(r"\s*[(\[,.;:/\-\u2013\u2014]")
_CLOSING = lazy(r"^[\s)\]]+")  # closing brackets after a phrase: its own bracket ends, the clause goes on


class FunctionName(str):
    """A function's own name (`state of charge` for `state_of_charge`) searched for as a synonym: its
    exact and phrase matches rank below those of the function's real synonyms."""


def tiers(synonym: str) -> tuple[int, int]:
    """(exact tier, phrase tier) of a synonym."""
    return (NAME_EXACT, NAME_PHRASE) if isinstance(synonym, FunctionName) else (EXACT, PHRASE)


_NOT_WORD = re.compile(r"[^\w]+")
# ASCII text (most tables) is split by bytes.translate instead, which a regex costs several times:
# every byte but a word character (\w: [A-Za-z0-9_]; [^\W_]: [A-Za-z0-9]) becomes a space
_ASCII_WORD = bytes(c if c < 128 and (chr(c).isalnum() or c == ord("_")) else 32 for c in range(256))
_ASCII_ALNUM = bytes(c if c < 128 and chr(c).isalnum() else 32 for c in range(256))


def _normal(lower: str) -> str:
    if lower.isascii():
        return " ".join(lower.encode().translate(_ASCII_WORD).decode().split())
    return " ".join(_NOT_WORD.sub(" ", lower).split())


def _words(lower: str) -> list[str]:
    if lower.isascii():
        return lower.encode().translate(_ASCII_ALNUM).decode().split()
    return _WORD.findall(lower)


def normalize(text: str) -> str:
    return _normal(text.lower())


def words(text: str) -> list[str]:
    return _words(text.lower())


@dataclass(frozen=True, order=True)
class Score:
    tier: int
    value: float

    def __str__(self) -> str:
        return f"{self.value:.2f}"


ZERO = Score(FUZZY, 0.0)


@dataclass(frozen=True)
class Phrase:
    """Where a synonym was found as a phrase: how many words stand between its words, and whether its
    clause ends after it."""

    value: float
    between: int
    clause_ends: bool


class Text:
    """A row's text, prepared once for every synonym scored against it: its words for every row (the
    index of words), where they stand only for a row a phrase is looked for in."""

    __slots__ = ("raw", "lower", "norm", "words", "_tokens")

    def __init__(self, raw: str) -> None:
        self.raw = raw
        self.lower = lower = raw.lower()
        self.words = _words(lower)
        # without an underscore, the runs of \w are the words: normalize's text, joined by spaces
        self.norm = " ".join(self.words) if lower.isascii() and "_" not in lower else _normal(lower)
        self._tokens: list[tuple[str, int, int]] | None = None

    @property
    def tokens(self) -> list[tuple[str, int, int]]:
        """Each word with its start and end in `lower`."""
        if self._tokens is None:
            self._tokens = [(m.group(0), m.start(), m.end()) for m in _WORD.finditer(self.lower)]
        return self._tokens


def find_phrase(syn_words: list[str], syn_norm: str, text: Text) -> Phrase | None:
    """The best place the synonym's words stand in `text` as a phrase (see the module docstring)."""
    tokens, k = text.tokens, len(syn_words)
    if not k or not text.norm:
        return None
    best: Phrase | None = None
    for start, (word, _, _) in enumerate(tokens):
        if word != syn_words[0]:
            continue
        at, between, ok = start, 0, True
        for want in syn_words[1:]:
            nxt = at + 1
            while nxt < len(tokens) and tokens[nxt][0] != want:
                nxt += 1
            if nxt == len(tokens):
                ok = False
                break
            if nxt > at + 1 and _CLAUSE_BREAK().search(text.lower, tokens[at][2], tokens[nxt][1]):
                ok = False  # words between, across a clause break: another clause
                break
            between += nxt - at - 1
            at = nxt
        if not ok or between > k - 1:
            continue
        rest = text.lower[tokens[at][2] :]
        rest = _CLOSING().sub("", rest)
        clause_ends = not _WORD.search(rest) or bool(_CLAUSE_ENDS().match(rest))
        value = 0.9 + (0.1 if clause_ends else 0.02) * len(syn_norm) / len(text.norm)
        if best is None or value > best.value or (value == best.value and between < best.between):
            best = Phrase(value, between, clause_ends)
    return best


def fuzzy(syn_norm: str, text_norm: str) -> float:
    return difflib.SequenceMatcher(None, syn_norm, text_norm).ratio()


def score_pair(synonym: str, text: str | Text) -> Score:
    """The score of one synonym against one text (the reference the fast search in match.py agrees with)."""
    t = text if isinstance(text, Text) else Text(text)
    syn = normalize(synonym)
    if not syn or not t.norm:
        return ZERO
    exact, phrase = tiers(synonym)
    if syn == t.norm:
        return Score(exact, 1.0)
    found = find_phrase(words(synonym), syn, t)
    if found is not None:
        return Score(phrase, found.value)
    return Score(FUZZY, fuzzy(syn, t.norm))


def score_row(synonyms: list[str], texts: list[str]) -> Score:
    return max((score_pair(s, t) for s in synonyms for t in texts if t), default=ZERO)


def why(synonym: str, text: str) -> str:
    """In words, how `synonym` scores against `text` (for --explain)."""
    t = Text(text)
    syn = normalize(synonym)
    if not syn or not t.norm:
        return "nothing to compare"
    named = isinstance(synonym, FunctionName)
    what = f"the function's own name '{synonym}'" if named else f"the synonym '{synonym}'"
    if syn == t.norm:
        return f"the text is {what}" + (" (ranked below the synonyms' exact and phrase matches)" if named else "")
    found = find_phrase(words(synonym), syn, t)
    if found is not None:
        gap = f", {found.between} word{'s' * (found.between != 1)} between its words" if found.between else ""
        end = "its clause ends there" if found.clause_ends else "another word follows in its clause (bonus / 5)"
        below = "; ranked below the synonyms' exact and phrase matches" if named else ""
        return f"{what} found as a phrase{gap}; it covers {len(syn)} of {len(t.norm)} characters; {end}{below}"
    return f"{what} is not a phrase of the text; SequenceMatcher ratio {fuzzy(syn, t.norm):.3f}"
