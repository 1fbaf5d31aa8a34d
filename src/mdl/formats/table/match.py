"""Each function's best rows, and each function its row, without scoring every (row, synonym) pair.

The scores are scoring.py's. A function's candidates come out best first (tier, value, then the
earlier row), exactly as if every pair had been scored and sorted:

- EXACT (and NAME_EXACT) rows from an index of normalized texts, PHRASE (and NAME_PHRASE) rows
  from an index of words (only rows holding every word of a synonym are looked at);
- FUZZY rows by a best-first search over upper bounds: difflib's `real_quick_ratio` (lengths only,
  one bound per text length), then `quick_ratio` (shared characters), and `ratio()` only for a pair
  whose bound is still the best left. Below the threshold nothing is looked at.

`assign` settles the strongest (function, row) pairs first, each row serving one function, pulling
each function's candidates only as far as it needs them.
"""

from __future__ import annotations

import heapq
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from mdl.formats.table.scoring import FUZZY, Score, Text, find_phrase, fuzzy, normalize, tiers, words


@dataclass
class Candidate:
    function: str
    row_index: int
    score: Score


class Index:
    """The texts of a table's rows, indexed for matching (built once per table)."""

    def __init__(self, row_texts: list[list[str]]) -> None:
        self.rows = len(row_texts)
        self.texts: list[list[Text]] = [[Text(t) for t in texts if t] for texts in row_texts]
        # where each kept text came from: 0 the description cell, 1... a name column's (rows.row_texts)
        self.sources: list[list[int]] = [[k for k, t in enumerate(texts) if t] for texts in row_texts]
        self.exact: dict[str, list[int]] = {}
        self.postings: dict[str, set[int]] = {}
        exact, postings = self.exact, self.postings
        by_length: dict[int, list[tuple[int, int]]] = {}
        for r, texts in enumerate(self.texts):
            for k, t in enumerate(texts):
                norm = t.norm
                if not norm:
                    continue
                rows = exact.get(norm)
                if rows is None:
                    exact[norm] = [r]
                elif rows[-1] != r:
                    rows.append(r)
                for word in t.words:
                    posting = postings.get(word)
                    if posting is None:
                        postings[word] = {r}
                    else:
                        posting.add(r)
                same = by_length.get(len(norm))
                if same is None:
                    by_length[len(norm)] = [(r, k)]
                else:
                    same.append((r, k))
        self.lengths = sorted(by_length)
        self.by_length = [by_length[n] for n in self.lengths]  # (row, text) pairs, rows ascending
        self._counts: dict[str, Counter[str]] = {}

    def counts(self, norm: str) -> Counter[str]:
        found = self._counts.get(norm)
        if found is None:
            found = self._counts[norm] = Counter(norm)
        return found


@dataclass(frozen=True)
class Synonym:
    norm: str
    words: list[str]
    chars: tuple[tuple[str, int], ...]  # each character and how often it occurs (quick_ratio)
    exact_tier: int
    phrase_tier: int


def synonyms_of(phrases: list[str]) -> list[Synonym]:
    """The distinct synonyms (by normalized text); a real synonym wins over the function's name."""
    out: dict[str, Synonym] = {}
    for phrase in phrases:
        norm = normalize(phrase)
        if norm and (norm not in out or out[norm].exact_tier < tiers(phrase)[0]):
            out[norm] = Synonym(norm, words(phrase), tuple(Counter(norm).items()), *tiers(phrase))
    return list(out.values())


class Work:
    """How many SequenceMatcher ratios were computed (for the bench and the tests)."""

    ratios = 0


PULSE = 256  # steps of the fuzzy search between two calls of its `pulse`


def candidates(
    name: str,
    phrases: list[str],
    index: Index,
    threshold: float,
    budget: int | None = None,
    pulse: Callable[[], None] | None = None,
) -> Iterator[Candidate]:
    """Every row scoring at least `threshold` for the function, best first (earlier rows first on ties).
    With a budget, the fuzzy search stops after that many ratios (what it yielded is still right).
    `pulse` is called every PULSE steps of the fuzzy search (a progress bar's sign of life)."""
    syns = synonyms_of(phrases)
    strong: dict[int, Score] = {}  # rows found exactly or as a phrase, with their best score
    for s in syns:
        score = Score(s.exact_tier, 1.0)
        for r in index.exact.get(s.norm, ()):
            if r not in strong or score > strong[r]:
                strong[r] = score
    for s in syns:
        posting = [index.postings.get(w) for w in dict.fromkeys(s.words)]
        if not posting or any(p is None for p in posting):
            continue
        rows = set.intersection(*sorted((p for p in posting if p is not None), key=len))
        for r in rows:
            known = strong.get(r)
            if known is not None and known.tier > s.phrase_tier:
                continue
            for t in index.texts[r]:
                found = find_phrase(s.words, s.norm, t)
                if found is not None and (known is None or Score(s.phrase_tier, found.value) > known):
                    known = strong[r] = Score(s.phrase_tier, found.value)
    for r, score in sorted(strong.items(), key=lambda kv: (-kv[1].tier, -kv[1].value, kv[0])):
        if score.value >= threshold:
            yield Candidate(name, r, score)
    yield from _fuzzy(name, syns, index, threshold, set(strong), budget, pulse)


