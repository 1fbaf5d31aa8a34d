"""The WISE-Agent guide's SenML (SPEC 7, 9): `mdl read --format senml` once and polling (bt), `mdl export --to
senml` (the capability document, no device), and `precision` in `mdl read`'s table output only (SPEC 2.2)."""

from __future__ import annotations

import json
import re

from support.common import DATA, ROOT, fn_xml
from support.run import cli, run_mdl

ALL = DATA / "all_tables.xml"
SEED = ROOT / "examples" / "wise_4012e" / "Modbus.ini"
HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"
VALUE_KEYS = ("v", "bv", "sv")


def test_read_senml_shape(sim_factory, tmp_path):
    """One object per block label (the device name for functions without one); entries n, v|bv|sv, u, min, max,
    asm; a null has no value; enumeration text and a bitset's labels are sv."""
    raw = tmp_path / "raw.json"
    raw.write_text(json.dumps({"input": {"10": 65535}, "coil": {"1": 1}, "holding": {"100": 215, "101": 2}}))
    sim = sim_factory(ALL, "--registers", raw)
    proc = cli("read", ALL, *sim.connection, "fan", "voltage", "setpoint", "mode", "label", "--format", "senml")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {
        "All Tables": {
            "bn": "All Tables",
            "e": [
                {"n": "fan", "bv": True, "asm": "rw"},
                {"n": "voltage", "u": "V", "asm": "r"},
                {"n": "setpoint", "v": 21.5, "u": "°C", "min": 5, "max": 35, "asm": "rw"},
                {"n": "mode", "sv": "Cool", "asm": "rw"},
                {"n": "label", "sv": "", "asm": "rw"},
            ],
        }
    }
    assert '"min": 5,' in proc.stdout and '"max": 35,' in proc.stdout  # as the guide writes them


def test_read_senml_blocks_and_names_inside_them(sim_factory, tmp_path):
    xml = tmp_path / "heat_pump.xml"
    assert cli("import", HEAT_PUMP, "-o", xml).returncode == 0
    sim = sim_factory(xml, "--scenario", "Heating")
    doc = json.loads(cli("read", xml, *sim.connection, "--format", "senml").stdout)
    assert list(doc) == ["Status", "Energy"]
    status = {e["n"]: e for e in doc["Status"]["e"]}
    assert status["Mode"] == {"n": "Mode", "sv": "Heating", "asm": "r"}
    assert status["FlowTemperature"] == {"n": "FlowTemperature", "v": 35.5, "u": "degC", "asm": "r"}
    assert status["Alarms"] == {"n": "Alarms", "sv": "", "asm": "r"}
    assert doc["Energy"]["bn"] == "Energy" and [e["n"] for e in doc["Energy"]["e"]] == ["Power", "Energy"]


def test_read_senml_names_an_entry_by_its_name_inside_the_block(sim_factory, write_device):
    path = write_device(
        fn_xml("Pump.Speed", "0", format="UINT16", block_label="Pump")
        + fn_xml("Fan.Speed", "1", format="UINT16", block_label="Fan")
        + fn_xml("Speed", "2", format="UINT16", block_label="Fan")
    )
    sim = sim_factory(path)
    doc = json.loads(cli("read", path, *sim.connection, "--format", "senml").stdout)
    assert [e["n"] for e in doc["Pump"]["e"]] == ["Speed"]
    assert [e["n"] for e in doc["Fan"]["e"]] == ["Fan.Speed", "Speed"]  # "Speed" twice would not say which


def test_polling_senml_has_bt_in_every_block(sim_factory):
    sim = sim_factory(SEED, "--set", "Voltage0=4.645")
    proc = run_mdl("read", SEED, *sim.connection, "--interval", "0.2", "--count", "2", "--format", "senml", timeout=30)
    assert proc.returncode == 0, proc.stderr
    documents = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(documents) == 2
    for doc in documents:
        assert list(doc) == ["Digital Input", "Digital Output", "Analog Input"]
        times = {block["bt"] for block in doc.values()}
        assert len(times) == 1 and isinstance(times.pop(), float)
        assert all(list(block) == ["bn", "bt", "e"] for block in doc.values())
    assert documents[0]["Analog Input"]["e"][0] == {
        "n": "Voltage0",
        "v": 4.645,
        "u": "V",
        "min": 0,
        "max": 5,
        "asm": "r",
    }
    assert documents[1]["Digital Input"]["bt"] > documents[0]["Digital Input"]["bt"]


