"""One resolve (issue 19): a command resolves each description once and the session, the simulator and
the scenarios read that resolved device; resolving reads the model and never writes it (compiled
expressions live on mdl.resolver.ResolvedFunction). And the one collector of diagnostics
(mdl.diagnostics.Collector): kinds, grouping of repeated messages, the cap on errors."""

from __future__ import annotations

import copy
import dataclasses
import json
import sys

import pytest

import mdl.resolver
from mdl.diagnostics import Collector, Diagnostic, message_kind
from mdl.formats.loading import load_any
from mdl.model import Function
from support.common import DATA
from support.run import cli

HEAT_PUMP = DATA.parent.parent / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"  # expressions
ALL = DATA / "all_tables.xml"


def _count_resolves(monkeypatch) -> list[str]:
    """From now on, the name of the device of every call of mdl.resolver.resolve, wherever a loaded module
    imported it from."""
    original = mdl.resolver.resolve
    calls: list[str] = []

    def counted(device, path=None):
        calls.append(device.name)
        return original(device, path)

    for module in list(sys.modules.values()):
        for name, value in list(vars(module).items()):
            if value is original:
                monkeypatch.setattr(module, name, counted)
    return calls


@pytest.mark.commands  # serves or dials a device
@pytest.mark.parametrize("extra", [[], ["--interval", "0.1", "--count", "2"]], ids=["read", "poll"])
def test_mdl_read_resolves_the_description_once(sim_factory, monkeypatch, extra):
    sim = sim_factory(HEAT_PUMP, "--scenario", "Heating")
    assert cli("read", HEAT_PUMP, *sim.connection).returncode == 0  # every module the command imports, loaded
    calls = _count_resolves(monkeypatch)
    proc = cli("read", HEAT_PUMP, *sim.connection, "--format", "json", *extra)
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in proc.stdout.splitlines()] if extra else [json.loads(proc.stdout)]
    assert len(records) == (2 if extra else 1) and all(r for r in records)
    assert calls == ["heat_pump"], calls  # the CLI's resolve, and no second one in the session


@pytest.mark.commands  # serves or dials a device
def test_mdl_write_and_sim_set_resolve_once(sim_factory, monkeypatch):
    sim = sim_factory(ALL, "--set", "setpoint=21.5")
    assert cli("write", ALL, *sim.connection, "setpoint=21").returncode == 0
    calls = _count_resolves(monkeypatch)
    proc = cli("write", ALL, *sim.connection, "setpoint=22.5")
    assert proc.returncode == 0, proc.stderr
    assert len(calls) == 1, calls
    proc = cli("read", ALL, *sim.connection, "setpoint", "--format", "json")
    assert json.loads(proc.stdout) == {"setpoint": 22.5}


def _snapshot(functions: list[Function]) -> list[dict]:
    """Every attribute of every function, compared or not (a deep copy: nothing shared with the model)."""
    return copy.deepcopy([dict(vars(fn)) for fn in functions])


@pytest.mark.parametrize("path", [HEAT_PUMP, ALL], ids=lambda p: p.name)
def test_resolving_leaves_the_model_as_it_is(path):
    device = load_any(path)
    before = _snapshot(device.functions)
    first = mdl.resolver.resolve(device, str(path))
    second = mdl.resolver.resolve(device, str(path))
    assert _snapshot(device.functions) == before  # nothing written onto the model, not even a cache
    assert "compiled" not in {f.name for f in dataclasses.fields(Function)}
    assert not any(hasattr(fn, "compiled") for fn in device.functions)
    assert [(f.ident, f.layout, f.codec, f.deps, f.compiled) for f in first.functions] == [
        (f.ident, f.layout, f.codec, f.deps, f.compiled) for f in second.functions
    ]
    expressions = [f for f in first.functions if f.fn.expression is not None]
    assert all(f.compiled is not None for f in expressions) and (expressions or path == ALL)
    assert all(f.compiled is None for f in first.functions if f.fn.expression is None)


def test_a_resolved_expression_reads_from_the_resolved_device_only():
    """What the model says of an expression function is what the file said: its registers, known only
    once compiled, are the resolved function's layout."""
    device = load_any(HEAT_PUMP)
    resolved = mdl.resolver.resolve(device, str(HEAT_PUMP))
    f = next(f for f in resolved.functions if f.compiled is not None and f.deps)
    assert f.fn.addresses == [] and f.layout.addresses == tuple(f.compiled.lowered.addresses)
    assert f.deps == tuple(f.compiled.deps)


