"""`mdl export --to homeassistant`, proven three ways:
- Home Assistant's own modbus configuration schema (homeassistant 2024.3.3, the newest release that installs
  on Python 3.11, in a venv of its own: tests/support/engines.py) accepts the exported YAML and keeps every entity
  (its validator drops a second entity on one register: the export leaves it out and says so);
- Home Assistant's own entity classes (ModbusHub, ModbusRegisterSensor, ModbusBinarySensor, ModbusSwitch,
  ModbusThermostat, in that venv) read `mdl sim` and show what `mdl read` gives, and their writes land in it
  with the function code mdl writes with (a proxy records each request);
- a reader that follows the YAML's own meaning, as Home Assistant's docs and base_platform.py give it
  (swap byte/word/word_byte, struct unpack, scale * value + offset, nan_value, precision), reads `mdl sim`
  with pymodbus and shows what `mdl read` gives."""

from __future__ import annotations

import json
import struct
import subprocess

import pytest
import yaml
from pymodbus.client import ModbusTcpClient

from support.common import DATA, EXAMPLE, device_xml, fn_xml
from support.engines import HOMEASSISTANT, installed_version, require
from support.export_warnings import ACCEPTED, named
from support.homeassistant import configuration, through_home_assistant
from support.raw_images import ALL_TABLES_RAW, TEMCO_RAW
from support.refusing_proxy import refusing_proxy
from support.run import assert_clean_error, run_mdl

ALL_TABLES = DATA / "all_tables.xml"
TEMCO = EXAMPLE / "temco_tstat.xml"

# what Home Assistant's sensor refuses (sensor/__init__.py logs it and "should raise"): a unit or a state_class
# its device_class does not take (sensor/const.py DEVICE_CLASS_UNITS, DEVICE_CLASS_STATE_CLASSES)
CLASS_CHECK = r"""
from homeassistant.components.sensor.const import DEVICE_CLASS_STATE_CLASSES, DEVICE_CLASS_UNITS, SensorDeviceClass

def class_errors(hubs):
    errors = []
    for hub in hubs:
        for sensor in hub.get("sensors", []):
            device_class = sensor.get("device_class")
            if device_class is None:
                continue
            device_class = SensorDeviceClass(device_class)
            if sensor.get("unit_of_measurement") not in DEVICE_CLASS_UNITS[device_class]:
                errors.append(["unit", sensor["name"], device_class.value, sensor.get("unit_of_measurement")])
            if sensor.get("state_class") not in DEVICE_CLASS_STATE_CLASSES[device_class]:
                errors.append(["state_class", sensor["name"], device_class.value, str(sensor.get("state_class"))])
    return errors
"""

SCHEMA = (
    CLASS_CHECK
    + r"""
import json, logging, sys
from homeassistant.util.yaml import load_yaml
from homeassistant.components.modbus import CONFIG_SCHEMA

logged = []
class Keep(logging.Handler):
    def emit(self, record):
        logged.append(record.getMessage())
logging.getLogger("homeassistant.components.modbus").addHandler(Keep())
logging.getLogger("homeassistant.components.modbus").setLevel(logging.WARNING)

KINDS = ("sensors", "binary_sensors", "switches", "climates")
config = load_yaml(sys.argv[1])
given = [[len(hub.get(kind, [])) for kind in KINDS] for hub in config["modbus"]]
valid = CONFIG_SCHEMA(config)
kept = [[len(hub.get(kind, [])) for kind in KINDS] for hub in valid["modbus"]]
print(json.dumps({"given": given, "kept": kept, "logged": logged, "valid": valid,
                  "class_errors": class_errors(valid["modbus"])}, default=str))
"""
)


def export(path, *extra) -> subprocess.CompletedProcess:
    proc = run_mdl("export", path, "--to", "homeassistant", *extra)
    assert proc.returncode == 0, proc.stderr
    return proc