def test_export_senml_is_the_capability_document(tmp_path):
    """No device: the guide's capability objects, entries n, u, min, max, asm and no value."""
    proc = cli("export", SEED, "--to", "senml")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {
        "Digital Input": {"bn": "Digital Input", "e": [{"n": "Switch0", "asm": "r"}, {"n": "Switch1", "asm": "r"}]},
        "Digital Output": {"bn": "Digital Output", "e": [{"n": "LED0", "asm": "rw"}, {"n": "LED1", "asm": "rw"}]},
        "Analog Input": {
            "bn": "Analog Input",
            "e": [
                {"n": "Voltage0", "u": "V", "min": 0, "max": 5, "asm": "r"},
                {"n": "Voltage1", "u": "V", "min": 0, "max": 5, "asm": "r"},
            ],
        },
    }
    out = tmp_path / "capability.json"
    assert cli("export", SEED, "--to", "senml", "-o", out).returncode == 0
    assert out.read_text() == proc.stdout
    proc = cli("export", SEED, "--to", "senml", "--host", "192.0.2.1")
    assert "note: the capability document describes the functions" in proc.stderr


def test_capability_matches_what_read_prints(sim_factory):
    """The same objects as `mdl read --format senml`, values left out; a write-only function is asm w."""
    proc = cli("export", ALL, "--to", "senml")
    assert proc.returncode == 0, proc.stderr
    capability = json.loads(proc.stdout)["All Tables"]["e"]
    assert {"n": "alarm_reset", "asm": "w"} in capability
    sim = sim_factory(ALL)
    read = json.loads(cli("read", ALL, *sim.connection, "--format", "senml").stdout)["All Tables"]["e"]
    without_values = [{k: v for k, v in e.items() if k not in VALUE_KEYS} for e in read]
    assert without_values == [e for e in capability if e["n"] != "alarm_reset"]
    assert not any(k in e for e in capability for k in VALUE_KEYS)
    assert cli("export", ALL, "--to", "senml").stdout == proc.stdout  # deterministic


# --- precision (SPEC 2.2: decimal places to show; mdl read's table only) ------------------------------------

PRECISE = (
    fn_xml("temperature", "0", format="INT16", multiplier="0.01", units="&#176;C").replace(
        "</units>", "</units>\n    <precision>1</precision>"
    )
    + fn_xml("energy", "1", format="UINT16").replace("</format>", "</format>\n    <precision>-2</precision>")
    + fn_xml("ratio", "2", format="UINT16", multiplier="0.5").replace(
        "</multiplier>", "</multiplier>\n    <precision>3</precision>"
    )
    + fn_xml("plain", "3", format="UINT16", multiplier="0.1")
)


def test_precision_shows_in_the_table_only(sim_factory, write_device):
    path = write_device(PRECISE)
    assert cli("validate", path).returncode == 0
    sim = sim_factory(
        path, "--set", "temperature=21.47", "--set", "energy=1250", "--set", "ratio=3.5", "--set", "plain=8.7"
    )
    table = cli("read", path, *sim.connection)
    assert table.returncode == 0, table.stderr
    assert [line.split() for line in table.stdout.splitlines()] == [
        ["temperature", "21.5", "°C"],
        ["energy", "1200"],
        ["ratio", "3.500"],
        ["plain", "8.7"],
    ]
    assert json.loads(cli("read", path, *sim.connection, "--format", "json").stdout) == {
        "temperature": 21.47,
        "energy": 1250,
        "ratio": 3.5,
        "plain": 8.7,
    }
    csv = cli("read", path, *sim.connection, "--format", "csv").stdout
    assert "temperature,21.47,°C\nenergy,1250,\nratio,3.5,\n" in csv
    senml = json.loads(cli("read", path, *sim.connection, "--format", "senml").stdout)
    assert [e["v"] for e in senml["Test Device"]["e"]] == [21.47, 1250, 3.5, 8.7]


