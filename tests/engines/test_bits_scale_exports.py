"""Bits of a register and values scaled by another register (SPEC 2.2 `bits`, `scale_exponent`, `scale_by`) in
the exports and the Toolkit import (issue 21), and one warning per kind of loss in the XIF and WISE exports
(issue 20). Each carried feature is proven by the engine's own code reading `mdl sim` where the engine runs
here (VOLTTRON's Modbus-TK driver, Home Assistant's modbus entities), else by the engine's documented
converter (Telegraf's type_conversions_bit.go, as tests/unit/exports/test_export_telegraf.py reads it); each feature an
export cannot carry is one warning naming every function it concerns (docs/bits-and-scale.md, "In other
formats and engines")."""

from __future__ import annotations

import json

import pytest
import tomllib
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from support.common import DATA, fn_xml
from support.export_warnings import assert_one_per_kind, named, said
from support.homeassistant import through_home_assistant
from support.run import cli, run_mdl
from support.telegraf import check_config, telegraf_gather
from support.volttron import map_rows, through_volttron

FLAGS = DATA / "flags_and_scale.xml"
BITS = {"alarm", "mode", "fan_speed", "enabled", "status_high", "low_flag"}
SCALED = {"w", "wmax_lim_pct", "energy"}
# every bit of register 100 in use, 101-102 a little-endian-word UINT32, SunSpec-style factors
RAW = {
    "holding": {
        "100": 0b1000_1010_0010_0001,
        "101": 0x8000,
        "102": 0x0007,
        "103": 0x8000,
        "200": 0xFFFE,
        "201": 1234,
        "202": 4321,
        "203": 0xFFFF,
        "210": 10,
        "211": 0,
        "212": 77,
    }
}


def start(sim_factory, tmp_path, path, raw: dict):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(raw))
    return sim_factory(path, "--registers", registers)