def validate(tmp_path, text: str) -> subprocess.CompletedProcess:
    python = require(HOMEASSISTANT)
    path = configuration(tmp_path / "config", text)
    return subprocess.run([str(python), "-c", SCHEMA, str(path)], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("path", [ALL_TABLES, TEMCO])
@pytest.mark.parametrize(
    "connection",
    [
        ("--host", "192.0.2.10", "--port", "1502"),
        ("--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E"),
        ("--host", "192.0.2.10", "--framer", "rtu"),
    ],
)
def test_home_assistant_schema_accepts_the_export(tmp_path, path, connection):
    text = export(path, *connection, "--unit", "3", "--interval", "30").stdout
    proc = validate(tmp_path, text)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["given"] == result["kept"], result  # no entity dropped as a duplicate
    assert result["logged"] == [], result["logged"]
    assert result["class_errors"] == [], result["class_errors"]
    hub = result["valid"]["modbus"][0]
    assert hub["name"] == path.stem
    for sensor in hub.get("sensors", []):
        assert sensor["device_address"] == 3 and sensor["scan_interval"] == 30


def test_home_assistant_schema_refuses_a_broken_export(tmp_path):
    """The schema check can fail: a swap Home Assistant forbids for one register is refused."""
    config = yaml.safe_load(export(ALL_TABLES, "--host", "h").stdout)
    sensor = next(s for s in config[0]["sensors"] if s["name"] == "gap_low")
    sensor["swap"] = "word"
    proc = validate(tmp_path, yaml.safe_dump(config))
    assert proc.returncode != 0 and "illegal" in proc.stderr, proc.stderr[-2000:]


SCHEMA_MANY = (
    CLASS_CHECK
    + r"""
import json, logging, sys
from homeassistant.util.yaml import load_yaml
from homeassistant.components.modbus import CONFIG_SCHEMA

logged = []
class Keep(logging.Handler):
    def emit(self, record):
        logged.append(record.getMessage())
logging.getLogger("homeassistant.components.modbus").addHandler(Keep())
logging.getLogger("homeassistant.components.modbus").setLevel(logging.WARNING)
KINDS = ("sensors", "binary_sensors", "switches", "climates")
for path in sys.argv[1:]:
    logged.clear()
    config = load_yaml(path)
    given = [len(config["modbus"][0].get(kind, [])) for kind in KINDS]
    valid = CONFIG_SCHEMA(config)
    kept = [len(valid["modbus"][0].get(kind, [])) for kind in KINDS]
    print(json.dumps({"path": path, "given": given, "kept": kept, "logged": list(logged),
                      "class_errors": class_errors(valid["modbus"])}))
"""
)


def test_random_descriptions_keep_every_entity_in_home_assistant(tmp_path):
    """Random descriptions, many functions sharing registers and tables: Home Assistant's own check keeps
    every entity the export writes (the export left out what it would drop), and logs nothing."""
    import random

    from mdl.diagnostics import MdlError
    from mdl.exchange.export import Settings
    from mdl.exports import export as export_to
    from mdl.formats.loading import load_resolved

    rng = random.Random(13)
    kinds = [
        {"format": "UINT16"},
        {"format": "INT32"},
        {"format": "BIT"},
        {"format": "BIT", "register_type": "coil"},
        {"format": "BIT", "register_type": "discrete"},
        {"format": "BIT", "register_type": "input"},
        {"format": "UINT8", "length": "Lower byte"},
        {"format": "UINT8", "length": "Upper byte"},
        {"format": "INT16", "register_type": "input"},
    ]
    paths = []
    for case in range(30):
        functions = ""
        for i in range(rng.randint(2, 8)):
            fields = dict(rng.choice(kinds))
            read_only = fields.get("register_type") in ("input", "discrete")
            fields["access"] = "read" if read_only else rng.choice(["read", "write", "read_write"])
            if rng.random() < 0.3 and fields["access"] != "read":
                fields["write_multiple"] = "true"
            functions += fn_xml(f"f{i}", rng.randint(0, 4), **fields)
        path = tmp_path / f"d{case}.xml"
        path.write_text(device_xml(functions), encoding="ascii")
        try:
            result = export_to(load_resolved(path), "homeassistant", Settings())
        except MdlError:
            continue
        paths.append(str(configuration(tmp_path / f"d{case}", result.text or "")))
    assert len(paths) >= 25
    python = require(HOMEASSISTANT)
    proc = subprocess.run([str(python), "-c", SCHEMA_MANY, *paths], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = [json.loads(line) for line in proc.stdout.strip().splitlines()]
    assert len(results) == len(paths)
    for result in results:
        assert result["given"] == result["kept"] and result["logged"] == [] and result["class_errors"] == [], result


TABLES = r"""
import json
from homeassistant.components.sensor.const import DEVICE_CLASS_STATE_CLASSES, DEVICE_CLASS_UNITS
print(json.dumps({c.value: [sorted(str(u) for u in DEVICE_CLASS_UNITS[c]),
                            sorted(s.value for s in DEVICE_CLASS_STATE_CLASSES[c])] for c in DEVICE_CLASS_UNITS}))
"""


def test_the_accepted_classes_are_home_assistants():
    """ACCEPTED (support/export_warnings.py, which the fuzz test of tests/unit/exports/test_export_warnings.py checks
    exports against) is Home Assistant's own DEVICE_CLASS_UNITS and DEVICE_CLASS_STATE_CLASSES for each device
    class the export writes."""
    python = require(HOMEASSISTANT)
    proc = subprocess.run([str(python), "-c", TABLES], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    tables = json.loads(proc.stdout.strip().splitlines()[-1])
    for device_class, (units, states) in ACCEPTED.items():
        assert (sorted(units), sorted(states)) == tuple(tables[device_class]), device_class


def _xml_text(text: str) -> str:
    return "".join(ch if ch.isascii() and ch not in "&<>" else f"&#x{ord(ch):X};" for ch in text)


def test_every_unit_spelling_is_one_home_assistant_accepts(tmp_path):
    """A sensor for every spelling the unit table knows (Home Assistant's, the vendors', the words), through
    `modbus: !include modbus.yaml` and Home Assistant's schema: each device_class with a unit and a
    state_class it takes, Volts as V, kWh a counter (total_increasing)."""
    from mdl.exports import ha_units
    from mdl.model import units

    spellings = sorted(
        {
            *ha_units.CLASSES,
            *units.SYMBOLS,
            *units.WORDS,
            *units.GUESSED,
            *units.HUMIDITY_WORDS,
            "Volts",
            "Amps",
            "Kilowatt Hours",
        }
    )
    path = tmp_path / "units.xml"
    path.write_text(
        device_xml(
            "".join(
                fn_xml(f"f{i}", i, format="UINT16", access="read", units=_xml_text(unit))
                for i, unit in enumerate(spellings)
            )
        ),
        encoding="ascii",
    )
    proc = export(path, "--host", "192.0.2.10")
    result = json.loads(validate(tmp_path, proc.stdout).stdout.strip().splitlines()[-1])
    assert result["class_errors"] == [] and result["logged"] == [], result
    sensors = {s["name"]: s for s in result["valid"]["modbus"][0]["sensors"]}
    assert len(sensors) == len(spellings)
    by_unit = {unit: sensors[f"f{i}"] for i, unit in enumerate(spellings)}
    assert sum("device_class" in s for s in sensors.values()) > len(spellings) // 2
    assert (by_unit["Volts"]["unit_of_measurement"], by_unit["Volts"]["device_class"]) == ("V", "voltage")
    assert (by_unit["KWH"]["unit_of_measurement"], by_unit["KWH"]["state_class"]) == ("kWh", "total_increasing")
    assert (by_unit["Amps"]["unit_of_measurement"], by_unit["Kilowatt Hours"]["unit_of_measurement"]) == ("A", "kWh")
    assert by_unit["kvarh"]["state_class"] == "total_increasing" and "device_class" not in by_unit["kvarh"]


def test_home_assistant_version_is_the_pinned_one():
    python = require(HOMEASSISTANT)
    assert installed_version(python, "homeassistant") == "2024.3.3"


# --- the YAML's own meaning, as Home Assistant reads it -------------------------------------------------

_COUNT = {
    "int16": 1,
    "uint16": 1,
    "float16": 1,
    "int32": 2,
    "uint32": 2,
    "float32": 2,
    "int64": 4,
    "uint64": 4,
    "float64": 4,
}
_STRUCT = {
    "int16": "h",
    "uint16": "H",
    "float16": "e",
    "int32": "i",
    "uint32": "I",
    "float32": "f",
    "int64": "q",
    "uint64": "Q",
    "float64": "d",
}


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
    if "max_value" in sensor and value > sensor["max_value"]:  # min_value: never exported
        value = sensor["max_value"]
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
    from mdl.formats.loading import load_resolved

    return {f.name: f.fn.values for f in load_resolved(path).functions}


def register_switch(client: ModbusTcpClient, entity: dict) -> bool | None:
    """A register's switch as its verify reads it (base_platform.BaseSwitch.async_update): on at command_on,
    off at command_off, else unchanged (None here)."""
    value = client.read_holding_registers(entity["address"], count=1, device_id=entity["device_address"]).registers[0]
    on, off = entity.get("command_on", 1), entity.get("command_off", 0)
    return True if value == on else False if value == off else None


def current_of(path, climate: dict) -> str:
    """The function a climate reads as its current temperature (its address and table)."""
    from mdl.formats.loading import load_resolved

    table = climate.get("input_type", "holding")
    (name,) = [
        f.name
        for f in load_resolved(path).functions
        if (f.layout.table, f.layout.addresses[0]) == (table, climate["address"])
    ]
    return name


def climate_readings(climate: dict) -> list[tuple[str, dict]]:
    """The climate's two readings as sensors of the same struct: its current temperature (address, input_type)
    and its target (target_temp_register, a holding register; climate.py async_update)."""
    target = {**climate, "address": climate["target_temp_register"], "input_type": "holding"}
    return [("current", climate), ("target", target)]


# TEMCO: 13 sensors, 5 relays' switches, the climate's current and target temperature
@pytest.mark.parametrize(("path", "raw", "entities"), [(ALL_TABLES, ALL_TABLES_RAW, 17), (TEMCO, TEMCO_RAW, 20)])
def test_reading_as_the_yaml_says_gives_mdl_read_values(sim_factory, tmp_path, path, raw, entities):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", registers, "--unit", "4")
    hub = yaml.safe_load(export(path, *sim.connection, "--unit", "4").stdout)[0]
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
                if table in ("holding", "holdings"):  # a register of range 0..1: on where mdl reads 1
                    assert register_switch(client, entity) is (expected[entity["name"]] == 1), entity
                else:
                    assert bits(client, table, entity["address"], entity["device_address"]) == expected[entity["name"]]
                checked += 1
        for climate in hub.get("climates", []):
            names = {"current": current_of(path, climate), "target": climate["name"]}
            for reading, sensor in climate_readings(climate):
                shown = mdl_as_ha_shows(expected[names[reading]], sensor, None)
                assert ha_sensor_state(client, sensor) == shown, (reading, climate)
                checked += 1
    finally:
        client.close()
    assert checked == entities


@pytest.mark.parametrize(("path", "raw", "entities"), [(ALL_TABLES, ALL_TABLES_RAW, 17), (TEMCO, TEMCO_RAW, 20)])
def test_home_assistant_own_entities_show_mdl_read_values(sim_factory, tmp_path, path, raw, entities):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", registers, "--unit", "4")
    text = export(path, *sim.connection, "--unit", "4").stdout
    hub = yaml.safe_load(text)[0]
    states = through_home_assistant(tmp_path, text)
    proc = run_mdl("read", path, *sim.connection, "--unit", "4", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    expected = json.loads(proc.stdout)
    labels = labels_of(path)
    checked = 0
    for sensor in hub.get("sensors", []):
        state = states["sensors"][sensor["name"]]
        if sensor["data_type"] == "string" and state is not None:
            state = state.rstrip("\x00 ")  # the NUL padding Home Assistant keeps (warned)
        assert state == mdl_as_ha_shows(expected[sensor["name"]], sensor, labels[sensor["name"]]), sensor
        checked += 1
    for kind in ("binary_sensors", "switches"):
        for entity in hub.get(kind, []):
            if kind == "switches" and "verify" not in entity:
                continue  # write-only: Home Assistant shows what it wrote
            assert states[kind][entity["name"]] is bool(expected[entity["name"]]), entity
            checked += 1
    for climate in hub.get("climates", []):
        (shown,) = through_the_climate(tmp_path, text)
        assert shown["current"] == expected[current_of(path, climate)], shown
        assert shown["target"] == expected[climate["name"]], shown
        checked += 2
    assert checked == entities


BITREG = (
    fn_xml("flag", "10", format="BIT")
    + fn_xml("ro_flag", "11", format="BIT", register_type="input")
    + fn_xml("lo", "12", length="Lower byte", format="UINT8", byte_order="little")
)


def test_a_bit_in_a_register_shows_mdl_read_value(sim_factory, tmp_path, write_device):
    """mdl reads a BIT in a holding/input register as true when the register is not 0. Home Assistant's
    binary_sensor on a register reads bit 0 only (2 -> off): the export makes it a sensor clamped to 1."""
    path = write_device(BITREG)
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"holding": {"10": 2, "12": 0x1234}, "input": {"11": 0x8000}}))
    sim = sim_factory(path, "--registers", registers)
    proc = export(path, *sim.connection)
    assert named(proc.stderr, "Home Assistant", "a bit in a register") == {"flag", "ro_flag"}, proc.stderr
    hub = yaml.safe_load(proc.stdout)[0]
    sensors = {s["name"]: s for s in hub["sensors"]}
    assert sensors["flag"]["input_type"] == "holding" and sensors["ro_flag"]["input_type"] == "input"
    assert sensors["flag"]["max_value"] == 1 and "binary_sensors" not in hub
    assert [(s["name"], s["write_type"]) for s in hub["switches"]] == [("flag", "holding")]
    states = through_home_assistant(tmp_path, proc.stdout)
    mdl = json.loads(run_mdl("read", path, *sim.connection, "--format", "json").stdout)
    assert mdl["flag"] is True and mdl["ro_flag"] is True and mdl["lo"] == 0x34
    assert states["sensors"]["flag"] == states["sensors"]["ro_flag"] == "1"
    assert float(states["sensors"]["lo"]) == 0x34
    client = ModbusTcpClient(sim.host, port=sim.port)
    assert client.connect()
    try:  # the YAML's documented meaning gives the same
        for name in ("flag", "ro_flag"):
            assert ha_sensor_state(client, sensors[name]) == mdl_as_ha_shows(mdl[name], sensors[name], None) == "1"
    finally:
        client.close()
    # the control: Home Assistant's own binary_sensor on the same registers says off
    bit0 = [
        {"name": "flag", "address": 10, "input_type": "holding", "device_address": 1},
        {"name": "ro_flag", "address": 11, "input_type": "input", "device_address": 1},
    ]
    control = [{**{k: v for k, v in hub.items() if k not in ("sensors", "switches")}, "binary_sensors": bit0}]
    shown = through_home_assistant(tmp_path, yaml.safe_dump(control))["binary_sensors"]
    assert shown == {"flag": False, "ro_flag": False}
    zero = tmp_path / "zero.json"
    zero.write_text(json.dumps({"holding": {"10": 0}, "input": {"11": 0}}))
    sim0 = sim_factory(path, "--registers", zero)
    states0 = through_home_assistant(tmp_path, export(path, *sim0.connection).stdout)
    assert states0["sensors"]["flag"] == states0["sensors"]["ro_flag"] == "0"


@pytest.mark.parametrize(("multiple", "codes"), [(False, {"relay": 5, "flag": 6}), (True, {"relay": 15, "flag": 16})])
def test_switches_write_with_mdl_function_codes(sim_factory, tmp_path, write_device, multiple, codes):
    """A switch writes with the function code mdl writes with: write_type coil (5) or coils (15) for a
    coil, holding (6) or holdings (16) for a bit in a register, as the function's write_multiple says;
    behind a proxy that refuses the other pair, through Home Assistant's own switch."""
    extra = {"write_multiple": "true"} if multiple else {}
    path = write_device(
        fn_xml("relay", "3", format="BIT", register_type="coil", **extra) + fn_xml("flag", "10", format="BIT", **extra)
    )
    sim = sim_factory(path)
    refused = {5, 6} if multiple else {15, 16}
    with refusing_proxy(sim.host, sim.port, refused=refused) as proxy:
        text = export(path, "--host", proxy.host, "--port", str(proxy.port)).stdout
        switches = {s["name"]: s for s in yaml.safe_load(text)[0]["switches"]}
        assert switches["relay"]["write_type"] == ("coils" if multiple else "coil")
        assert switches["flag"]["write_type"] == ("holdings" if multiple else "holding")
        states = through_home_assistant(tmp_path, text, {"relay": True, "flag": True})
        written = [code for code in proxy.codes if code in (5, 6, 15, 16)]
    assert sorted(written) == sorted(codes.values()), proxy.codes
    assert states["switches"] == {"relay": True, "flag": True}
    mdl = json.loads(run_mdl("read", path, *sim.connection, "--format", "json").stdout)
    assert mdl == {"relay": True, "flag": True}


def test_one_entity_per_register_as_home_assistant_loads_them(tmp_path):
    """Home Assistant loads one entity per register key (hub, address, input_type/write_type, command_on/off,
    device_address) and drops the others with a log line. The export leaves those out with a warning naming
    each; put back, Home Assistant drops exactly them."""
    functions = {
        "lo": fn_xml("lo", "5", length="Lower byte", format="UINT8", access="read"),
        "hi": fn_xml("hi", "5", length="Upper byte", format="UINT8", access="read"),
        "whole": fn_xml("whole", "5", format="UINT16", access="read"),
        "in5": fn_xml("in5", "5", format="UINT16", register_type="input"),
        "coil5": fn_xml("coil5", "5", format="BIT", register_type="coil"),
        "coil5_ro": fn_xml("coil5_ro", "5", format="BIT", register_type="coil", access="read"),
        "di5": fn_xml("di5", "5", format="BIT", register_type="discrete"),
        "bit10": fn_xml("bit10", "10", format="BIT"),
        "word10": fn_xml("word10", "10", format="INT16", access="read"),
        "in10": fn_xml("in10", "10", format="INT16", register_type="input"),
    }
    dropped = {"hi", "whole", "word10"}
    path = tmp_path / "dup.xml"
    path.write_text(device_xml("".join(functions.values()), name="Dup"), encoding="ascii")
    proc = export(path, "--host", "192.0.2.10")
    assert named(proc.stderr, "Home Assistant", "shares its register") == dropped, proc.stderr
    proc_schema = validate(tmp_path, proc.stdout)
    assert proc_schema.returncode == 0, proc_schema.stderr[-3000:]
    result = json.loads(proc_schema.stdout.strip().splitlines()[-1])
    # sensors lo, in5, bit10, in10; binary_sensors coil5_ro, di5; switches coil5, bit10
    assert result["given"] == result["kept"] == [[4, 2, 2, 0]] and result["logged"] == []
    # put back what the export left out: Home Assistant drops exactly those
    config = yaml.safe_load(proc.stdout)
    for name in sorted(dropped):
        alone = tmp_path / f"{name}.xml"
        alone.write_text(device_xml(functions[name], name="Dup"), encoding="ascii")
        config[0]["sensors"] += yaml.safe_load(export(alone, "--host", "192.0.2.10").stdout)[0]["sensors"]
    result = json.loads(validate(tmp_path, yaml.safe_dump(config)).stdout.strip().splitlines()[-1])
    assert result["given"][0][0] == result["kept"][0][0] + len(dropped)  # [sensors, binary_sensors, switches]
    assert sorted(line.split("/sensor.", 1)[1].split()[0] for line in result["logged"]) == sorted(dropped)


def test_not_implemented_reads_as_none(sim_factory, tmp_path):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"input": {"10": 0xFFFF}}))
    sim = sim_factory(ALL_TABLES, "--registers", registers)
    hub = yaml.safe_load(export(ALL_TABLES, *sim.connection).stdout)[0]
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
    path = write_device(
        fn_xml("t", "0", format="INT16", not_implemented="0x8000 0x7FFF", access="read")
        + fn_xml("u", "1", format="INT16", not_implemented="0xFFFF", access="read")
        + fn_xml("w", "2", format="UINT32", word_order="little", not_implemented="0x0000FFFF", access="read")
    )
    proc = export(path)
    sensors = {s["name"]: s for s in yaml.safe_load(proc.stdout)[0]["sensors"]}
    assert sensors["t"]["nan_value"] == -32768  # int16 0x8000, as struct unpacks it
    assert sensors["u"]["nan_value"] == -1
    assert sensors["w"]["nan_value"] == 0xFFFF0000  # registers 0x0000 0xFFFF, words swapped
    assert named(proc.stderr, "Home Assistant", "nan_value holds one 'not implemented' value") == {"t"}
    assert "'t' (0x8000 used; 0x7FFF read as numbers)" in proc.stderr
    assert named(proc.stderr, "Home Assistant", "also makes its negative read as not implemented") == {"u"}
    assert "'u' (nan_value -1 also makes 1)" in proc.stderr


