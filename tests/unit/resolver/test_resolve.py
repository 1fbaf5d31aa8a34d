"""One resolve step for every source: non-finite numbers refused, positions in the file (inside
expressions and fragments too), warnings printed once and --fail-on-warning on every command."""

from __future__ import annotations

import math

import pytest

from mdl.diagnostics import MdlError
from mdl.formats.loading import load_any, load_resolved
from mdl.model import Device, Function
from mdl.resolver import resolve
from support.common import fn_xml
from support.run import assert_clean_error, cli, run_mdl

# ---- numbers that are not finite


@pytest.mark.parametrize(
    "element, text",
    [
        ("multiplier", "INF"),
        ("multiplier", "-INF"),
        ("multiplier", "NaN"),
        ("multiplier", "1e999"),
        ("offset", "NaN"),
        ("offset", "-1e400"),
        ("minimum", "-INF"),
        ("maximum", "1e999"),
    ],
)
def test_non_finite_numbers_are_refused_at_their_element(write_device, element, text):
    path = write_device(fn_xml("t", "1", format="UINT16", **{element: text}))
    col = len(element) + 7  # "    <element>" then the text
    message = f"{path}:10:{col}: error: function 't': <{element}> {text} is not a finite number"
    for command in (["validate"], ["gen", "--lang", "cpp", "-o", path.parent / "out"], ["test"]):
        assert_clean_error(cli(*command, path), 1, message)
    assert not (path.parent / "out").exists()


def test_non_finite_number_crash_from_the_issue_is_gone(write_device, tmp_path):
    """`<multiplier>INF</multiplier>` passed validate, then `mdl gen --lang cpp` crashed with a traceback."""
    path = write_device(fn_xml("t", "1", format="UINT16", multiplier="INF"))
    assert_clean_error(run_mdl("gen", path, "--lang", "cpp", "-o", tmp_path / "out"), 1, "<multiplier> INF")


@pytest.mark.parametrize("attr", ["multiplier", "offset", "minimum", "maximum"])
@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan])
def test_resolve_refuses_non_finite_numbers_of_a_model_built_in_code(attr, value):
    fn = Function("t", "t", [1], format="UINT16")
    setattr(fn, attr, value)
    with pytest.raises(MdlError) as caught:
        resolve(Device("d", "d", [fn]))
    assert [d.message for d in caught.value.diagnostics] == [
        f"function 't': <{attr}> {'NaN' if math.isnan(value) else 'INF' if value > 0 else '-INF'} "
        "is not a finite number"
    ]


def test_finite_numbers_still_resolve():
    resolve(Device("d", "d", [Function("t", "t", [1], format="UINT16", multiplier=1e300, offset=-1e-300)]))


def test_a_csv_cell_beyond_a_double_is_reported_and_never_read(tmp_path):
    table = tmp_path / "map.csv"
    table.write_text("Address,Description,Multiplier\n0,Room temperature,1e999\n1,Humidity,0.1\n")
    proc = cli("csv2xml", table, "--all")
    assert proc.returncode == 0, proc.stderr
    # a scale cell keeps its row at the default scale (SPEC 4.1), never read as infinity
    assert f"{table}:2: warning: column 2 'Multiplier' multiplier cell '1e999'" in proc.stderr
    assert "multiplier '1e999' is not a finite number" in proc.stderr
    assert "inf" not in proc.stdout.lower() and "<multiplier>0.1</multiplier>" in proc.stdout


# ---- positions: the column in the file, also inside expressions and fragments


def test_fragment_error_points_at_its_column_past_character_references(write_device):
    path = write_device(fn_xml("t", "1", format="UINT16", read_function_code="arg = r1 &amp; 0xFF; arg = foo;"))
    # line 10, "    <read_function_code>" is 24 characters; 'foo' is character 24 of the code, after "&amp;"
    assert_clean_error(
        cli("validate", path),
        1,
        f"{path}:10:{24 + 23 + 4 + 1}: error: function 't': read_function_code: unknown identifier 'foo' (column 24)",
    )


