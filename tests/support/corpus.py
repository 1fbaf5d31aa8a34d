"""One home for the corpus tests (tests/test_corpus_*.py): a real published table and the INI a user
wrote for it from docs/ go through `mdl csv2xml`, the description is served by `mdl sim` with raw
registers computed by hand from the vendor's documented encoding, and `mdl read` must give the values
the vendor's documentation says those registers mean. Sources and licences: tests/data/corpus/README.md."""

from __future__ import annotations

import json
from pathlib import Path

from support.common import DATA
from support.run import cli, run_mdl
from support.tables import functions

CORPUS = DATA / "corpus"


def convert(tmp_path: Path, table: Path, ini: Path | None, *args: str):
    """csv2xml of TABLE (with INI) to tmp_path/out.xml: (proc, {name: {field: text}}, xml path)."""
    out = tmp_path / "out.xml"
    extra = ["--ini", ini] if ini else []
    proc = cli("csv2xml", table, *extra, "-o", out, *args)
    return proc, (functions(out.read_text()) if out.exists() else {}), out


def read_served(sim_factory, xml: Path, registers: dict, *names: str) -> dict:
    """Serve XML with the raw image REGISTERS ({"holding": {"addr": value}, "input": …, "coil": …,
    "discrete": …}) and read NAMES back with `mdl read --format json`."""
    raw = xml.parent / "raw.json"
    raw.write_text(json.dumps(registers))
    sim = sim_factory(xml, "--registers", raw)
    proc = run_mdl("read", xml, "--host", sim.host, "--port", sim.port, *names, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def check_table(tmp_path, sim_factory, table: Path, ini: Path | None, registers: dict, expected: dict, *args: str):
    """The whole chain for one table: csv2xml (with ARGS) exits 0, every EXPECTED function is in the
    description, and each reads back exactly the EXPECTED value. Returns (proc, functions)."""
    proc, fns, xml = convert(tmp_path, table, ini, *args)
    assert proc.returncode == 0, proc.stderr
    missing = sorted(set(expected) - set(fns))
    assert not missing, f"functions not converted: {missing}\n{proc.stderr}"
    values = read_served(sim_factory, xml, registers, *expected)
    assert values == expected, proc.stderr
    return proc, fns