def test_home_assistant_warnings_and_refusal(tmp_path, write_device):
    proc = export(ALL_TABLES, "--interval", "2.5")
    for name, fragment in [
        ("status_bit", "read fragment"),
        ("flow", "read fragment"),
        ("mode", "enumeration"),
        ("label", "NUL padding"),
        ("setpoint", "modbus.write_register"),
        ("power", "2 decimal"),
        ("alarm_reset", "write-only"),
    ]:
        assert name in named(proc.stderr, "Home Assistant", fragment), (name, proc.stderr)
    assert "--interval 2.5 becomes 3" in proc.stderr
    assert "scan_interval 3 is under 5 seconds" in proc.stderr
    assert "note: Home Assistant: no connection given" in proc.stderr
    only_fragments = write_device(fn_xml("f", "0", format="UINT16", read_function_code="arg = r1 + 1;", access="read"))
    assert_clean_error(
        run_mdl("export", only_fragments, "--to", "homeassistant"),
        1,
        "Home Assistant can hold none of this description's functions",
    )


def test_home_assistant_export_is_deterministic():
    assert export(TEMCO, "--host", "h").stdout == export(TEMCO, "--host", "h").stdout


def test_roles_give_certain_classes_home_assistant_accepts(tmp_path):
    """Functions with profile roles (SPEC 13) get the classes the role makes certain: a power factor
    with or without %, a battery's state of charge, a storage capacity (a measurement, not a counter),
    energy counters without a guess; Home Assistant's schema and class checks accept them."""
    roles = tmp_path / "roles.xml"
    roles.write_text(
        device_xml(
            fn_xml("pf", 0, format="INT16", multiplier="0.001", role="power_factor")
            + fn_xml("pf_pct", 1, format="INT16", units="%", role="power_factor")
            + fn_xml("soc", 2, format="UINT16", units="%", role="soc_pct")
            + fn_xml("capacity", 3, format="UINT16", units="kWh", role="capacity_wh")
            + fn_xml("imported", 4, format="UINT32", units="kWh", role="energy_import_wh"),
            name="Roles",
        )
    )
    proc = export(roles, "--host", "192.0.2.10")
    assert proc.returncode == 0, proc.stderr
    assert "counter that only grows" not in proc.stderr  # a role is no guess
    sensors = {s["name"]: s for s in yaml.safe_load(proc.stdout)[0]["sensors"]}
    assert sensors["pf"]["device_class"] == "power_factor" and "unit_of_measurement" not in sensors["pf"]
    assert sensors["soc"]["device_class"] == "battery"
    assert (sensors["capacity"]["device_class"], sensors["capacity"]["state_class"]) == (
        "energy_storage",
        "measurement",
    )
    assert sensors["imported"]["state_class"] == "total_increasing"
    checked = validate(tmp_path, proc.stdout)
    assert checked.returncode == 0, checked.stderr[-3000:]
    result = json.loads(checked.stdout.strip().splitlines()[-1])
    assert result["class_errors"] == [] and result["logged"] == [], result


