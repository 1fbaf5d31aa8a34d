"""Modbus Schema Toolkit: the 59 reference scenarios through `mdl test` (YAML and imported MDL),
the generated Python driver and the generated C++ driver against `mdl sim --scenario`."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from pymodbus.client import ModbusTcpClient

from mdl.device.server.scenarios import matches
from mdl.formats.loading import load_any, load_resolved
from support.common import REFERENCE, ROOT
from support.cpp_harness import Harness, build
from support.devices import Sim
from support.drivers import python_device
from support.run import assert_clean_error, cli, run_mdl

FILES = sorted(REFERENCE.glob("*.yaml"))
TOTAL_SCENARIOS = 59
HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"
reference = pytest.mark.conformance("modbus-schema-reference")


def test_heat_pump_example_passes_its_own_scenarios():
    proc = cli("test", HEAT_PUMP)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.splitlines()[-1] == "2 passed, 0 failed"


@reference
def test_reference_files_are_all_there():
    assert len(FILES) == 13
    assert sum(len(load_any(f).tests) for f in FILES) == TOTAL_SCENARIOS


@reference
def test_mdl_test_on_yaml():
    proc = cli("test", *FILES)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.splitlines()[-1] == f"{TOTAL_SCENARIOS} passed, 0 failed"


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    out = tmp_path_factory.mktemp("imported")
    paths = []
    for f in FILES:
        target = out / f"{f.stem}.xml"
        proc = cli("import", f, "-o", target)
        assert proc.returncode == 0, proc.stderr
        paths.append(target)
    return paths


@reference
def test_imported_mdl_validates_and_passes(imported):
    proc = cli("validate", *imported)
    assert proc.returncode == 0, proc.stderr
    assert all(
        "valid MDL 1.0 (extensions:" in line and "expression" in line and "tests" in line
        for line in proc.stdout.splitlines()
    )
    proc = cli("test", *imported)
    assert proc.returncode == 0, proc.stdout
    assert proc.stdout.splitlines()[-1] == f"{TOTAL_SCENARIOS} passed, 0 failed"


@reference
def test_failures_are_reported_with_scenario_field_expected_and_got(tmp_path):
    text = (REFERENCE / "Float.yaml").read_text()
    text = text.replace("Float32_NI      : [ 1234.567 ]", "Float32_NI      : [ 1234.568 ]")
    path = tmp_path / "Float.yaml"
    path.write_text(text)
    proc = cli("test", path)
    assert proc.returncode == 1
    assert (
        f"{path}: test 'Float: Normal values': Float32_NI: expected ['1234.568'], got ['1234.5670166015625']"
        in proc.stdout
    )
    assert proc.stdout.splitlines()[-1] == "4 passed, 1 failed"


@pytest.mark.compile  # builds generated C++/C: heavier than its folder
@pytest.mark.parametrize(
    "yaml_file", [*(pytest.param(f, marks=reference) for f in FILES), HEAT_PUMP], ids=lambda p: p.stem
)
def test_scenarios_through_generated_drivers(yaml_file, tmp_path):
    """One simulator per file serves scenario k at unit k (k = 1, 2, ...); the Python driver and the C++
    harness read every unit."""
    device = load_resolved(yaml_file).device
    driver_cls = python_device(device, tmp_path)
    exe = build(device, tmp_path)
    sim = Sim([yaml_file] * len(device.tests), *[arg for sc in device.tests for arg in ("--scenario", sc.id)])
    try:
        client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
        assert client.connect()
        try:
            values = {("python", unit): driver_cls(client, unit=unit).read_all() for unit in sim.units}
        finally:
            client.close()
        for unit in sim.units:
            harness = Harness(exe, sim.port, unit=unit)
            try:
                values[("c++", unit)] = harness.values()
            finally:
                harness.close()
    finally:
        sim.stop()
    scenarios = dict(zip(sim.units, device.tests, strict=True))
    for (language, unit), got in values.items():
        sc = scenarios[unit]
        for name, want in sc.expected.items():
            assert matches(got[name], want), (sc.id, name, language, got[name], want)


@pytest.mark.commands  # serves or dials a device
@reference
def test_mdl_read_evaluates_expressions(sim_factory, tmp_path):
    path = REFERENCE / "QuickTestDevice.yaml"
    mdl_file = tmp_path / "q.xml"
    assert cli("import", path, "-o", mdl_file).returncode == 0
    sim = sim_factory(mdl_file, "--scenario", "Normal values")
    proc = run_mdl(
        "read",
        mdl_file,
        "--host",
        sim.host,
        "--port",
        sim.port,
        "MyEnum",
        "MyBitset1",
        "Boolean Field Reference",
        "CombinedNumerical",
        "MyFloatNI",
        "--format",
        "json",
    )
    assert proc.returncode == 0, proc.stderr
    values = json.loads(proc.stdout)
    assert values["MyEnum"] == "Manual" and values["MyBitset1"] == ["Zero", "One", "Two", "Bit 3", "Bit 12"]
    assert values["Boolean Field Reference"] == "Foo<false> and Bar<No>"
    assert round(values["CombinedNumerical"], 3) == -61.732


@reference
def test_max_registers_per_request_is_honoured(tmp_path):
    resolved = load_resolved(REFERENCE / "QuickTestDevice.yaml")
    assert resolved.device.max_registers == 42
    from mdl.plan import plan_reads

    assert all(r.count <= 42 for r in plan_reads(resolved.device, layouts=resolved.layouts))
    assert 'max_registers="42"' in cli("import", REFERENCE / "QuickTestDevice.yaml").stdout


def _schema(tmp_path, expression: str, extra_field: str = "") -> Path:
    path = tmp_path / "bad.yaml"
    path.write_text(f"""description: 'bad'