def test_expression_error_on_a_later_line_of_the_element(write_device):
    path = write_device(
        "  <function><name>c</name><description>c</description><addresses>3</addresses>\n"
        "    <expression>int16(hr:3) +\n"
        "  Nosuch</expression></function>\n"
    )
    assert_clean_error(cli("validate", path), 1, f"{path}:7:3: error: function 'c': expression: unknown field 'Nosuch'")


def test_minified_document_positions(tmp_path):
    """Everything on one line: each function's own element is found, not the first of its name."""
    path = tmp_path / "one_line.xml"
    functions = "".join(
        f"<function><name>f{i}</name><description>d</description><addresses>{i}</addresses>"
        f"<expression>int16(hr:{i}) + Nosuch{i}</expression></function>"
        for i in range(3)
    )
    text = (
        f'<device xmlns="http://www.ornl.gov/ModbusXMLSchema" version="1.0"><name>n</name>'
        f"<description>d</description>{functions}</device>"
    )
    path.write_text(text)
    proc = cli("validate", path)
    assert proc.returncode == 1
    for i in range(3):
        col = text.index(f"Nosuch{i}") + 1
        assert f"{path}:1:{col}: error: function 'f{i}': expression: unknown field 'Nosuch{i}'" in proc.stderr


def _toolkit(tmp_path, expression_line: str):
    path = tmp_path / "bad.yaml"
    path.write_text(
        "description: 'bad'\nblocks:\n  - id: 'Main'\n    fields:\n"
        "      - id: 'Good'\n        expression: 'int16(hr:0)'\n"
        f"      - id: 'Bad'\n{expression_line}"
    )
    return path


@pytest.mark.parametrize(
    "expression_line, line, col",
    [
        ("        expression: int16(hr:0) + Nosuch\n", 8, 35),  # plain
        ("        expression: 'Good + Nosuch'\n", 8, 29),  # single-quoted
        ("        expression: 'Good + ''x'' + Nosuch'\n", 8, 37),  # '' is one quote
        ('        expression: "Good + \\u0020 Nosuch"\n', 8, 36),  # an escape is one character
        ('        expression: "Good +\n          Nosuch"\n', 9, 11),  # folded onto the next line
    ],
)
def test_toolkit_expression_errors_point_into_the_yaml_scalar(tmp_path, expression_line, line, col):
    path = _toolkit(tmp_path, expression_line)
    assert_clean_error(cli("test", path), 1, f"{path}:{line}:{col}: error: field 'Bad' of block 'Main': unknown field")


def test_toolkit_literal_beyond_a_double(tmp_path):
    path = _toolkit(tmp_path, "        expression: 'int16(hr:0) * 1e999'\n")
    assert_clean_error(cli("import", path), 1, f"{path}:8:36: error: field 'Bad' of block 'Main':", "too large")


def test_every_error_is_printed_once(write_device, tmp_path):
    path = write_device(fn_xml("a", "1", format="UINT16") + fn_xml("a", "2", format="UINT16", minimum="5", maximum="1"))
    proc = cli("gen", path, "-o", tmp_path / "out")
    assert proc.returncode == 1
    lines = proc.stderr.splitlines()
    assert len(lines) == len(set(lines)) == 2, lines
    assert lines[0].startswith(f"{path}:11:3: error: function 'a': duplicate function name")
    assert lines[1].startswith(f"{path}:11:3: error: function 'a': minimum 5 is above maximum 1")


# ---- sources give the model; load_resolved gives the resolved device


def test_load_any_is_the_model_only_and_load_resolved_checks_it(write_device):
    path = write_device(fn_xml("a", "1", format="UINT16") + fn_xml("a", "2", format="UINT16"))
    assert [fn.name for fn in load_any(path).functions] == ["a", "a"]
    with pytest.raises(MdlError, match="duplicate function name"):
        load_resolved(path)


# ---- warnings, and --fail-on-warning


WARNED = (
    "  <function><name>w</name><description>w</description><addresses>7</addresses>"
    "<expression>int16(hr:0)</expression></function>\n"
)
WARNING = "warning: function 'w': addresses 7 differ from the registers the expression reads (0)"