def _fuzzy(
    name: str,
    syns: list[Synonym],
    index: Index,
    threshold: float,
    excluded: set[int],
    budget: int | None,
    pulse: Callable[[], None] | None = None,
) -> Iterator[Candidate]:
    # heap entries: (-bound, row, kind, tiebreak, payload); kind 0: an exact ratio, 1: a quick_ratio
    # bound of one pair, 2: a real_quick_ratio bound of every pair of one text length (row: its first row)
    heap: list[tuple[float, int, int, int, tuple[int, int, int]]] = []
    serial = 0
    for si, s in enumerate(syns):
        ls = len(s.norm)
        for li, lt in enumerate(index.lengths):
            bound = 2.0 * min(ls, lt) / (ls + lt)
            if bound >= threshold and bound > 0:
                heap.append((-bound, index.by_length[li][0][0], 2, serial, (si, li, 0)))
                serial += 1
    if threshold <= 0:  # every row scores at least 0: each is listed, at 0 if nothing better is found
        heap += [(-0.0, r, 0, 0, (0, 0, 0)) for r in range(index.rows) if r not in excluded]
    heapq.heapify(heap)
    done: set[int] = set()
    best: dict[int, float] = {}  # row -> the best exact ratio pushed so far
    steps = 0
    while heap:
        steps += 1
        if pulse is not None and steps % PULSE == 0:
            pulse()
        neg, row, kind, _, (si, a, b) = heapq.heappop(heap)
        if kind == 0:
            if row not in done:
                done.add(row)
                yield Candidate(name, row, Score(FUZZY, -neg))
            continue
        s = syns[si]
        if kind == 2:
            for r, k in index.by_length[a]:
                if r in excluded or r in done:
                    continue
                norm = index.texts[r][k].norm
                bound = _quick(s, norm, index)
                if bound >= threshold and bound > best.get(r, -1.0):
                    heapq.heappush(heap, (-bound, r, 1, serial, (si, r, k)))
                    serial += 1
            continue
        if row in done or -neg <= best.get(row, -1.0):
            continue  # the row already has a ratio at least this bound
        if budget is not None:
            if budget <= 0:
                return
            budget -= 1
        Work.ratios += 1
        value = fuzzy(s.norm, index.texts[a][b].norm)
        if value >= threshold and value > best.get(row, -1.0):
            best[row] = value
            heapq.heappush(heap, (-value, row, 0, serial, (si, a, b)))
            serial += 1


def _quick(syn: Synonym, text: str, index: Index) -> float:
    """difflib's quick_ratio of (synonym, text): the characters they share, an upper bound of ratio()."""
    have = index.counts(text).get
    shared = len(syn.norm)
    for ch, n in syn.chars:
        m = have(ch, 0)
        if m < n:
            shared -= n - m
    return 2.0 * shared / (len(syn.norm) + len(text))


def assign(
    functions: dict[str, list[str]], index: Index, threshold: float, progress: Callable[[int], None] | None = None
) -> dict[str, Candidate]:
    """Each function its best row at or above the threshold, each row serving one function at most.
    The strongest pairs are settled first (ties: the function listed first, then the earlier row), so
    a weaker function never takes a stronger one's row.

    A function's search is dropped once it has given its best row (most functions keep it), and
    started again, past the rows it gave, only if a stronger function takes that row: memory stays
    in proportion to the functions that compete for rows, not to functions x rows.

    `progress` is told of 2 steps per function: its first search done (the bulk of the work), and
    the function settled (a row, or none left); between them, progress(0) while a search runs."""
    order = {name: i for i, name in enumerate(functions)}
    given = dict.fromkeys(functions, 0)  # candidates each function has given so far
    live: dict[str, Iterator[Candidate]] = {}  # the searches of functions that lost a row: kept
    heap: list[tuple[int, float, int, int, str]] = []

    pulse = (lambda: progress(0)) if progress else None

    def push(name: str) -> None:
        stream = live.get(name)
        if stream is None:
            stream = candidates(name, functions[name], index, threshold, pulse=pulse)
            for _ in range(given[name]):
                next(stream)
            if given[name]:
                live[name] = stream
        c = next(stream, None)
        given[name] += 1
        if c is not None:
            heapq.heappush(heap, (-c.score.tier, -c.score.value, order[name], c.row_index, name))
            return
        live.pop(name, None)
        if progress:
            progress(1)

    for name in functions:
        push(name)
        if progress:
            progress(1)
    chosen: dict[str, Candidate] = {}
    used: set[int] = set()
    while heap:
        tier, value, _, row, name = heapq.heappop(heap)
        if row in used:
            push(name)
            continue
        chosen[name] = Candidate(name, row, Score(-tier, -value))
        used.add(row)
        live.pop(name, None)  # its search, and the bounds it holds, are done with
        if progress:
            progress(1)
    return {name: chosen[name] for name in functions if name in chosen}


def best(name: str, phrases: list[str], index: Index, skip: set[int] | None = None, limit: int = 10) -> list[Candidate]:
    """The function's `limit` best rows of any score, rows in `skip` left out."""
    out = []
    for c in candidates(name, phrases, index, 0.0):
        if not skip or c.row_index not in skip:
            out.append(c)
            if len(out) == limit:
                break
    return out
