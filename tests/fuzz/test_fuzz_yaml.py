"""Fuzzing the Toolkit YAML reader: any file, however mangled, nested or aliased, either imports as
a device whose scenarios `mdl test` can run, or is refused with an MdlError naming the file,
never another exception."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mdl.device.server.scenarios import run_scenario
from mdl.diagnostics import MdlError
from mdl.exchange.yamlnodes import MAX_YAML_DEPTH
from mdl.formats.toolkit.read import import_schema

EXAMPLE = (Path(__file__).resolve().parents[2] / "examples" / "toolkit_heat_pump" / "heat_pump.yaml").read_text()
MINIMAL = """description: 'x'
blocks:
  - id: 'M'
    fields:
      - id: 'F'
        expression: 'int16(hr:0)'
tests:
  - id: 'T'
    input:
      - firstAddress: 'hr:0'
        rawValues: 0001
    blocks:
      - id: 'M'
        expected:
          F: [ 1 ]
"""
PIECES = [
    "\n",
    " ",
    "  ",
    "- ",
    ": ",
    "-",
    ":",
    ",",
    "[",
    "]",
    "{",
    "}",
    "? ",
    "#",
    "&a ",
    "*a",
    "!!str ",
    "!x ",
    "'",
    '"',
    "|\n",
    ">\n",
    "---\n",
    "...\n",
    "%YAML 1.1\n",
    "\t",
    "id",
    "blocks",
    "fields",
    "expression",
    "tests",
    "input",
    "expected",
    "firstAddress",
    "rawValues",
    "registers",
    "maxRegistersPerModbusRequest",
    "immutable",
    "true",
    "'hr:0'",
    "'c:65535'",
    "0001 0002",
    "0101",
    "hr:1#3000000000",
    "int16(hr:0)",
    "((((",
    "\u00b2",
    "\x00",
    "\ufeff",
]
SEEDS = [EXAMPLE, MINIMAL]


@st.composite
def mangled(draw: st.DrawFn) -> str:
    """A real Toolkit file with a few pieces inserted, deleted or replaced."""
    text = draw(st.sampled_from(SEEDS))
    for _ in range(draw(st.integers(1, 6))):
        at = draw(st.integers(0, len(text)))
        cut = draw(st.integers(0, 8))
        text = text[:at] + draw(st.sampled_from(PIECES)) + text[at + cut :]
    return text


nested = st.builds(
    lambda opener, closer, n: "description: 'x'\nblocks: " + opener * n + closer * n + "\n",
    st.sampled_from(["[", "{a: ", "[{a: "]),
    st.sampled_from(["]", "}", "}]"]),
    st.integers(0, 3 * MAX_YAML_DEPTH),
)
soup = st.lists(st.sampled_from(PIECES), max_size=40).map("".join)
documents = st.one_of(mangled(), nested, soup, st.text(max_size=200))


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(documents)
def test_yaml_imports_or_is_refused_with_an_mdl_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "fuzz.yaml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        device = import_schema(path)
    except MdlError as exc:
        assert all(d.file == str(path) for d in exc.diagnostics), exc
        event("refused")
        return
    event("imported")
    for scenario in device.tests:
        run_scenario(device, scenario)
