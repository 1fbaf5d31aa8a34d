"""Round trips through SmartServer XIF (SPEC 7):

- MDL -> XIF -> MDL for every example and test device description in the repository: the exported
  `.mod`, served by `mdl sim` beside the original with the same raw registers, reads the same value for
  every function XIF can express; every other function is named in a warning, never silently dropped.
- XIF -> MDL -> XIF -> MDL for every `.mod` in the repository: the second import is the first one,
  function for function, down to each value's IR, and `mdl sim` reads the same values from both.

One `mdl sim` serves all the devices a test compares (a unit each)."""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest

from mdl.exchange.export import Settings
from mdl.formats.loading import load_any
from mdl.formats.xif.read import read_xif
from mdl.formats.xif.write import export_xif
from mdl.model import Device
from mdl.resolver import ResolvedDevice, resolve
from support.common import DATA, ROOT
from support.export_warnings import said
from support.run import cli, run_mdl

HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"
DESCRIPTIONS = sorted((ROOT / "examples").glob("**/*.xml")) + sorted(DATA.glob("*.xml")) + [HEAT_PUMP]
MOD_FILES = sorted((ROOT / "examples").glob("**/*.mod")) + sorted((DATA / "xif").glob("*.mod"))


def _rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


def as_mdl(path: Path, tmp_path: Path) -> Path:
    """The description as an MDL file (a Toolkit YAML file imported first, as a user would)."""
    if path.suffix != ".yaml":
        return path
    out = tmp_path / (path.stem + ".xml")
    proc = cli("import", path, "-o", out)
    assert proc.returncode == 0, proc.stderr
    return out


def random_registers(resolved: ResolvedDevice, seed: str) -> dict[str, dict[str, int]]:
    """A raw value for every register and bit the device uses, the same for a given seed."""
    rng = random.Random(seed)
    tables: dict[str, dict[str, int]] = {}
    for rf in resolved.functions:
        table = tables.setdefault(rf.layout.table, {})
        for address in rf.layout.addresses:
            table[str(address)] = rng.randrange(2) if rf.layout.unit == "bit" else rng.randrange(1 << 16)
    return tables


def read_all(path: Path, connection: list[str], unit: int) -> dict:
    proc = run_mdl("read", path, *connection, "--unit", unit, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def inexpressible(device: Device) -> set[str]:
    """Functions with something SPEC 7 lists XIF cannot express: an expression, a fragment, an
    enumeration, "not implemented" values, write-only access."""
    return {
        fn.name
        for fn in device.functions
        if fn.expression is not None
        or fn.read_function_code
        or fn.write_function_code
        or fn.values
        or fn.not_implemented
        or fn.access == "write"
    }


@pytest.mark.parametrize("source", DESCRIPTIONS, ids=_rel)
def test_mdl_to_xif_to_mdl_reads_the_same_values(source, tmp_path, sim_factory):
    mdl_file = as_mdl(source, tmp_path)
    mod = tmp_path / (mdl_file.stem + ".mod")
    proc = cli("export", mdl_file, "--to", "xif", "-o", mod)
    assert proc.returncode == 0, proc.stderr
    warned = {name for d in said(proc.stderr) if d["severity"] == "warning" for name in d["names"]}
    original = resolve(load_any(mdl_file), str(mdl_file))
    assert inexpressible(original.device) <= warned, proc.stderr
    again = load_any(mod)
    exported = {fn.name for fn in again.functions}
    readable = {rf.name for rf in original.functions if rf.fn.readable}
    assert readable - exported <= warned, "dropped without a warning"
    assert exported <= {fn.name for fn in original.device.functions}
    if not again.functions:
        assert original.device.functions and {fn.name for fn in original.device.functions} <= warned
        return
    values = random_registers(original, _rel(source))
    raw, raw_again = tmp_path / "raw.json", tmp_path / "raw_again.json"
    raw.write_text(json.dumps(values))
    used = random_registers(resolve(again, str(mod)), "")  # the same registers, where the .mod has them
    raw_again.write_text(json.dumps({t: {a: values[t][a] for a in regs} for t, regs in used.items()}))
    sim = sim_factory([mdl_file, mod], "--unit", "1", "--unit", "2", "--registers", raw, "--registers", raw_again)
    before, after = read_all(mdl_file, sim.connection, 1), read_all(mod, sim.connection, 2)
    # an enumeration reads its label and "not implemented" null where the .mod reads the number: both warned
    differ = {fn.name for fn in original.device.functions if fn.values or fn.not_implemented}
    compared = [name for name in after if name in before and name not in differ]  # write-only: not read before
    assert len(compared) >= len(after) / 2, (compared, after)
    assert {name: after[name] for name in compared} == {name: before[name] for name in compared}


def test_every_description_of_the_repository_is_covered():
    names = {p.name for p in DESCRIPTIONS}
    assert {"temco_tstat.xml", "all_tables.xml", "heat_pump.yaml"} <= names


def _value_fields(device: Device) -> list[tuple]:
    return [
        (
            fn.name,
            fn.description,
            fn.addresses,
            fn.register_type,
            fn.format,
            fn.length,
            fn.count,
            fn.byte_order,
            fn.word_order,
            fn.multiplier,
            fn.offset,
            fn.access,
            fn.minimum,
            fn.maximum,
            fn.marker,
            fn.precision,
            fn.write_multiple,
            fn.block_labels,
        )
        for fn in device.functions
    ]


def test_xif_to_mdl_to_xif_to_mdl_keeps_every_value(tmp_path, sim_factory):
    firsts, seconds, raws = [], [], []
    for i, mod in enumerate(MOD_FILES):
        first = resolve(read_xif(mod), str(mod))
        export = export_xif(first, Settings())
        assert not [w for w in export.warnings if w.severity == "warning"], export.warnings
        again = tmp_path / f"{i}_{mod.name}"
        again.write_text(export.text or "", encoding="utf-8", newline="")
        second = resolve(read_xif(again), str(again))
        dev1, dev2 = first.device, second.device
        assert _value_fields(dev2) == _value_fields(dev1), mod
        assert [rf.codec for rf in second.functions] == [rf.codec for rf in first.functions], mod
        assert (dev2.description, dev2.manufacturer, dev2.product, dev2.product_version, dev2.program_id) == (
            dev1.description,
            dev1.manufacturer,
            dev1.product,
            dev1.product_version,
            dev1.program_id,
        )
        raw = tmp_path / f"{i}.json"
        raw.write_text(json.dumps(random_registers(first, _rel(mod))))
        firsts.append(mod)
        seconds.append(again)
        raws.append(raw)
    files = firsts + seconds
    units = [arg for n in range(1, len(files) + 1) for arg in ("--unit", str(n))]
    sim = sim_factory(files, *units, *[arg for raw in raws + raws for arg in ("--registers", raw)])
    for n, (mod, again) in enumerate(zip(firsts, seconds, strict=True), start=1):
        before = read_all(mod, sim.connection, n)
        assert before, mod
        assert read_all(again, sim.connection, n + len(firsts)) == before, mod


def test_every_mod_file_of_the_repository_is_covered():
    assert {p.name for p in MOD_FILES} >= {"meter.mod", "adam4150_legacy.mod", "excel_meter.mod", "strings_bytes.mod"}
