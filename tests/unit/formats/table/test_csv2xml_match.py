"""Matching at scale: the indexed, bounded search gives exactly what scoring every (row, synonym)
pair and sorting would (SPEC 4's scores), with SequenceMatcher.ratio() run only where it can change
the result; a long table shows progress on a terminal and nothing elsewhere."""

from __future__ import annotations

import importlib.util
import io
import random
import sys
import time

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.formats.table.match import Index, Work, assign, candidates
from mdl.formats.table.report import Progress
from mdl.formats.table.scoring import EXACT, FUZZY, NAME_EXACT, NAME_PHRASE, PHRASE, FunctionName, score_row
from support.common import ROOT
from support.run import cli
from support.tables import functions

_spec = importlib.util.spec_from_file_location("csv2xml_bench", ROOT / "bench" / "csv2xml_bench.py")
assert _spec and _spec.loader
bench = importlib.util.module_from_spec(_spec)
sys.modules["csv2xml_bench"] = bench  # dataclasses look their module up
_spec.loader.exec_module(bench)

WORDS = [
    "total",
    "real",
    "power",
    "phase",
    "a",
    "voltage",
    "max.",
    "demand",
    "import",
    "current",
    "energy",
    "setpoint",
    "occupied",
    "unoccupied",
    "heating",
    "(sum)",
    "L1",
    "-",
    "instantaneous",
    "Power,",
    "factor",
    "1",
    "_",
    "volts",
    "Volt",
    "re al",
]
texts = st.lists(st.sampled_from(WORDS), max_size=6).map(" ".join)


def brute_force(functions_: dict[str, list[str]], rows: list[list[str]], threshold: float):
    """What the matcher must equal: every pair scored, sorted, the strongest settled first."""
    order = {name: i for i, name in enumerate(functions_)}
    ranked, pairs = {}, []
    for name, synonyms in functions_.items():
        scored = sorted(
            ((score_row(synonyms, texts_), i) for i, texts_ in enumerate(rows)),
            key=lambda c: (-c[0].tier, -c[0].value, c[1]),
        )
        ranked[name] = scored
        pairs += [(score, name, i) for score, i in scored if score.value >= threshold]
    pairs.sort(key=lambda p: (-p[0].tier, -p[0].value, order[p[1]], p[2]))
    chosen, used = {}, set()
    for score, name, i in pairs:
        if name not in chosen and i not in used:
            chosen[name] = (i, score)
            used.add(i)
    return ranked, chosen


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(st.lists(texts, min_size=1, max_size=2), min_size=1, max_size=25),
    st.lists(st.lists(texts, min_size=1, max_size=3), min_size=1, max_size=6),
    st.sampled_from([0.0, 0.3, 0.6, 0.9, 0.95, 1.0]),
    st.lists(st.none() | texts, min_size=6, max_size=6),
)
def test_the_search_equals_scoring_every_pair(rows, synonym_lists, threshold, names):
    """With the functions' own names among their synonyms (ranked below the synonyms' exact and phrase
    matches) as convert.py adds them."""
    functions_ = {
        f"f{i}": synonyms + ([FunctionName(names[i])] if names[i] is not None else [])
        for i, synonyms in enumerate(synonym_lists)
    }
    ranked, chosen = brute_force(functions_, rows, threshold)
    index = Index(rows)
    got = assign(functions_, index, threshold)
    assert {name: (c.row_index, c.score) for name, c in got.items()} == chosen
    for name, synonyms in functions_.items():
        assert [(c.score, c.row_index) for c in candidates(name, synonyms, index, 0.0)] == ranked[name]


def test_the_tiers():
    index = Index(
        [
            ["TOTAL REAL POWER MAX. DEMAND IMPORT"],
            ["TOTAL INSTANTANEOUS REAL POWER"],
            ["Total real power"],
            ["Real power total"],
        ]
    )
    got = [(c.row_index, c.score.tier) for c in candidates("p", ["total real power"], index, 0.0)]
    assert got == [(2, EXACT), (1, PHRASE), (0, PHRASE), (3, FUZZY)]
    # the function's own name: below every exact and phrase match of its synonyms, above fuzzy ones
    index = Index(
        [
            ["SOC"],
            ["Battery State of Charge (System)"],
            ["Battery SOC"],
            ["state of chrge"],
            ["Battery State of Charge (System) estimate"],
        ]
    )
    got = [
        (c.row_index, c.score.tier)
        for c in candidates("soc", ["battery state of charge (system)", FunctionName("soc")], index, 0.0)
    ]
    assert got[:4] == [(1, EXACT), (4, PHRASE), (0, NAME_EXACT), (2, NAME_PHRASE)]
    assert {tier for _, tier in got[4:]} == {FUZZY}


def test_exact_synonyms_need_no_ratio_at_all():
    case_rows = bench.descriptions(5000, random.Random(3))
    index = Index([[t] for t in case_rows])
    targets = list(range(0, 5000, 25))
    wanted = {f"f{t}": [case_rows[t], case_rows[t].lower()] for t in targets}
    Work.ratios = 0
    started = time.process_time()
    got = assign(wanted, index, 0.6)
    elapsed = time.process_time() - started
    assert {name: c.row_index for name, c in got.items()} == {f"f{t}": t for t in targets}
    assert Work.ratios == 0 and elapsed < 5, (Work.ratios, elapsed)


def test_fuzzy_synonyms_compute_few_ratios_and_still_agree():
    rng = random.Random(5)
    rows = bench.descriptions(400, rng)
    targets = list(range(0, 400, 20))
    wanted = {f"f{t}": [bench.typo(rows[t], rng)] for t in targets}
    Work.ratios = 0
    got = assign(wanted, Index([[t] for t in rows]), 0.6)
    assert Work.ratios < 0.1 * len(rows) * len(targets), Work.ratios  # far fewer than one per pair
    _, chosen = brute_force(wanted, [[t] for t in rows], 0.6)
    assert {name: (c.row_index, c.score) for name, c in got.items()} == chosen
    assert {name: c.row_index for name, c in got.items()} == {f"f{t}": t for t in targets}


def test_a_long_table_through_the_cli(tmp_path):
    case = bench.generate(5000, 200, tmp_path / "t")
    out = tmp_path / "out.xml"
    started = time.monotonic()
    proc = cli("csv2xml", case.folder / "device.ini", "-o", out)
    elapsed = time.monotonic() - started
    assert proc.returncode == 0, proc.stderr
    fns = functions(out.read_text())
    assert {name: fns[name]["addresses"] for name in case.expected} == case.expected
    assert "summary: 5000 rows read, 0 skipped; 200 functions matched, 0 unmatched" in proc.stderr
    assert "\r" not in proc.stderr  # no progress bar when stderr is not a terminal
    assert elapsed < 30, elapsed


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_on_a_terminal_only_once_the_work_is_long(monkeypatch):
    clock = [100.0]
    monkeypatch.setattr("mdl.formats.table.report.time.monotonic", lambda: clock[0])
    screen = Terminal()
    bar = Progress("matching", 4, screen)
    bar()
    assert screen.getvalue() == ""  # not within the first half second
    clock[0] += 1
    bar()
    assert screen.getvalue() == "\rmatching [###############...............] 2/4"
    bar.close()
    assert screen.getvalue().endswith("\r\x1b[K")
    plain = io.StringIO()
    quiet = Progress("matching", 4, plain)
    clock[0] += 5
    quiet(4)
    quiet.close()
    assert plain.getvalue() == ""
