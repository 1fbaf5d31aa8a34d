"""`mdl export --to homeassistant`, proven two ways:
- Home Assistant's own modbus configuration schema (homeassistant 2024.3.3, the newest release that installs
  on Python 3.11, in a venv of its own: tests/engines.py) accepts the exported YAML and keeps every entity;
- a reader that follows the YAML's own meaning, as Home Assistant's docs and base_platform.py give it
  (swap byte/word/word_byte, struct unpack, scale * value + offset, nan_value, precision), reads `mdl sim`
  with pymodbus and shows what `mdl read` gives."""

from __future__ import annotations

import json
import struct
import subprocess

import pytest
import yaml
from conftest import DATA, EXAMPLE, assert_clean_error, fn_xml, run_mdl
from engines import HOMEASSISTANT, installed_version, require
from pymodbus.client import ModbusTcpClient

ALL_TABLES = DATA / "all_tables.xml"
TEMCO = EXAMPLE / "temco_tstat.xml"

SCHEMA = r"""
import json, logging, sys
from homeassistant.util.yaml import load_yaml
from homeassistant.components.modbus import CONFIG_SCHEMA

logged = []
class Keep(logging.Handler):
    def emit(self, record):
        logged.append(record.getMessage())
logging.getLogger("homeassistant.components.modbus").addHandler(Keep())
logging.getLogger("homeassistant.components.modbus").setLevel(logging.WARNING)

KINDS = ("sensors", "binary_sensors", "switches")
config = load_yaml(sys.argv[1])
given = [[len(hub.get(kind, [])) for kind in KINDS] for hub in config["modbus"]]
valid = CONFIG_SCHEMA(config)
kept = [[len(hub.get(kind, [])) for kind in KINDS] for hub in valid["modbus"]]
print(json.dumps({"given": given, "kept": kept, "logged": logged, "valid": valid}, default=str))
"""

ALL_TABLES_RAW = {
    "coil": {"0": 1, "1": 0, "5": 1},
    "discrete": {"0": 0, "1": 1},
    "input": {"0": 0x5678, "1": 0x1234, "2": 0x4049, "3": 0x0FDB, "10": 2301},
    "holding": {"50": 65535, "52": 7, "100": 0xFF38, "101": 2, "102": 0x4142, "103": 0x4320, "104": 0, "105": 0,
                "200": 0xFFFF, "201": 0xFFFE, "202": 0x1234, "203": 0x5678, "300": 101, "400": 0x1122,
                "401": 0x3344, "402": 0x7F85, "403": 0xC812},
}
TEMCO_RAW = {"holding": {"6": 0xAB07, "7": 0x0112, "121": 0xFF06, "140": 455, "137": 0x0103, "128": 2,
                         "255": 1, "256": 0, "257": 1, "258": 0, "259": 1, "345": 215, "346": 180, "348": 205}}


def export(path, *extra) -> subprocess.CompletedProcess:
    proc = run_mdl("export", path, "--to", "homeassistant", *extra)
    assert proc.returncode == 0, proc.stderr
    return proc