def mdl_read(path, sim) -> dict:
    proc = run_mdl("read", path, *sim.connection, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def with_bits(xml: str, bits: str) -> str:
    """A <function> of fn_xml with <bits> (after every element fn_xml writes, as the schema orders them)."""
    return xml.replace("  </function>", f"    <bits>{bits}</bits>\n  </function>")


# --- VOLTTRON: scale_reg_pow_10 ------------------------------------------------------------------------------


def test_volttron_reads_scale_exponent_through_scale_reg_pow_10(sim_factory, tmp_path):
    sim = start(sim_factory, tmp_path, FLAGS, RAW)
    out = tmp_path / "v"
    proc = run_mdl("export", FLAGS, "--to", "volttron", "-o", out, *sim.connection)
    assert proc.returncode == 0, proc.stderr
    rows = map_rows(out, "flags_and_scale")
    assert rows["w"]["Transform"] == "scale_reg_pow_10(wsf)" and rows["wsf"]["Address"] == "200"
    assert rows["wmax_lim_pct"]["Transform"] == "scale_reg_pow_10(wmaxlimpctsf)"
    got = through_volttron(out, "flags_and_scale")["before"]
    expected = mdl_read(FLAGS, sim)
    assert (expected["w"], expected["wmax_lim_pct"]) == (12.34, 432.1)  # the control: both really scaled
    assert got["w"] == expected["w"] and got["wmax_lim_pct"] == expected["wmax_lim_pct"], got
    assert got["w_sf"] == -2 and got["wmax_lim_pct_sf"] == -1  # the factors keep their point names
    assert not (BITS | {"energy"}) & set(got), got
    assert named(proc.stderr, "VOLTTRON", "bits of a register") == BITS, proc.stderr
    assert named(proc.stderr, "VOLTTRON", "scale_reg(REG) divides") == {"energy"}
    assert named(proc.stderr, "VOLTTRON", "rounds to the decimal places of str(10**e)") == {"w", "wmax_lim_pct"}
    assert named(proc.stderr, "VOLTTRON", "Register Name written without", "note") == {"w_sf", "wmax_lim_pct_sf"}
    assert_one_per_kind(proc.stderr)


def test_volttron_limits_the_export_warns_of_are_real(sim_factory, tmp_path):
    """What the warnings say, shown by the driver: scale_reg divides (so scale_by is left out), and an
    exponent below -4 rounds the value to a whole number (str(1e-05) has no decimal point)."""
    sim = start(sim_factory, tmp_path, FLAGS, {"holding": {**RAW["holding"], "200": 0xFFFB}})  # w_sf = -5
    out = tmp_path / "v"
    assert run_mdl("export", FLAGS, "--to", "volttron", "-o", out, *sim.connection).returncode == 0
    assert mdl_read(FLAGS, sim)["w"] == 0.01234
    assert through_volttron(out, "flags_and_scale")["before"]["w"] == 0.0
    path = out / "flags_and_scale_map.csv"
    text = path.read_text().replace("scale_reg_pow_10(wsf)", "scale_reg(wsf)")
    path.write_text(text)
    assert through_volttron(out, "flags_and_scale")["before"]["w"] == 1234 / -5  # w / v, where scale_by is w * v


# --- Home Assistant: binary_sensor on bit 0 of a register ----------------------------------------------------


def test_home_assistant_binary_sensor_reads_bit_0_of_a_register(sim_factory, tmp_path, write_device):
    path = write_device(
        with_bits(fn_xml("b0", "10", format="UINT16"), "0")
        + with_bits(fn_xml("lo32", "11 12", format="UINT32"), "0")  # bit 0: register 12
        + with_bits(fn_xml("swapped", "13", format="UINT16", byte_order="little"), "8")
        + with_bits(fn_xml("b3", "14", format="UINT16"), "3")
    )
    for raw, state in (({"10": 0xFFFE, "12": 0xFFFE, "13": 0xFFFE}, False), ({"10": 1, "12": 1, "13": 1}, True)):
        sim = start(sim_factory, tmp_path, path, {"holding": {**raw, "11": 1, "14": 8}})
        proc = run_mdl("export", path, "--to", "homeassistant", *sim.connection)
        assert proc.returncode == 0, proc.stderr
        hub = yaml.safe_load(proc.stdout)[0]
        assert [(b["name"], b["address"], b["input_type"]) for b in hub["binary_sensors"]] == [
            ("b0", 10, "holding"),
            ("lo32", 12, "holding"),
            ("swapped", 13, "holding"),
        ]
        expected = mdl_read(path, sim)
        assert expected["b0"] is expected["lo32"] is expected["swapped"] is state and expected["b3"] is True
        shown = through_home_assistant(tmp_path, proc.stdout)["binary_sensors"]
        assert shown == {"b0": state, "lo32": state, "swapped": state}
    assert named(proc.stderr, "Home Assistant", "reads bit 0 of a register only") == {"b3"}
    assert named(proc.stderr, "Home Assistant", "exported read-only (a binary_sensor)") == {"b0", "lo32", "swapped"}


def test_home_assistant_leaves_out_what_it_cannot_read():
    proc = cli("export", FLAGS, "--to", "homeassistant", "--host", "192.0.2.10")
    assert proc.returncode == 0, proc.stderr
    hub = yaml.safe_load(proc.stdout)[0]
    assert [b["name"] for b in hub["binary_sensors"]] == ["alarm"]
    assert named(proc.stderr, "Home Assistant", "reads bit 0 of a register only") == BITS - {"alarm"}
    assert named(proc.stderr, "Home Assistant", "none is read from another register") == SCALED
    assert_one_per_kind(proc.stderr)


# --- Telegraf: BIT fields -------------------------------------------------------------------------------------


def test_telegraf_bit_fields_read_mdl_values(sim_factory, tmp_path, write_device):
    path = write_device(
        with_bits(fn_xml("b0", "10", format="UINT16"), "0")
        + with_bits(fn_xml("b15", "10", format="UINT16"), "15")
        + with_bits(fn_xml("hi", "11 12", format="UINT32", word_order="little"), "20")  # reg 12 bit 4
        + with_bits(fn_xml("sw", "13", format="UINT16", byte_order="little"), "3")  # wire bit 11
        + with_bits(fn_xml("sw_range", "13", format="UINT16", byte_order="little"), "0-3")
        + fn_xml("plain", "14", format="UINT16")
    )
    for raw in (
        {"10": 0x8000, "11": 0xFFFF, "12": 0x0010, "13": 0x0800, "14": 7},
        {"10": 0x7FFF, "11": 0x0000, "12": 0xFFEF, "13": 0xF7FF, "14": 9},
    ):
        sim = start(sim_factory, tmp_path, path, {"holding": raw})
        proc = run_mdl("export", path, "--to", "telegraf", *sim.connection)
        assert proc.returncode == 0, proc.stderr
        config = tomllib.loads(proc.stdout)
        check_config(config)
        got, _ = telegraf_gather(config, sim.host, sim.port)
        expected = mdl_read(path, sim)
        assert got == {name: value for name, value in expected.items() if name != "sw_range"}, (got, expected)
        assert {got["b0"], got["b15"], got["hi"], got["sw"]} == {True, False} or raw["14"] == 9
    fields = {f["name"]: f for r in config["inputs"]["modbus"][0]["request"] for f in r["fields"] if "name" in f}
    assert (fields["hi"]["type"], fields["hi"]["address"], fields["hi"]["bit"]) == ("BIT", 12, 4)
    assert fields["sw"]["type"] == "BIT"
    assert "Needs Telegraf 1.32 or newer" in proc.stdout
    assert named(proc.stderr, "Telegraf", "no field type takes a range of them") == {"sw_range"}


def test_telegraf_leaves_out_ranges_and_scaled_values():
    proc = cli("export", FLAGS, "--to", "telegraf", "--host", "192.0.2.10")
    assert proc.returncode == 0, proc.stderr
    assert named(proc.stderr, "Telegraf", "no field type takes a range of them") == {"mode", "fan_speed", "status_high"}
    assert named(proc.stderr, "Telegraf", "multiplies by another register") == SCALED
    assert_one_per_kind(proc.stderr)


# --- XIF, WISE, SenML: what the formats carry, one warning per kind -------------------------------------------


@pytest.mark.parametrize("to", ["xif", "wise"])
def test_xif_and_wise_leave_bits_and_scale_out_in_one_warning_each(to):
    proc = cli("export", FLAGS, "--to", to)
    assert proc.returncode == 0, proc.stderr
    kinds = {d["kind"]: set(d["names"]) for d in said(proc.stderr) if d["severity"] == "warning"}
    assert BITS in kinds.values() and SCALED in kinds.values(), kinds
    assert_one_per_kind(proc.stderr)
    names_in_output = {n for n in BITS | SCALED if f",{n}," in proc.stdout or f"={n}," in proc.stdout}
    assert not names_in_output, names_in_output


@pytest.mark.parametrize("to", ["xif", "wise"])
@pytest.mark.parametrize("path", [DATA / "all_tables.xml", DATA / "flags_and_scale.xml"], ids=lambda p: p.stem)
def test_xif_and_wise_say_each_kind_once(to, path):
    """Issue 20: the same kind of loss for several functions is one warning naming them, at the first one's line."""
    proc = cli("export", path, "--to", to)
    assert proc.returncode == 0, proc.stderr
    assert said(proc.stderr), proc.stderr  # the control: these lose something in both formats
    assert_one_per_kind(proc.stderr)
    assert any(len(d["names"]) > 1 for d in said(proc.stderr)), proc.stderr


def test_senml_capability_holds_every_function():
    """The capability document describes functions (n, u, min, max, asm), not how they are read: nothing lost."""
    proc = cli("export", FLAGS, "--to", "senml")
    assert proc.returncode == 0 and "warning" not in proc.stderr, proc.stderr
    entries = {e["n"]: e for e in json.loads(proc.stdout)["Flags And Scale"]["e"]}
    assert BITS | SCALED <= set(entries) and entries["energy"]["u"] == "kWh"


# --- Toolkit import: bitsetbit becomes bits -------------------------------------------------------------------

TOOLKIT = """description: bits
blocks:
  - id: b
    fields:
      - id: alarm
        expression: "bitsetbit(hr:100; 3)"
      - id: high
        expression: "bitsetbit(hr:102#2; 17)"
      - id: swapped
        expression: "bitsetbit(hr:105, hr:104; 1)"
      - id: flags
        expression: "bitset(hr:101; 0 -> 'a'; 1 -> 'b')"
"""


def test_toolkit_bitsetbit_is_imported_as_bits(sim_factory, tmp_path):
    source = tmp_path / "bits.yaml"
    source.write_text(TOOLKIT)
    xml = tmp_path / "bits.xml"
    proc = cli("import", source, "-o", xml)
    assert proc.returncode == 0, proc.stderr
    text = xml.read_text()
    assert "<format>UINT16</format>" in text and "<bits>3</bits>" in text and "<bits>17</bits>" in text
    assert text.count("<expression>") == 2 and text.count("<access>read</access>") == 2  # swapped, flags: kept
    raw = {"holding": {"100": 0x0008, "101": 3, "102": 0x0002, "103": 0, "104": 2, "105": 0}}
    for path in (source, xml):
        sim = start(sim_factory, tmp_path, path, raw)
        assert mdl_read(path, sim) == {"alarm": True, "high": True, "swapped": True, "flags": ["a", "b"]}
    config = tomllib.loads(cli("export", xml, "--to", "telegraf", "--host", "h").stdout)
    fields = {f["name"] for r in config["inputs"]["modbus"][0]["request"] for f in r["fields"] if "name" in f}
    assert fields == {"alarm", "high"}  # the engines carry what was an expression; the others stay expressions


# --- random descriptions ------------------------------------------------------------------------------------

_FUNCTION = st.fixed_dictionaries(
    {
        "format": st.sampled_from(["UINT16", "INT16", "UINT32", "INT32", "UINT8"]),
        "bits": st.sampled_from(["0", "3", "7", "8", "15", "0-3", "4-7", "12-15", None]),
    },
    optional={
        "register_type": st.sampled_from(["holding", "input"]),
        "byte_order": st.sampled_from(["big", "little"]),
        "word_order": st.sampled_from(["big", "little"]),
        "access": st.sampled_from(["read", "read_write"]),
        "scaled": st.sampled_from(["scale_exponent", "scale_by"]),
    },
)


def _xml(specs: list[dict]) -> tuple[str, set[str]]:
    """The functions of `specs` after a factor `sf`, and the names of those with bits or a scale register."""
    out, special = fn_xml("sf", "0", format="INT16"), set()
    for i, spec in enumerate(specs):
        fields = {k: v for k, v in spec.items() if k not in ("bits", "scaled")}
        count = 2 if fields["format"].endswith("32") else 1
        body = fn_xml(f"f{i}", " ".join(str(10 + 4 * i + k) for k in range(count)), **fields)
        if spec["bits"] is not None and not (fields["format"] == "UINT8" and int(spec["bits"].split("-")[-1]) > 7):
            body, _ = with_bits(body, spec["bits"]), special.add(f"f{i}")
        elif "scaled" in spec:
            body = body.replace("  </function>", f"    <{spec['scaled']}>sf</{spec['scaled']}>\n  </function>")
            special.add(f"f{i}")
        out += body
    return out, special


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.lists(_FUNCTION, min_size=1, max_size=4),
    st.sampled_from(["xif", "wise", "homeassistant", "telegraf", "volttron"]),
)
def test_random_bits_and_scale_export_or_are_named(tmp_path, write_device, specs, to):
    """Every function with bits or a scale register is carried or named in a warning; one warning per kind."""
    functions, special = _xml(specs)
    path = write_device(functions)
    extra = ["-o", str(tmp_path / "v"), "--force"] if to == "volttron" else []
    proc = cli("export", path, "--to", to, "--host", "192.0.2.10", *extra)
    assert "Traceback" not in proc.stderr
    if proc.returncode == 1:
        assert "error:" in proc.stderr, proc.stderr
        return
    assert proc.returncode == 0, proc.stderr
    assert_one_per_kind(proc.stderr)
    text = proc.stdout if to != "volttron" else next((tmp_path / "v").glob("*_map.csv")).read_text()
    warned = {n for d in said(proc.stderr) if d["severity"] == "warning" for n in d["names"]}
    for name in special - warned:
        assert name in text, (to, name, proc.stderr)  # not named in a warning: carried, then
