"""Fuzzing the fleet inventory reader (SPEC 15, mdl.device.fleet.inventory): any YAML or CSV text, however
mangled, is read (every entry whole and in range, every diagnostic naming the inventory and a line) or
refused with an MdlError naming the file; never another exception."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mdl.device.fleet.inventory import ID, INTERVALS, MAX_UNIT, load_inventory, read_inventory
from mdl.diagnostics import MdlError, error
from mdl.exchange.yamlnodes import MAX_YAML_DEPTH
from mdl.formats.loading import load_resolved
from support.common import DATA

ROOT = Path(__file__).resolve().parents[2]
YAML_SEED = (ROOT / "examples" / "fleet" / "site.yml").read_text(encoding="utf-8")
CSV_SEED = (ROOT / "examples" / "fleet" / "site.csv").read_text(encoding="utf-8")
LOADED_SEED = """defaults: {interval: 1, timeout: 0.5}
devices:
  - {id: a, description: all_tables.xml, connection: rtu+tcp://127.0.0.1:5020, unit: 1, tags: {site: s}}
  - {id: b, description: all_tables.xml, connection: 'rtu+tcp://127.0.0.1:5020#2', interval: 0.5}
  - id: c
    description: all_tables.xml
    connection: tcp://127.0.0.1:5021?retries=0
    tags: k=v;l=w
"""
PIECES = [
    "\n",
    " ",
    "  ",
    "- ",
    ": ",
    ",",
    ";",
    "=",
    "#",
    '"',
    "'",
    "[",
    "]",
    "{",
    "}",
    "&a ",
    "*a",
    "!!str ",
    "|\n",
    "---\n",
    "\t",
    "\r",
    "\x00",
    "\ufeff",
    "\u2028",
    "id",
    "description",
    "connection",
    "unit",
    "interval",
    "profile",
    "tags",
    "timeout",
    "retries",
    "defaults",
    "devices",
    "tcp://",
    "rtu+tcp://",
    "rtu:///dev/ttyUSB0",
    "?baud=9600&parity=E",
    "?timeout=0.01",
    "#3",
    "#999",
    ":502",
    ":0",
    "[::1]",
    "0",
    "0.05",
    "1e9",
    "nan",
    "-1",
    "256",
    "99999999999",
    "meter",
    "../profiles/meter_a.xml",
    "all_tables.xml",
    "a=b;c",
    "site=plant1",
    "x" * 70,
]


@st.composite
def mangled(draw: st.DrawFn, seed: str) -> str:
    """A real inventory with a few pieces inserted, deleted or replaced."""
    text = seed
    for _ in range(draw(st.integers(1, 6))):
        at = draw(st.integers(0, len(text)))
        cut = draw(st.integers(0, 8))
        text = text[:at] + draw(st.sampled_from(PIECES)) + text[at + cut :]
    return text


nested = st.builds(
    lambda opener, closer, n: "devices: " + opener * n + closer * n + "\n",
    st.sampled_from(["[", "{a: ", "[{id: "]),
    st.sampled_from(["]", "}", "}]"]),
    st.integers(0, 3 * MAX_YAML_DEPTH),
)
soup = st.lists(st.sampled_from(PIECES), max_size=40).map("".join)
documents = st.tuples(
    st.one_of(mangled(YAML_SEED), mangled(CSV_SEED), mangled(LOADED_SEED), nested, soup, st.text(max_size=200)),
    st.sampled_from(["fleet.yaml", "fleet.csv"]),
)
ALL = load_resolved(DATA / "all_tables.xml")


def load(path: Path):
    """The descriptions a fuzzed inventory may name: all_tables.xml beside it loads, anything else does not."""
    if path.name == "all_tables.xml":
        return ALL
    raise error("no such file", path)


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(documents)
def test_any_inventory_is_read_or_refused_with_an_mdl_error(tmp_path_factory, document):
    text, name = document
    path = tmp_path_factory.mktemp("fuzz") / name
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        inventory = read_inventory(path)
    except MdlError as exc:
        assert exc.diagnostics and all(d.file == str(path) for d in exc.diagnostics), exc
        event("refused")
        return
    assert all(d.file == str(path) for d in inventory.diagnostics), inventory.diagnostics
    assert all(d.line is None or d.line >= 1 for d in inventory.diagnostics)
    event("read" if inventory.ok else "errors")
    for entry in inventory.entries:
        assert ID.fullmatch(entry.id) and 0 <= entry.unit <= MAX_UNIT
        assert INTERVALS[0] <= entry.interval <= INTERVALS[1]
        assert 0.1 <= entry.connection.timeout <= 600 and 0 <= entry.connection.retries <= 10
        assert entry.line >= 1
    try:
        members, _ = load_inventory(path, load)
    except MdlError as exc:
        assert all(d.file for d in exc.diagnostics), exc  # the inventory's, or a description's own
        assert any(d.file == str(path) and d.line for d in exc.diagnostics), exc
        return
    event("loaded")
    assert inventory.ok and len(members) == len(inventory.entries)