# --- the Collector --------------------------------------------------------------------------------------


def _messages(diags: list[Diagnostic]) -> list[str]:
    return [str(d) for d in diags]


def test_a_kind_seen_up_to_shown_each_times_is_said_each_time():
    c = Collector("f.mod")
    for line in (4, 2, 9):
        c.warn(f"'x{line}' is odd", line, 3, kind="an odd cell")
    assert _messages(c.diagnostics()) == [
        "f.mod:2:3: warning: 'x2' is odd",
        "f.mod:4:3: warning: 'x4' is odd",
        "f.mod:9:3: warning: 'x9' is odd",
    ]


def test_a_kind_seen_more_often_is_one_summary_counting_rows():
    c = Collector("f.mod")
    for line in (5, 5, 6, 7, 8, 9):  # two cells of line 5: one row
        c.warn(f"cell on {line}", line, 1, kind="an odd cell")
    c.note("a guess", 1, kind="a guess")
    assert _messages(c.diagnostics()) == [
        "f.mod:1: note: a guess",
        "f.mod:5:1: warning: an odd cell on 5 rows (first at lines 5, 6, 7, ...)",
    ]
    assert c.counts["warning"] == 6 and not c.failed


def test_one_kind_at_two_severities_is_two_kinds():
    c = Collector("f")
    for line in range(1, 5):
        c.warn("w", line, kind="k")
    c.note("n", 9, kind="k")
    assert _messages(c.diagnostics()) == ["f:1: warning: k on 4 rows (first at lines 1, 2, 3, ...)", "f:9: note: n"]


def test_errors_past_the_cap_are_counted_in_one_last_error():
    c = Collector("f.mod", max_errors=2)
    for line in (3, 1, 8, 8, 9):
        c.error(f"bad {line}", line, 2)
    c.error("why the reader stopped", 20, always=True)
    out = _messages(c.diagnostics())
    assert out == [
        "f.mod:1:2: error: bad 1",
        "f.mod:3:2: error: bad 3",
        "f.mod:20: error: why the reader stopped",
        "f.mod:8:2: error: 3 more errors not shown (first at lines 8, 9): only the first 2 are",
    ]
    assert c.failed and c.counts["error"] == 6
    assert _messages(c.diagnostics("warning")) == []


def test_fold_says_the_first_and_sums_up_the_rest_in_the_next():
    c = Collector("m.ini", shown_each=2, shown_lines=2, fold=True, kind_of=message_kind)
    for line in range(10, 16):
        c.warn(f"[AI] entry {line}: 'n{line}' has no unit", line, 1)
    c.warn("unlike the others", 30)
    c.error("an error is its own kind", 12)
    assert _messages(c.diagnostics()) == [
        "m.ini:10:1: warning: [AI] entry 10: 'n10' has no unit",
        "m.ini:11:1: warning: [AI] entry 11: 'n11' has no unit",
        "m.ini:12: error: an error is its own kind",
        "m.ini:12:1: warning: [AI] entry 12: 'n12' has no unit; and 3 more like it (lines 13, 14, ...)",
        "m.ini:30: warning: unlike the others",
    ]
    assert _messages(c.diagnostics("error")) == ["m.ini:12: error: an error is its own kind"]


def test_fold_says_one_more_in_full_and_counts_none():
    c = Collector("m.ini", shown_each=1, fold=True, kind_of=message_kind)
    c.warn("x 1", 1)
    c.warn("x 2", 2)
    assert _messages(c.diagnostics()) == ["m.ini:1: warning: x 1", "m.ini:2: warning: x 2"]


def test_notes_once_says_a_note_once_and_warnings_always():
    c = Collector(notes_once=True)
    assert c.add(Diagnostic("a.csv", None, None, "guess", "note"))
    assert not c.add(Diagnostic("b.csv", 7, None, "guess", "note"))  # the same text: not said again
    c.note("guess", 8, file="c.csv")
    c.warn("row skipped", 3, file="a.csv")
    c.warn("row skipped", 3, file="a.csv")
    assert _messages(c.diagnostics()) == [
        "a.csv: note: guess",
        "a.csv:3: warning: row skipped",
        "a.csv:3: warning: row skipped",
    ]


def test_message_kind_ignores_quoted_words_and_numbers():
    assert message_kind("line 7: 'a b' is 12") == message_kind("line 9: 'c' is 3") == "line #: # is #"
