"""Tiny inputs must not exhaust memory or stack (issue 8): huge register runs, YAML aliases, deep
nesting in expressions and YAML. Each command runs as a user would, capped at 1 GB of address space
and 20 s, so a regression fails here instead of eating the machine."""

from __future__ import annotations

from pathlib import Path

import pytest

from support.capped import run_capped
from support.common import ROOT, device_xml, fn_xml
from support.run import assert_clean_error

EXAMPLE_YAML = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"


def schema(tmp_path: Path, expression: str, tests: str = "") -> Path:
    """A Toolkit file whose field 'F' (its expression on line 8) has the expression; tests from line 9."""
    path = tmp_path / "limits.yaml"
    path.write_text(f"""description: 'limits'
blocks:
  - id: 'Main'
    fields:
      - id: 'G'
        expression: 'int16(hr:0)'
      - id: 'F'
        expression: "{expression}"
{tests}""")
    return path


def deep(opening: str, inner: str, closing: str, n: int) -> str:
    return opening * n + inner + closing * n


# (expression, column, message): each names the spot where the limit is passed
REFUSED = [
    ("utf8(hr:1#3000000000)", 6, "3000000000 addresses are more than one request reads (at most 125 registers"),
    ("utf8(c:0..c:65535)", 6, "65536 addresses are more than one request reads"),
    ("utf8(hr:65530#10)", 6, "address 65539 is over 65535"),
    ("utf8(hr:1..hr:3000000000)", 12, "address 3000000000 is over 65535"),
    ("int16(hr:" + "1" * 5000 + ")", 7, "too large"),
    ("utf8(hr:0#" + "9" * 5000 + ")", 6, "register count '99999999999999999999...' is too large"),
    ("+".join(["int16(hr:0#2000)"] * 40), 551, "the expression lists more than 65536 registers"),
    ("1" * 5000, 1, "this integer does not fit in 64 bits"),
    ("9223372036854775808", 1, "this integer does not fit in 64 bits"),
    ("2 * 1e999", 5, "this number is too large for a double"),
    ("enum(hr:0; " + "7" * 5000 + " -> 'a')", 12, "this value does not fit in 64 bits"),
    (deep("(", "1", ")", 200), 65, "the expression nests more than 64 levels deep"),
    ("-" * 20000 + "1", 65, "the expression nests more than 64 levels deep"),
    ("+".join(["1"] * 3000), 130, "the expression nests more than 64 levels deep"),
    ("2" + "^2" * 3000, 130, "the expression nests more than 64 levels deep"),
    (deep("concat(", "1", ")", 300), 449, "the expression nests more than 64 levels deep"),
    (deep("boolean(", "G", ")", 300), 513, "the expression nests more than 64 levels deep"),
    ("int16(" + deep("swapbytes(", "hr:0", ")", 300) + ")", 637, "the expression nests more than 64 levels deep"),
]


@pytest.mark.parametrize("expression, col, message", REFUSED, ids=[f"{e[:12]}-{c}" for e, c, _ in REFUSED])
def test_expression_limits_through_import_and_test(tmp_path, expression, col, message):
    path = schema(tmp_path, expression)
    col += 21  # the expression's text starts in column 22 of line 8, after the quote
    for command in ("import", "test"):
        assert_clean_error(run_capped(command, path), 1, f"{path}:8:{col}: error: field 'F' of block 'Main': ", message)


ACCEPTED_AT_THE_LIMIT = [
    deep("(", "G", ")", 63),
    "-" * 63 + "G",
    "+".join(["G"] * 64),
    deep("concat(", "G", ")", 64),
    deep("boolean(", "c:0", ")", 64),
    "int16(" + deep("swapbytes(", "hr:0", ")", 63) + ")",
    "G" + "^2" * 64,
]