def validate(tmp_path, text: str) -> subprocess.CompletedProcess:
    python = require(HOMEASSISTANT)
    path = tmp_path / "modbus.yaml"
    path.write_text(text, encoding="utf-8")
    return subprocess.run([str(python), "-c", SCHEMA, str(path)], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("path", [ALL_TABLES, TEMCO])
@pytest.mark.parametrize("connection", [("--host", "192.0.2.10", "--port", "1502"),
                                        ("--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E"),
                                        ("--host", "192.0.2.10", "--framer", "rtu")])
def test_home_assistant_schema_accepts_the_export(tmp_path, path, connection):
    text = export(path, *connection, "--unit", "3", "--interval", "30").stdout
    proc = validate(tmp_path, text)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["given"] == result["kept"], result  # no entity dropped as a duplicate
    assert result["logged"] == [], result["logged"]
    hub = result["valid"]["modbus"][0]
    assert hub["name"] == path.stem
    for sensor in hub.get("sensors", []):
        assert sensor["device_address"] == 3 and sensor["scan_interval"] == 30


def test_home_assistant_schema_refuses_a_broken_export(tmp_path):
    """The schema check can fail: a swap Home Assistant forbids for one register is refused."""
    config = yaml.safe_load(export(ALL_TABLES, "--host", "h").stdout)
    sensor = next(s for s in config["modbus"][0]["sensors"] if s["name"] == "gap_low")
    sensor["swap"] = "word"
    proc = validate(tmp_path, yaml.safe_dump(config))
    assert proc.returncode != 0 and "illegal" in proc.stderr, proc.stderr[-2000:]


def test_home_assistant_version_is_the_pinned_one():
    python = require(HOMEASSISTANT)
    assert installed_version(python, "homeassistant") == "2024.3.3"


# --- the YAML's own meaning, as Home Assistant reads it -------------------------------------------------

_COUNT = {"int16": 1, "uint16": 1, "float16": 1, "int32": 2, "uint32": 2, "float32": 2, "int64": 4, "uint64": 4,
          "float64": 4}
_STRUCT = {"int16": "h", "uint16": "H", "float16": "e", "int32": "i", "uint32": "I", "float32": "f", "int64": "q",
           "uint64": "Q", "float64": "d"}


def ha_sensor_state(client: ModbusTcpClient, sensor: dict) -> str | None:
    """A sensor's state as Home Assistant computes it (base_platform.BaseStructPlatform)."""
    count = sensor.get("count", _COUNT.get(sensor["data_type"]))
    read = client.read_input_registers if sensor["input_type"] == "input" else client.read_holding_registers
    registers = list(read(sensor["address"], count=count, device_id=sensor["device_address"]).registers)
    swap = sensor.get("swap")
    if swap in ("byte", "word_byte"):
        registers = [int.from_bytes(r.to_bytes(2, "little"), "big") for r in registers]
    if swap in ("word", "word_byte"):
        registers.reverse()
    data = b"".join(r.to_bytes(2, "big") for r in registers)
    if sensor["data_type"] == "string":
        return data.decode()
    structure = sensor.get("structure", ">" + _STRUCT.get(sensor["data_type"], ""))
    entry = struct.unpack(structure, data)[0]
    nan = sensor.get("nan_value")
    if nan and entry in (nan, -nan):
        return None
    if entry != entry:
        return None
    value = sensor.get("scale", 1) * entry + sensor.get("offset", 0)
    is_int = sensor["data_type"] in ("int16", "int32", "int64", "uint16", "uint32", "uint64")
    precision = sensor.get("precision", 0 if is_int else 2)
    return str(round(value)) if precision == 0 else f"{float(value):.{precision}f}"


def mdl_as_ha_shows(value, sensor: dict, labels: dict[int, str] | None) -> str | None:
    """mdl read's value as Home Assistant shows a value: at the sensor's precision (labels: the key, as warned)."""
    if value is None:
        return None
    if labels and isinstance(value, str):
        value = {label: key for key, label in labels.items()}[value]
    if sensor["data_type"] == "string":
        return value
    is_int = sensor["data_type"] in ("int16", "int32", "int64", "uint16", "uint32", "uint64")
    precision = sensor.get("precision", 0 if is_int else 2)
    return str(round(value)) if precision == 0 else f"{float(value):.{precision}f}"


def bits(client: ModbusTcpClient, table: str, address: int, unit: int) -> bool:
    read = client.read_discrete_inputs if table == "discrete_input" else client.read_coils
    return bool(read(address, count=1, device_id=unit).bits[0])


def labels_of(path) -> dict[str, dict[int, str] | None]:
    from mdl.sources.loading import load_resolved

    return {f.name: f.fn.values for f in load_resolved(path).functions}


@pytest.mark.parametrize(("path", "raw", "entities"), [(ALL_TABLES, ALL_TABLES_RAW, 17), (TEMCO, TEMCO_RAW, 14)])
def test_reading_as_the_yaml_says_gives_mdl_read_values(sim_factory, tmp_path, path, raw, entities):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", registers, "--unit", "4")
    hub = yaml.safe_load(export(path, *sim.connection, "--unit", "4").stdout)["modbus"][0]
    proc = run_mdl("read", path, *sim.connection, "--unit", "4", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    expected = json.loads(proc.stdout)
    labels = labels_of(path)
    client = ModbusTcpClient(hub["host"], port=hub["port"])
    assert client.connect()
    checked = 0
    try:
        for sensor in hub.get("sensors", []):
            state = ha_sensor_state(client, sensor)
            if sensor["data_type"] == "string" and state is not None:
                state = state.rstrip("\x00 ")  # the NUL padding Home Assistant keeps (warned)
            assert state == mdl_as_ha_shows(expected[sensor["name"]], sensor, labels[sensor["name"]]), sensor
            checked += 1
        for kind in ("binary_sensors", "switches"):
            for entity in hub.get(kind, []):
                if kind == "switches" and "verify" not in entity:
                    continue  # write-only: Home Assistant shows what it wrote
                table = entity.get("input_type", entity.get("write_type"))
                assert bits(client, table, entity["address"], entity["device_address"]) == expected[entity["name"]]
                checked += 1
    finally:
        client.close()
    assert checked == entities


def test_not_implemented_reads_as_none(sim_factory, tmp_path):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"input": {"10": 0xFFFF}}))
    sim = sim_factory(ALL_TABLES, "--registers", registers)
    hub = yaml.safe_load(export(ALL_TABLES, *sim.connection).stdout)["modbus"][0]
    voltage = next(s for s in hub["sensors"] if s["name"] == "voltage")
    assert voltage["nan_value"] == 0xFFFF
    client = ModbusTcpClient(hub["host"], port=hub["port"])
    assert client.connect()
    try:
        assert ha_sensor_state(client, voltage) is None
    finally:
        client.close()
    proc = run_mdl("read", ALL_TABLES, *sim.connection, "voltage", "--format", "json")
    assert json.loads(proc.stdout)["voltage"] is None


