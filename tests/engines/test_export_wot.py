"""`mdl export --to wot`, proven with node-wot itself (SPEC 11.1, issue 38): @node-wot/core 0.8.16 with
@node-wot/binding-modbus (cached by tests/support/node_engines.py) consumes the exported Thing Description and
reads every property from `mdl sim` (tests/support/wot_client.js): after the mdl: terms (support.wot.described,
as docs/wot.md tells a consumer), each value is `mdl read`'s bit for bit, and each value node-wot cannot read
is one the export warned of, naming the function. A write through node-wot lands as `mdl read` then reads it,
except exactly where the export warns that node-wot writes it wrong. The forms' modv:pollingTime paces
node-wot's polls. Every example's TD and Thing Model, and every profile's Thing Model, validates against the
W3C TD 1.1 and TM JSON schemas node-wot ships (tests/support/wot_schema.js, with node-wot's own Ajv), and
node-wot's own ThingModelHelpers make of the device's Thing Model the TD mdl writes."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

from mdl.profiles.load import shipped
from support.common import EXAMPLE, TESTS
from support.fleet_checks import WIDE, WIDE_RAW
from support.node_engines import NODE_WOT, require_node_engine
from support.raw_images import ALL_TABLES_RAW, TEMCO_RAW
from support.run import run_mdl
from support.wot import (
    ALL_TABLES,
    ARGS,
    DESCRIPTIONS,
    SCALED,
    SCALED_RAW,
    TEMCO,
    WRITES,
    WRITTEN,
    described,
    named_in,
)

pytestmark = pytest.mark.engines

CLIENT = TESTS / "support" / "wot_client.js"
METER_B = EXAMPLE.parent / "profiles" / "meter_b.xml"
SCHEMA = TESTS / "support" / "wot_schema.js"
# the set point in range (node-wot refuses a value outside minimum/maximum: warned, and proven below)
ALL_TABLES_IN_RANGE = {**ALL_TABLES_RAW, "holding": {**ALL_TABLES_RAW["holding"], "100": 215}}
# what node-wot says where it cannot read a value, and the warning that says so
READ_FAILURES = {
    "byteLength": "node-wot reads integers of up to 48 bits",
    "Invalid value according to DataSchema": "node-wot refuses to read a value",
}


def node(script: Path | str, *args: str, timeout: float = 120) -> dict:
    folder = require_node_engine(NODE_WOT)
    env = {**os.environ, "NODE_PATH": str(folder / "node_modules")}
    command = ["node", str(script), *args] if isinstance(script, Path) else ["node", "-e", script, *args]
    proc = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def export(path, *extra) -> subprocess.CompletedProcess:
    proc = run_mdl("export", path, "--to", "wot", *extra)
    assert proc.returncode == 0, proc.stderr
    return proc


def through_node_wot(tmp_path: Path, td_text: str, job: dict) -> dict:
    td = tmp_path / "thing.td.json"
    td.write_text(td_text, encoding="utf-8")
    request = tmp_path / "job.json"
    request.write_text(json.dumps(job), encoding="utf-8")
    return node(CLIENT, str(td), str(request))


def mdl_read(path, sim, unit: str = "1") -> dict:
    proc = run_mdl("read", path, *sim.connection, "--unit", unit, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def same(got, want) -> bool:
    if isinstance(want, str) and isinstance(got, str):
        return got.rstrip("\x00 ") == want  # the padding node-wot keeps (warned)
    if isinstance(want, float) or isinstance(got, float):
        return isinstance(got, (int, float)) and not isinstance(got, bool) and float(got) == float(want)
    return got == want and type(got) is type(want)


@pytest.mark.parametrize(
    ("path", "raw"),
    [(ALL_TABLES, ALL_TABLES_IN_RANGE), (TEMCO, TEMCO_RAW), ("wide", WIDE_RAW), ("scaled", SCALED_RAW)],
    ids=["all_tables", "temco", "wide", "scaled"],
)
def test_node_wot_reads_what_mdl_read_reads(sim_factory, tmp_path, write_device, path, raw):
    if path in ("wide", "scaled"):
        path = write_device("".join(WIDE if path == "wide" else SCALED))
    image = tmp_path / "raw.json"
    image.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", image, "--unit", "4")
    proc = export(path, *sim.connection, "--unit", "4", "--interval", "5")
    td = json.loads(proc.stdout)
    got = through_node_wot(tmp_path, proc.stdout, {"read": None})["read"]
    expected = mdl_read(path, sim, "4")
    readable = [name for name, prop in td["properties"].items() if not prop.get("writeOnly")]
    assert sorted(got) == sorted(readable) and readable
    others = {name: (td["properties"][name], got[name]) for name in readable}
    read = 0
    for name in readable:
        value = described(td["properties"][name], got[name], others)
        if isinstance(value, dict):  # node-wot could not: the export said so, naming the function
            (kind,) = [kind for error, kind in READ_FAILURES.items() if error in value["error"]]
            assert name in named_in(proc.stderr, kind), (name, value, proc.stderr)
            continue
        assert same(value, expected[name]), (name, got[name], value, expected[name])
        read += 1
    assert read >= len(readable) - 2, (read, got)


def test_node_wot_refuses_a_value_outside_the_limits_as_warned(sim_factory, tmp_path):
    image = tmp_path / "raw.json"
    image.write_text(json.dumps(ALL_TABLES_RAW))  # the set point at -20.0, outside 5..35
    sim = sim_factory(ALL_TABLES, "--registers", image)
    proc = export(ALL_TABLES, *sim.connection)
    got = through_node_wot(tmp_path, proc.stdout, {"read": ["setpoint", "mode"]})["read"]
    assert "Invalid value according to DataSchema" in got["setpoint"]["error"]
    assert mdl_read(ALL_TABLES, sim)["setpoint"] == -20.0
    assert "setpoint" in named_in(proc.stderr, "refuses to read a value outside minimum/maximum")


def test_a_write_through_node_wot_lands_as_mdl_reads_it(sim_factory, tmp_path, write_device):
    path = write_device("".join(WRITES))
    sim = sim_factory(path)
    proc = export(path, *sim.connection)
    td = json.loads(proc.stdout)
    result = through_node_wot(tmp_path, proc.stdout, {"write": {k: v for k, (v, _) in WRITTEN.items()}, "read": []})
    expected = mdl_read(path, sim)
    kinds = (
        "a write through node-wot is wrong",
        "puts the bytes in the wrong order",
        "writes integers of up to 32 bits",
    )
    warned = {name for kind in kinds for name in named_in(proc.stderr, kind)}
    for name, (value, lands) in WRITTEN.items():
        want = described(td["properties"][name], value)
        if lands:
            assert result["wrote"][name] is True, (name, result["wrote"][name])
            assert same(expected[name], want), (name, value, expected[name], want)
        else:  # node-wot writes it wrong or not at all, as the export warned
            assert name in warned, (name, proc.stderr)
            assert result["wrote"][name] is not True or not same(expected[name], want), (name, expected[name])
    assert warned == {name for name, (_, lands) in WRITTEN.items() if not lands} | {"u64"}
    # a text shorter than its registers: node-wot refuses to write it (warned); mdl pads it with NULs
    short = through_node_wot(tmp_path, proc.stdout, {"write": {"text": "AB"}, "read": []})
    assert "Content length does not match" in short["wrote"]["text"]["error"]
    assert named_in(proc.stderr, "writes a text only of exactly the registers' length") == ["text"]
    # and the write node-wot does with function 6 where the description says 16 (warned) lands all the same
    assert named_in(proc.stderr, "writes one register with function 6") == ["single"]


def test_node_wot_polls_at_the_interval(sim_factory, tmp_path):
    sim = sim_factory(ALL_TABLES)
    proc = export(ALL_TABLES, *sim.connection, "--interval", "0.2")
    assert json.loads(proc.stdout)["properties"]["gap_high"]["forms"][0]["modv:pollingTime"] == 200
    observed = through_node_wot(tmp_path, proc.stdout, {"read": [], "observe": "gap_high", "for_ms": 1500})["observed"]
    assert 4 <= len(observed) <= 9 and set(observed) == {0}, observed


def test_every_td_and_thing_model_validates_against_the_w3c_schemas(tmp_path):
    files = []
    for path in DESCRIPTIONS:
        for kind, extra in (("td", ARGS), ("tm", ("--tm",))):
            out = tmp_path / f"{path.stem}.{kind}.json"
            out.write_text(export(path, *extra).stdout, encoding="utf-8")
            files.append(out)
    out = tmp_path / "meter_b.roles.td.json"
    out.write_text(export(METER_B, "--names", "roles", "--profile", "meter", *ARGS).stdout)
    files.append(out)
    for name in shipped():
        out = tmp_path / f"{name}.tm.jsonld"
        proc = run_mdl("profiles", name, "--as", "tm")
        assert proc.returncode == 0, proc.stderr
        out.write_text(proc.stdout, encoding="utf-8")
        files.append(out)
    controls = []  # the controls: the schemas are really applied
    for i, spoil in enumerate((lambda d: d.pop("security"), lambda d: d["properties"]["pump"].update(type="register"))):
        doc = json.loads((tmp_path / "all_tables.td.json").read_text())
        spoil(doc)
        controls.append(tmp_path / f"control{i}.json")
        controls[-1].write_text(json.dumps(doc))
    found = node(SCHEMA, *map(str, files + controls))
    assert {Path(f).name for f, errors in found.items() if errors} == {"control0.json", "control1.json"}, found
    assert "security" in found[str(controls[0])][0] and "type" in found[str(controls[1])][0]


TM_TO_TD = r"""
const fs = require("fs");
const { ThingModelHelpers } = require("@node-wot/td-tools");
const [model, map] = process.argv.slice(1).map((file) => JSON.parse(fs.readFileSync(file, "utf8")));
new ThingModelHelpers().getPartialTDs(model, { map }).then((tds) => {
    process.stdout.write(JSON.stringify(tds[0]) + "\n");
});
"""


@pytest.mark.parametrize("path", [ALL_TABLES, TEMCO], ids=lambda p: p.stem)
def test_node_wot_makes_the_td_of_the_thing_model(tmp_path, path):
    model = tmp_path / "model.json"
    model.write_text(export(path, "--tm").stdout, encoding="utf-8")
    values = tmp_path / "map.json"
    values.write_text(
        json.dumps({"HOST": "192.0.2.10", "PORT": 1502, "UNIT_ID": 7, "POLLING_TIME": 5000, "TIMEOUT": 1500})
    )
    made = node(TM_TO_TD, str(model), str(values))
    td = json.loads(
        export(
            path, "--host", "192.0.2.10", "--port", "1502", "--unit", "7", "--interval", "5", "--timeout", "1.5"
        ).stdout
    )
    assert made["properties"] == td["properties"]
    assert made["title"] == td["title"] and made["security"] == td["security"]


def test_node_wot_is_the_pinned_version():
    folder = require_node_engine(NODE_WOT)
    for package in ("core", "binding-modbus", "td-tools"):
        meta = json.loads((folder / "node_modules" / "@node-wot" / package / "package.json").read_text())
        assert meta["version"] == "0.8.16", (package, meta["version"])