@pytest.mark.parametrize("expression", ACCEPTED_AT_THE_LIMIT, ids=range(len(ACCEPTED_AT_THE_LIMIT)))
def test_deepest_expressions_still_compile_and_generate(tmp_path, expression):
    """What the limits let through, every later pass (type checks, lowering, both generators) handles."""
    path = schema(tmp_path, expression)
    proc = run_capped("gen", path, "--lang", "all", "-o", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    generated = next((tmp_path / "out").rglob("*.py"))
    compile(generated.read_text(), str(generated), "exec")


def test_expression_limits_in_mdl_xml(tmp_path):
    xml = tmp_path / "deep.xml"
    xml.write_text(
        device_xml(
            fn_xml("f", "0").replace(
                "<addresses>0</addresses>",
                "<addresses>0</addresses>\n    <expression>" + "(" * 500 + "1" + ")" * 500 + "</expression>",
            )
        )
    )
    proc = run_capped("validate", xml)
    assert_clean_error(proc, 1, "function 'f': expression: the expression nests more than 64 levels deep")


BILLION_LAUGHS = (
    "description: 'x'\nblocks: []\n"
    + "a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n"
    + "".join(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]\n" for i in range(1, 10))
)


@pytest.mark.parametrize(
    "text, where, message",
    [
        pytest.param(*case, id=case[2][:20] + "-" + case[1])
        for case in [
            (BILLION_LAUGHS, "4:10", "YAML aliases are not supported"),
            (
                "description: 'x'\nblocks: " + deep("[", "", "]", 3000) + "\n",
                "2:40",
                "YAML nested more than 32 levels deep",
            ),
            (
                "description: 'x'\nblocks: " + deep("[", "", "]", 100000) + "\n",
                "2:40",
                "YAML nested more than 32 levels deep",
            ),
            (
                "blocks:\n" + "".join("  " * i + "- \n" for i in range(1, 3000)),
                "33:",
                "YAML nested more than 32 levels deep",
            ),
            (
                "description: 'x'\nblocks: " + deep("{a: ", "1", "}", 3000) + "\n",
                "2:133",
                "YAML nested more than 32 levels",
            ),
            ("description: 'x'\n? [a, b]\n: 1\nblocks: []\n", "2:3", "a mapping key must be a plain text"),
            ("description: 'x'\nblocks: []\n---\ndescription: 'y'\n", "3:1", "the file must hold one YAML document"),
            (
                "description: 'x'\nmaxRegistersPerModbusRequest: '\u00b2'\nblocks: []\n",
                "2:31",
                "maxRegistersPerModbusRequest must be a whole number from 1 to 125",
            ),
            (
                "description: 'x'\nmaxRegistersPerModbusRequest: " + "9" * 5000 + "\nblocks: []\n",
                "2:31",
                "maxRegistersPerModbusRequest must be a whole number from 1 to 125",
            ),
        ]
    ],
)
def test_yaml_limits(tmp_path, text, where, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    for command in ("import", "test"):
        assert_clean_error(run_capped(command, path), 1, f"{path}:{where}", message)


@pytest.mark.parametrize(
    "tests, where, message",
    [
        pytest.param(
            "  - id: 'T'\n    input:\n      - firstAddress: 'hr:65534'\n        rawValues: 0001 0002 0003\n",
            "13:20",
            "the raw values run past address 65535 (to 65536)",
            id="registers",
        ),
        pytest.param(
            "  - id: 'T'\n    input:\n      - firstAddress: 'c:65535'\n        rawValues: 01\n",
            "13:20",
            "the raw values run past address 65535 (to 65536)",
            id="bits",
        ),
        pytest.param(
            "  - id: 'T'\n    blocks:\n      - id: 'Main'\n        expected:\n          F: [ [ [ 1 ] ] ]\n",
            "14:16",
            "test 'T': an expected value must be a text or a number",
            id="nested-list",
        ),
        pytest.param(
            "  - id: 'T'\n    blocks:\n      - id: 'Main'\n        expected:\n          F: { a: 1 }\n",
            "14:14",
            "test 'T': an expected value must be a text or a number",
            id="mapping",
        ),
    ],
)
def test_scenario_limits(tmp_path, tests, where, message):
    path = schema(tmp_path, "int16(hr:0)", "tests:\n" + tests)
    assert_clean_error(run_capped("test", path), 1, f"{path}:{where}: error: {message}")


def test_the_example_still_passes_capped():
    proc = run_capped("test", EXAMPLE_YAML)
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize(
    "cell, message",
    [
        pytest.param("hr:1#3000000000", "3000000000 addresses are more than one request reads", id="count"),
        pytest.param("0 to 3000000000", "3000000001 addresses are more than one request reads", id="range"),
        pytest.param("hr:" + "1" * 5000, "address '11111111111111111111...' is too large", id="named"),
        pytest.param("4x" + "1" * 5000, "register number '11111111111111111111...' is too large", id="4x"),
        pytest.param("hr:3000000000", "address 3000000000 is over 65535", id="over"),
    ],
)
def test_csv_address_cells_are_sized_before_they_are_built(tmp_path, cell, message):
    table = tmp_path / "table.csv"
    table.write_text(f"Address,Description,Format\n{cell},Huge,uint16\n5,Fine,uint16\n")
    proc = run_capped("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"{table}:2: warning: row skipped: " in proc.stderr and message in proc.stderr, proc.stderr
