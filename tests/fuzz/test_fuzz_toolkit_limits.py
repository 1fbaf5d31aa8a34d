"""Fuzzing the Toolkit reader's limits (issue 27): deep nesting, aliases, huge scalars, many fields and long
chains of fields naming each other either import (and their scenarios run) or are refused with an MdlError
naming the file (and a line where one is known), never another exception; a file over the size limit is
refused, or an error found before the limit is reported at its line. The limit is lowered here so that the
size path is fuzzed cheaply."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mdl.exchange.yamlnodes as yamlnodes
import mdl.formats.toolkit.read as toolkit
from mdl.device.evaluate import Evaluator
from mdl.device.server.scenarios import run_scenario
from mdl.diagnostics import MdlError
from mdl.resolver import resolve

SMALL_LIMIT = 60_000

HEAD = "description: 'limits'\nblocks:\n  - id: 'M'\n    fields:\n"


def _field(i: int, expression: str, extra: str = "") -> str:
    return f"      - id: 'F{i}'\n        expression: \"{expression}\"\n{extra}"


@st.composite
def hostile(draw: st.DrawFn) -> str:
    kind = draw(st.sampled_from(["nest", "alias", "scalar", "many", "chain", "tests"]))
    if kind == "nest":
        opener, closer = draw(st.sampled_from([("[", "]"), ("{a: ", "}"), ("[{a: ", "}]"), ("- ", "")]))
        n = draw(st.integers(0, 400))
        if opener == "- ":
            return "description: 'x'\nblocks:\n" + "".join("  " * i + "- \n" for i in range(n)) + "  " * n + "x\n"
        return "description: 'x'\nblocks: " + opener * n + closer * n + "\n"
    if kind == "alias":
        anchors = draw(st.integers(1, 8))
        text = "lol0: &a0 ['lol']\n"
        for i in range(1, anchors):
            text += f"lol{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]\n"
        return text + HEAD + _field(0, "int16(hr:0)")
    if kind == "scalar":
        size = draw(st.integers(0, 2 * SMALL_LIMIT))
        where = draw(st.sampled_from(["description", "expression", "id", "unit"]))
        big = draw(st.sampled_from(["x", "9", " + int16(hr:0)", "(", "\\\\", "'"])) * max(1, size // 10)
        big = big.replace('"', "")
        if where == "description":
            return 'description: "' + big.replace("\\", "/") + '"\n' + HEAD + _field(0, "int16(hr:0)")
        if where == "expression":
            return HEAD + _field(0, "int16(hr:0)" + big.replace("\\", "/").replace("'", ""))
        if where == "unit":
            return HEAD + _field(0, "int16(hr:0)", f'        unit: "{big.replace(chr(92), "/")}"\n')
        return HEAD + f"      - id: '{big.replace(chr(39), 'q')}'\n        expression: 'int16(hr:0)'\n"
    if kind == "many":
        n = draw(st.integers(0, 1500))
        return HEAD + "".join(_field(i, f"int16(hr:{i % 70000})") for i in range(n))
    if kind == "chain":
        n = draw(st.integers(1, 200))
        return HEAD + _field(0, "int16(hr:0)") + "".join(_field(i, f"F{i - 1} + F{i - 1}") for i in range(1, n))
    n = draw(st.integers(0, 300))
    tests = "tests:\n" + "".join(
        f"  - id: 'T{t}'\n    input:\n      - firstRegisterAddress: 'hr:0'\n        registers: '{t % 3:04x}'\n"
        "    blocks:\n      - id: 'M'\n        expected:\n          F0: 1\n"
        for t in range(n)
    )
    return HEAD + _field(0, "int16(hr:0)") + tests


@settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(hostile())
def test_hostile_toolkit_files_import_or_are_refused(tmp_path_factory, monkeypatch, text):
    monkeypatch.setattr(yamlnodes, "MAX_FILE_BYTES", SMALL_LIMIT)
    path = Path(tmp_path_factory.mktemp("tk")) / "hostile.yaml"
    path.write_text(text, encoding="utf-8")
    try:
        resolved = resolve(toolkit.read_schema(path), str(path))
    except MdlError as exc:
        assert exc.diagnostics and all(d.file == str(path) for d in exc.diagnostics), exc
        if "larger than" in str(exc):  # else an error found before the limit, with its line
            assert len(text.encode()) > SMALL_LIMIT and "larger than 60,000 bytes" in str(exc)
        elif len(text.encode()) > SMALL_LIMIT:
            assert all(d.line for d in exc.diagnostics), exc
        return
    assert len(text.encode()) <= SMALL_LIMIT
    evaluator = Evaluator(resolved)
    for sc in resolved.device.tests:
        for failure in run_scenario(evaluator, sc):
            assert failure.function == "F0"


@pytest.mark.parametrize("anchors", [1, 3])
def test_aliases_are_refused_wherever_they_are(tmp_path, anchors):
    text = (
        "lol0: &a0 ['lol']\n"
        + "".join(f"lol{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]\n" for i in range(1, anchors))
        + HEAD
    )
    path = tmp_path / "alias.yaml"
    path.write_text(text + _field(0, "int16(hr:0)"))
    if anchors == 1:  # an anchor without an alias is plain YAML: read, the unknown key ignored
        assert [fn.name for fn in toolkit.read_schema(path).functions] == ["F0"]
        return
    with pytest.raises(MdlError, match=r"alias.yaml:2:\d+: error: YAML aliases are not supported"):
        toolkit.read_schema(path)