# --- thermostats: Home Assistant's own climate ---------------------------------------------------------------

# Home Assistant's own thermostat on the exported hub (climate.py ModbusThermostat, outside a running Home
# Assistant): updated, then each action taken in turn (each ends with the entity's own update); its state
# after each, as Home Assistant holds it
CLIMATE = r"""
import asyncio, json, sys
from homeassistant.core import HomeAssistant
from homeassistant.util.yaml import load_yaml
from homeassistant.components.climate import HVACMode
from homeassistant.components.modbus import CONFIG_SCHEMA
from homeassistant.components.modbus.modbus import ModbusHub
from homeassistant.components.modbus.climate import ModbusThermostat

async def main():
    hub_config = CONFIG_SCHEMA(load_yaml(sys.argv[1]))["modbus"][0]
    actions = json.loads(sys.argv[2])
    hass = HomeAssistant(sys.argv[3])
    kinds = ("sensors", "binary_sensors", "switches", "climates")
    hub = ModbusHub(hass, {k: v for k, v in hub_config.items() if k not in kinds})
    assert await hub.async_setup()
    await hass.async_block_till_done()
    (config,) = hub_config["climates"]
    climate = ModbusThermostat(hass, hub, config)
    climate.async_write_ha_state = lambda: None  # not added to a running Home Assistant: no state machine

    def state():
        return {"current": climate.current_temperature, "target": climate.target_temperature,
                "hvac_mode": climate.hvac_mode, "hvac_modes": sorted(climate.hvac_modes),
                "fan_mode": climate.fan_mode, "fan_modes": climate.fan_modes, "min": climate.min_temp,
                "max": climate.max_temp, "step": climate.target_temperature_step, "unit": climate.temperature_unit}

    await climate.async_update()
    out = [state()]
    for action in actions:
        if "temperature" in action:
            await climate.async_set_temperature(temperature=action["temperature"])
        if "hvac_mode" in action:
            await climate.async_set_hvac_mode(HVACMode(action["hvac_mode"]))
        if "fan_mode" in action:
            await climate.async_set_fan_mode(action["fan_mode"])
        out.append(state())
    await hass.async_stop(force=True)
    print(json.dumps(out, default=str))

asyncio.run(main())
"""