def test_nan_value_is_what_home_assistant_unpacks(write_device):
    path = write_device(fn_xml("t", "0", format="INT16", not_implemented="0x8000 0x7FFF", access="read")
                        + fn_xml("u", "1", format="INT16", not_implemented="0xFFFF", access="read")
                        + fn_xml("w", "2", format="UINT32", word_order="little", not_implemented="0x0000FFFF",
                                 access="read"))
    proc = export(path)
    sensors = {s["name"]: s for s in yaml.safe_load(proc.stdout)["modbus"][0]["sensors"]}
    assert sensors["t"]["nan_value"] == -32768  # int16 0x8000, as struct unpacks it
    assert sensors["u"]["nan_value"] == -1
    assert sensors["w"]["nan_value"] == 0xFFFF0000  # registers 0x0000 0xFFFF, words swapped
    assert "0x7FFF read as numbers" in proc.stderr  # one nan_value only
    assert "also makes 1 read as not implemented" in proc.stderr


def test_home_assistant_warnings_and_refusal(tmp_path, write_device):
    proc = export(ALL_TABLES, "--interval", "2.5")
    for name, fragment in [("status_bit", "read fragment"), ("flow", "read fragment"), ("mode", "enumeration"),
                           ("label", "NUL padding"), ("setpoint", "modbus.write_register"), ("power", "2 decimal"),
                           ("alarm_reset", "write-only")]:
        assert any(f"function '{name}': Home Assistant:" in line and fragment in line
                   for line in proc.stderr.splitlines()), (name, proc.stderr)
    assert "--interval 2.5 becomes 3" in proc.stderr
    assert "note: Home Assistant: no connection given" in proc.stderr
    only_fragments = write_device(fn_xml("f", "0", format="UINT16", read_function_code="arg = r1 + 1;",
                                         access="read"))
    assert_clean_error(run_mdl("export", only_fragments, "--to", "homeassistant"), 1,
                       "Home Assistant can hold none of this description's functions")


def test_home_assistant_export_is_deterministic():
    assert export(TEMCO, "--host", "h").stdout == export(TEMCO, "--host", "h").stdout