def test_precision_in_polled_table_blocks(sim_factory, write_device):
    path = write_device(PRECISE)
    sim = sim_factory(path, "--set", "temperature=-0.04")
    proc = run_mdl("read", path, *sim.connection, "temperature", "--interval", "0.2", "--count", "1", timeout=30)
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"^temperature +0\.0 °C$", proc.stdout, re.M), proc.stdout  # rounded to zero, no sign


# --- NaN and infinities (SenML's v is a JSON number; JSON has none for them) --------------------------------


def _strict_json(text: str):
    """JSON as the standard has it: NaN, Infinity and -Infinity are not JSON."""

    def refuse(token: str):
        raise AssertionError(f"not JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def test_non_finite_floats(sim_factory, tmp_path, write_device):
    """A FLOAT32 NaN (0x7FC0 0x0000) from mdl sim: senml leaves `v` out, once and polled; json prints the
    string "nan" (valid JSON), csv and the table `nan`; the infinities likewise."""
    raw = tmp_path / "nan.json"
    raw.write_text(json.dumps({"input": {"2": 0x7FC0, "3": 0}}))
    sim = sim_factory(ALL, "--registers", raw)
    proc = cli("read", ALL, *sim.connection, "power", "energy", "--format", "senml")
    assert proc.returncode == 0, proc.stderr
    assert _strict_json(proc.stdout)["All Tables"]["e"] == [
        {"n": "power", "u": "W", "asm": "r"},
        {"n": "energy", "v": 0.0, "u": "kWh", "asm": "r"},
    ]
    polled = run_mdl(
        "read", ALL, *sim.connection, "power", "--interval", "0.2", "--count", "1", "--format", "senml", timeout=30
    )
    assert polled.returncode == 0, polled.stderr
    assert _strict_json(polled.stdout)["All Tables"]["e"] == [{"n": "power", "u": "W", "asm": "r"}]
    assert _strict_json(cli("read", ALL, *sim.connection, "power", "--format", "json").stdout) == {"power": "nan"}
    assert cli("read", ALL, *sim.connection, "power", "--format", "csv").stdout == "name,value,units\npower,nan,W\n"
    assert cli("read", ALL, *sim.connection, "power").stdout.split() == ["power", "nan", "W"]

    path = write_device(
        fn_xml("up", "0", format="FLOAT32", register_type="input")
        + fn_xml("down", "2", format="FLOAT32", register_type="input")
        + fn_xml("fine", "4", format="FLOAT32", register_type="input")
    )
    raw.write_text(json.dumps({"input": {"0": 0x7F80, "1": 0, "2": 0xFF80, "3": 0, "4": 0x3FC0, "5": 0}}))
    sim = sim_factory(path, "--registers", raw)
    doc = _strict_json(cli("read", path, *sim.connection, "--format", "senml").stdout)
    assert doc["Test Device"]["e"] == [
        {"n": "up", "asm": "r"},
        {"n": "down", "asm": "r"},
        {"n": "fine", "v": 1.5, "asm": "r"},
    ]
    assert _strict_json(cli("read", path, *sim.connection, "--format", "json").stdout) == {
        "up": "inf",
        "down": "-inf",
        "fine": 1.5,
    }
    polled = run_mdl("read", path, *sim.connection, "--interval", "0.2", "--count", "1", "--format", "json", timeout=30)
    record = _strict_json(polled.stdout)
    assert (record["up"], record["down"], record["fine"]) == ("inf", "-inf", 1.5)
    assert (
        cli("read", path, *sim.connection, "--format", "csv").stdout == "name,value,units\nup,inf,\ndown,-inf,\n"
        "fine,1.5,\n"
    )