def through_the_climate(tmp_path, text: str, actions: list[dict] | None = None) -> list[dict]:
    """Home Assistant's own climate on the exported hub: its state, then after each action (CLIMATE)."""
    python = require(HOMEASSISTANT)
    path = configuration(tmp_path / "climate", text)
    config_dir = tmp_path / "ha_climate_config"
    config_dir.mkdir(exist_ok=True)
    proc = subprocess.run(
        [str(python), "-c", CLIMATE, str(path), json.dumps(actions or []), str(config_dir)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_home_assistant_schema_accepts_the_thermostats_climate(tmp_path):
    """Issue 37: the TEMCO thermostat's set point is writable in Home Assistant, as a climate its own schema
    accepts and keeps (its target register a list of one per HVAC mode), with nothing logged; the relays are
    switches it keeps."""
    proc = validate(tmp_path, export(TEMCO, "--host", "192.0.2.10", "--unit", "3").stdout)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["given"] == result["kept"] == [[13, 0, 5, 1]] and result["logged"] == [], result
    (climate,) = result["valid"]["modbus"][0]["climates"]
    assert climate["target_temp_register"] == [345] * 7 and climate["address"] == 121
    assert (climate["min_temp"], climate["max_temp"], climate["temp_step"]) == (10.0, 30.0, 0.5)
    assert (climate["temperature_unit"], climate["device_address"], climate["structure"]) == ("C", 3, ">h")


def test_home_assistant_own_climate_reads_and_writes_the_thermostat(sim_factory, tmp_path):
    """Home Assistant's own ModbusThermostat shows the room temperature and the set point mdl reads, and its
    target temperature lands as mdl reads it, written with function 6 as mdl writes it (a proxy refuses 16).
    The control: a target off the export's temp_step (10.1, as an automation may send it) lands one step
    lower, 10.0: Home Assistant cuts 10.1 / 0.1 = 100.99999999999999 to 100, as the export's warning says."""
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(TEMCO_RAW))
    sim = sim_factory(TEMCO, "--registers", registers)
    with refusing_proxy(sim.host, sim.port, refused={16}) as proxy:
        proc = export(TEMCO, "--host", proxy.host, "--port", str(proxy.port))
        assert "10.1 written 100 where mdl writes 101" in proc.stderr
        shown = through_the_climate(tmp_path, proc.stdout, [{"temperature": 22.5}, {"temperature": 10.1}])
        written = [code for code in proxy.codes if code in (6, 16)]
        mdl = json.loads(run_mdl("read", TEMCO, *sim.connection, "--format", "json").stdout)
        assert run_mdl("write", TEMCO, *sim.connection, "occupied_setpoint=23.5").returncode == 0
        assert through_the_climate(tmp_path, proc.stdout)[0]["target"] == 23.5  # what mdl wrote, Home Assistant reads
    assert written == [6, 6], proxy.codes
    first, after, control = shown
    assert (first["current"], first["target"]) == (-25.0, 21.5)  # raw 0xFF06 and 215 at scale 0.1
    assert (first["min"], first["max"], first["step"], first["unit"]) == (10.0, 30.0, 0.5, "°C")
    assert after["target"] == 22.5 and control["target"] == 10.0
    assert (mdl["room_temperature"], mdl["occupied_setpoint"]) == (-25.0, 10.0)


ZONE = (
    fn_xml("room", 0, format="INT16", multiplier="0.5", units="degC", access="read", role="room_temperature_c")
    + fn_xml("sp", 1, format="INT16", multiplier="0.5", minimum="5", maximum="30", role="setpoint_c")
    + fn_xml("hvac", 2, format="UINT16", values={0: "Off", 1: "Heat", 2: "Cool", 3: "Auto"}, role="mode")
    + fn_xml("fan", 3, format="UINT16", values={0: "auto", 1: "low", 2: "high"}, write_multiple="true")
)


def test_home_assistant_own_climate_sets_modes_as_mdl_writes_them(sim_factory, tmp_path, write_device):
    """A thermostat with the profile's roles: Home Assistant's climate shows the HVAC and fan modes mdl reads (by
    their labels) and sets them as mdl writes them, the fan with function 16 (write_multiple), the mode and the
    target with 6; its schema keeps the mode registers."""
    path = write_device(ZONE, name="Zone")
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"holding": {"0": 41, "1": 40, "2": 2, "3": 1}}))
    sim = sim_factory(path, "--registers", registers)
    with refusing_proxy(sim.host, sim.port) as proxy:
        text = export(path, "--host", proxy.host, "--port", str(proxy.port)).stdout
        checked = json.loads(validate(tmp_path, text).stdout.strip().splitlines()[-1])
        assert checked["given"] == checked["kept"] and checked["logged"] == [], checked
        (climate,) = checked["valid"]["modbus"][0]["climates"]
        assert climate["hvac_mode_register"]["address"] == 2 and climate["fan_mode_register"]["address"] == [3]
        actions = [{"hvac_mode": "heat"}, {"fan_mode": "high"}, {"temperature": 21.5}]
        first, *_, last = through_the_climate(tmp_path, text, actions)
        written = [code for code in proxy.codes if code in (6, 16)]
    assert written == [6, 16, 6], proxy.codes
    assert (first["current"], first["target"], first["hvac_mode"], first["fan_mode"]) == (20.5, 20.0, "cool", "low")
    assert first["hvac_modes"] == ["auto", "cool", "heat", "off"] and first["fan_modes"] == ["auto", "low", "high"]
    assert (last["hvac_mode"], last["fan_mode"], last["target"]) == ("heat", "high", 21.5)
    mdl = json.loads(run_mdl("read", path, *sim.connection, "--format", "json").stdout)
    assert (mdl["hvac"], mdl["fan"], mdl["sp"]) == ("Heat", "high", 21.5)