blocks:
  - id: 'Main'
    fields:
      - id: 'Good'
        expression: 'int16(hr:0)'
      - id: 'Bad'
        expression: "{expression}"
{extra_field}""")
    return path


@pytest.mark.parametrize(
    "expression, col, message",
    [
        ("int16(hr:0 ++ 1", 12, "expected ')'"),
        ("Good + Nosuch", 8, "unknown field 'Nosuch'"),
        ("int16(hr:0, ir:1)", 13, "mix register tables"),
        ("utf8(hr:0#126)", 1, "at most 125"),
        ("int32(hr:0#2; 0xDEAD)", 1, "'not implemented' value of 1 register(s) for 2"),
        ("int32(hr:0)", 7, "int32 needs 2 registers, got 1"),
        ("concat('a') * 2", 1, "arithmetic needs numbers"),
        ("hexstring(hr:0, hr:2)", 11, "consecutive"),
    ],
)
def test_expression_errors_name_file_line_and_column(tmp_path, expression, col, message):
    path = _schema(tmp_path, expression)
    col += 21  # the expression's text starts in column 22 of its line, after the quote
    for command in ("import", "test"):
        assert_clean_error(cli(command, path), 1, f"{path}:8:{col}: error: field 'Bad' of block 'Main':", message)


def test_sim_reports_expression_errors(tmp_path):
    path = _schema(tmp_path, "Good + Nosuch")
    assert_clean_error(
        run_mdl("sim", path, "--port", "0"),
        1,
        f"{path}:8:29: error: field 'Bad' of block 'Main':",
        "unknown field 'Nosuch'",
    )


def test_mdl_validate_lists_every_expression_problem(tmp_path):
    xml = tmp_path / "x.xml"
    text = cli("import", _schema(tmp_path, "Good + 1")).stdout
    text = text.replace("<expression>Good + 1</expression>", "<expression>Good + Nosuch</expression>")
    text = text.replace("<expression>int16(hr:0)</expression>", "<expression>int16(hr:0; 0xDE 0xAD)</expression>")
    xml.write_text(text)
    proc = cli("validate", xml)
    assert proc.returncode == 1
    errors = [line for line in proc.stderr.splitlines() if "error:" in line]
    unknown = r":\d+:24: error: function 'Bad': expression: unknown field 'Nosuch'"  # <expression> at column 5
    assert any(re.search(unknown, e) for e in errors), errors
    not_implemented = "function 'Good': expression: a 'not implemented' value of 2 register(s) for 1"
    assert any(not_implemented in e for e in errors), errors


def test_bad_yaml(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("description: 'x'\nblocks: [\n")
    assert_clean_error(cli("import", path), 1, f"{path}:3:", "malformed YAML")
    path.write_text("- just\n- a list\n")
    assert_clean_error(cli("test", path), 1, "not a Modbus Schema Toolkit file")
    assert_clean_error(cli("import", tmp_path / "none.yaml"), 1, "no such file")
    assert_clean_error(run_mdl("sim", HEAT_PUMP, "--port", "0", "--scenario", "nope"), 1, "no test scenario 'nope'")