def test_a_warning_prints_once_and_the_command_goes_on(write_device, tmp_path):
    path = write_device(WARNED)
    proc = cli("validate", path)
    assert proc.returncode == 0 and proc.stderr.count(WARNING) == 1 and "valid MDL 1.0" in proc.stdout
    proc = cli("gen", path, "--lang", "python", "-o", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count(WARNING) == 1 and (tmp_path / "out" / "test_device.py").exists()


@pytest.mark.parametrize(
    "command",
    [
        ["validate"],
        ["gen", "-o", "OUT"],
        ["test"],
        ["read", "--host", "127.0.0.1", "--port", "1"],
        ["write", "--host", "127.0.0.1", "--port", "1", "w=1"],
    ],
)
def test_fail_on_warning_refuses_before_doing_anything(write_device, tmp_path, command):
    path = write_device(WARNED)
    args = [str(tmp_path / "out") if a == "OUT" else a for a in command]
    proc = cli(args[0], path, *args[1:], "--fail-on-warning")
    assert_clean_error(proc, 1, WARNING, f"{path}: error: 1 warning and --fail-on-warning")
    assert proc.stderr.count(WARNING) == 1
    assert not (tmp_path / "out").exists()
    assert "valid MDL" not in proc.stdout


def test_fail_on_warning_stops_sim_before_serving(write_device):
    path = write_device(WARNED)
    assert_clean_error(
        run_mdl("sim", path, "--port", "0", "--fail-on-warning", timeout=30),
        1,
        f"{path}: error: 1 warning and --fail-on-warning",
    )


def test_fail_on_warning_on_csv2xml_writes_nothing(tmp_path):
    table = tmp_path / "map.csv"
    table.write_text("Address,Description,Format\n0,Room temperature,int99\n1,Humidity,UINT16\n")
    out = tmp_path / "out.xml"
    assert cli("csv2xml", table, "--all", "-o", out).returncode == 0 and out.exists()
    out.unlink()
    proc = cli("csv2xml", table, "--all", "-o", out, "--fail-on-warning")
    assert_clean_error(proc, 1, "format cell 'int99': unknown format 'int99'", "1 warning and --fail-on-warning")
    assert not out.exists()


def test_fail_on_warning_without_warnings_changes_nothing(write_device, tmp_path):
    path = write_device(fn_xml("t", "1", format="UINT16"))
    proc = cli("validate", path, "--fail-on-warning")
    assert proc.returncode == 0 and proc.stderr == ""
    schema = _toolkit(tmp_path, "        expression: 'int16(hr:1)'\n")
    proc = cli("import", schema, "--fail-on-warning")
    assert proc.returncode == 0 and proc.stderr == "" and "<addresses>1</addresses>" in proc.stdout


# ---- what an expression may name


@pytest.mark.parametrize(
    "named, why",
    [
        (fn_xml("wo", "1", format="UINT16", access="write"), "field 'wo' it refers to cannot be read (access 'write')"),
        (
            fn_xml("wo", "1 2 3 4", format="UINT64", write_function_code="r1 = arg;"),
            "field 'wo' it refers to has a write fragment: its value is a double in the C++ driver",
        ),
        (
            fn_xml("wo", "1 2 3 4", format="INT64", write_function_code="r1 = arg;"),
            "field 'wo' it refers to has a write fragment",
        ),
    ],
)
def test_an_expression_may_not_name_what_no_driver_reads_exactly(write_device, tmp_path, named, why):
    """A write-only function, and a 64-bit integer with a write fragment (a double in the C++
    driver), are refused where an expression names them: each driver would read them otherwise."""
    path = write_device(named + fn_xml("e", "1", expression="concat(wo, '|')"))
    for command in (["validate"], ["gen", "--lang", "all", "-o", tmp_path / "out"], ["test"]):
        assert_clean_error(cli(*command, path), 1, "error: function 'e':", why)
    assert not (tmp_path / "out").exists()


def test_narrower_integers_with_a_write_fragment_may_be_named(write_device):
    """A 32-bit integer with a write fragment is a double in the C++ driver too, and exact there."""
    path = write_device(
        fn_xml("w", "1 2", format="INT32", write_function_code="r1 = arg;") + fn_xml("e", "1", expression="w + 1")
    )
    proc = cli("validate", path)
    assert proc.returncode == 0, proc.stderr