def test_home_assistant_own_switch_writes_a_relay_register(sim_factory, tmp_path):
    """The TEMCO relays (a byte of a register, range 0..1) are switches: Home Assistant's own switch turns one
    off and on with function 6, writing what mdl writes, and its verify reads the state mdl reads."""
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(TEMCO_RAW))
    sim = sim_factory(TEMCO, "--registers", registers)
    with refusing_proxy(sim.host, sim.port, refused={16}) as proxy:
        text = export(TEMCO, "--host", proxy.host, "--port", str(proxy.port)).stdout
        states = through_home_assistant(tmp_path, text, {"fan_relay_on": False, "cooling_stage1_relay_on": True})
        written = [code for code in proxy.codes if code in (6, 16)]
    assert written == [6, 6], proxy.codes
    mdl = json.loads(run_mdl("read", TEMCO, *sim.connection, "--format", "json").stdout)
    assert (mdl["fan_relay_on"], mdl["cooling_stage1_relay_on"]) == (0, 1)
    relays = [name for name in mdl if name.endswith("_relay_on")]
    assert {name: states["switches"][name] for name in relays} == {name: mdl[name] == 1 for name in relays}


def test_home_assistant_schema_accepts_a_fleets_hubs(tmp_path):
    """`mdl export --inventory --to homeassistant` (SPEC 15): a hub per line with every device's entities,
    named after the device's id; Home Assistant's schema keeps every one (no name or register dropped as a
    duplicate of another device's)."""
    import shutil

    from support.common import ROOT

    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    out = tmp_path / "ha"
    proc = run_mdl("export", "--inventory", tmp_path / "examples" / "fleet" / "site.yml", "--to", "homeassistant",
                   "-o", out)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    checked = validate(tmp_path, (out / "modbus.yaml").read_text())
    assert checked.returncode == 0, checked.stderr[-3000:]
    result = json.loads(checked.stdout.strip().splitlines()[-1])
    assert result["given"] == result["kept"] and result["logged"] == [], result
    hubs = result["valid"]["modbus"]
    assert len(hubs) == 3  # the gateway, the serial line, the EM100's address
    for kind in ("sensors", "binary_sensors", "switches", "climates"):  # a name once per platform, fleet-wide
        names = [e["name"] for hub in hubs for e in hub.get(kind, [])]
        assert len(names) == len(set(names)), kind
    assert any(e["name"].startswith("office-tstat-4 ") for hub in hubs for e in hub.get("sensors", []))
