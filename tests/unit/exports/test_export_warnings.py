"""Issue 20: an engine export says each kind of loss once (SPEC 11: "one warning per kind of loss, naming the
functions"), so that `--fail-on-warning` stays usable; and the Home Assistant export writes units in Home
Assistant's spelling with the device_class and state_class they give, only in combinations Home Assistant
accepts (ACCEPTED, checked against Home Assistant's own tables in tests/engines/test_export_homeassistant.py), each
guess said in a note.

A warning about functions reads `FILE:LINE: warning: functions 'a', 'b' (detail), 'c': ENGINE: KIND`, at the
first function's line; `named` takes it apart.

A longer fuzz run by hand: MDL_FUZZ_WARNINGS=500 python -m pytest tests/unit/exports/test_export_warnings.py -k fuzz"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mdl.exports.ha_units import CLASSES, ha_unit
from support.common import DATA, EXAMPLE, device_xml, fn_xml
from support.export_warnings import ACCEPTED, assert_one_per_kind, named, said
from support.run import assert_clean_error, cli

ENGINES = {"homeassistant": "Home Assistant", "telegraf": "Telegraf", "volttron": "VOLTTRON"}
CASES = [EXAMPLE / "temco_tstat.xml", DATA / "all_tables.xml"]

STATE_CLASSES = {"measurement", "total", "total_increasing"}


def export(path: Path, engine: str, tmp_path: Path, *extra: str):
    extra = ("-o", str(tmp_path / "out"), "--force", *extra) if engine == "volttron" else extra
    return cli("export", path, "--to", engine, "--host", "192.0.2.10", *extra)


@pytest.mark.parametrize("engine", sorted(ENGINES))
@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_each_kind_of_loss_is_one_warning(tmp_path, engine, path):
    proc = export(path, engine, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert said(proc.stderr), proc.stderr  # the control: these descriptions lose something in every engine
    assert_one_per_kind(proc.stderr)


def test_a_thermostat_to_home_assistant_is_a_few_warnings(tmp_path):
    """The issue's flood: the writable registers Home Assistant cannot write said once, naming all 5, at the
    first one's line (issue 37: the set point is the climate's, the relays are switches; each says its own
    kind once)."""
    proc = export(EXAMPLE / "temco_tstat.xml", "homeassistant", tmp_path)
    warnings = [line for line in proc.stderr.splitlines() if ": warning: " in line]
    # unreadable bytes, a fragment, writable registers, the climate's step, its room temperature, the relays' verify
    assert len(warnings) == 6, proc.stderr
    (writes,) = [d for d in said(proc.stderr) if "no entity that writes a register value" in d["kind"]]
    assert len(writes["names"]) == 5 and writes["names"][0] == "modbus_address" and writes["line"] == "24"


def test_a_meter_of_floats_says_the_precision_once(tmp_path, write_device):
    """The issue's other flood: ten floats, each "shows a float with 2 decimal places"."""
    path = write_device(
        "".join(
            fn_xml(f"v{i}", f"{2 * i} {2 * i + 1}", format="FLOAT32", access="read", units="Volts") for i in range(10)
        )
    )
    proc = export(path, "homeassistant", tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert_one_per_kind(proc.stderr)
    (floats,) = [line for line in proc.stderr.splitlines() if ": warning: " in line]
    assert "shows a float with 2 decimal places" in floats
    assert named(proc.stderr, "Home Assistant", "2 decimal places") == {f"v{i}" for i in range(10)}
    assert named(proc.stderr, "Home Assistant", "units written in Home Assistant's spelling", "note") == {
        f"v{i}" for i in range(10)
    }
    assert proc.stderr.count("'Volts' as 'V'") == 1  # one detail for the functions that share it


def test_details_go_with_their_functions(tmp_path, write_device):
    path = write_device(
        fn_xml("a", "0", format="UINT16", not_implemented="0xFFFF", access="read")
        + fn_xml("b", "1", format="UINT16", not_implemented="0xFFFF", access="read")
        + fn_xml("c", "2", format="UINT16", not_implemented="0x8000", access="read")
    )
    proc = export(path, "telegraf", tmp_path)
    assert proc.returncode == 0, proc.stderr
    (line,) = [text for text in proc.stderr.splitlines() if "not implemented" in text]
    assert line.startswith(
        f"{path}:{_function_line(path, 'a')}: warning: functions 'a', 'b' (0xFFFF), 'c' (0x8000): "
        "Telegraf: no 'not implemented' value"
    ), line


def _function_line(path: Path, name: str) -> int:
    """The line of the function element named `name` (where mdl positions its messages)."""
    lines = path.read_text().splitlines()
    at = lines.index(f"    <name>{name}</name>")
    return next(i for i in range(at, -1, -1) if lines[i].strip() == "<function>") + 1


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_fail_on_warning_counts_kinds_and_writes_nothing(tmp_path, engine):
    path = DATA / "all_tables.xml"
    out = tmp_path / ("out" if engine == "volttron" else "out.txt")
    proc = cli("export", path, "--to", engine, "--host", "h", "-o", out, "--fail-on-warning")
    kinds = [line for line in proc.stderr.splitlines() if ": warning: " in line]
    resolve = [line for line in cli("validate", path).stderr.splitlines() if ": warning: " in line]
    assert_clean_error(proc, 1, f"{len(kinds) - len(resolve)} warning")
    assert not out.exists()
    assert_one_per_kind(proc.stderr)


# --- Home Assistant: units, device_class, state_class --------------------------------------------------------

METER = {  # function -> (units as the vendor writes them, format, what Home Assistant gets)
    "voltage": ("Volts", "UINT16", ("V", "voltage", "measurement")),
    "current": ("Amps", "UINT16", ("A", "current", "measurement")),
    "power": ("KW", "INT16", ("kW", "power", "measurement")),
    "energy": ("kWh", "UINT32", ("kWh", "energy", "total_increasing")),
    "frequency": ("Hz", "UINT16", ("Hz", "frequency", "measurement")),
    "temperature": ("degC", "INT16", ("°C", "temperature", "measurement")),
    "humidity": ("%RH", "UINT16", ("%", "humidity", "measurement")),
    "reactive_energy": ("kVArh", "UINT32", ("kvarh", None, "total_increasing")),
    "apparent": ("kVA", "UINT16", ("kVA", None, "measurement")),
    "flow": ("l/min", "UINT16", ("L/min", "volume_flow_rate", "measurement")),
    "odd": ("furlongs", "UINT16", ("furlongs", None, None)),
}


def _meter(write_device) -> Path:
    functions = ""
    address = 0
    for name, (units, fmt, _) in METER.items():
        count = 2 if fmt.endswith("32") else 1
        functions += fn_xml(
            name, " ".join(str(address + i) for i in range(count)), format=fmt, units=units, access="read"
        )
        address += count
    return write_device(functions)


def test_units_device_class_and_state_class(tmp_path, write_device):
    path = _meter(write_device)
    proc = export(path, "homeassistant", tmp_path)
    assert proc.returncode == 0, proc.stderr
    sensors = {s["name"]: s for s in yaml.safe_load(proc.stdout)[0]["sensors"]}
    for name, (_, _, want) in METER.items():
        got = tuple(sensors[name].get(key) for key in ("unit_of_measurement", "device_class", "state_class"))
        assert got == want, (name, got)
    spelled = named(proc.stderr, "Home Assistant", "units written in Home Assistant's spelling", "note")
    assert spelled == {"voltage", "current", "power", "temperature", "humidity", "reactive_energy", "flow"}
    assert named(proc.stderr, "Home Assistant", "an energy reading taken as a meter's counter", "note") == {"energy"}
    assert named(proc.stderr, "Home Assistant", "a reactive energy reading", "note") == {"reactive_energy"}
    assert named(proc.stderr, "Home Assistant", "a unit Home Assistant does not class", "note") == {"odd"}
    assert not named(proc.stderr, "Home Assistant", "taken as", "warning")  # guesses are notes, not losses
    assert_one_per_kind(proc.stderr)
    assert cli("export", path, "--to", "homeassistant", "--fail-on-warning").returncode == 0  # notes pass


def test_a_text_sensor_has_no_unit_and_an_enumeration_no_class(tmp_path, write_device):
    """Home Assistant takes a sensor with a unit for a number (it refuses text then); an enumeration's number
    is a state, not a measurement."""
    path = write_device(
        fn_xml("label", "0", count="4", format="STRING", units="V", access="read")
        + fn_xml("mode", "5", format="UINT16", units="V", access="read", values={1: "Auto", 2: "Man"})
        + fn_xml("volts", "6", format="UINT16", units="V", access="read")
    )
    proc = export(path, "homeassistant", tmp_path)
    assert proc.returncode == 0, proc.stderr
    sensors = {s["name"]: s for s in yaml.safe_load(proc.stdout)[0]["sensors"]}
    assert "unit_of_measurement" not in sensors["label"] and "device_class" not in sensors["label"]
    assert named(proc.stderr, "Home Assistant", "written without its unit") == {"label"}
    assert sensors["mode"]["unit_of_measurement"] == "V" and "device_class" not in sensors["mode"]
    assert "state_class" not in sensors["mode"]
    assert (sensors["volts"]["device_class"], sensors["volts"]["state_class"]) == ("voltage", "measurement")


def test_home_assistant_classes_are_ones_it_accepts():
    for spelling, found in CLASSES.items():
        if found.device_class is not None:
            units, states = ACCEPTED[found.device_class]
            assert spelling in units and found.state_class in states, (spelling, found)
        assert found.state_class in STATE_CLASSES


FUZZ = int(os.environ.get("MDL_FUZZ_WARNINGS", "50"))  # a longer run by hand: MDL_FUZZ_WARNINGS=500
UNITS = st.one_of(
    st.sampled_from(sorted(CLASSES)),
    st.sampled_from(["Volts", "AMPS", "kwh", "%rh", "C", "m", "m3", "deg C", "kilowatt hours", " V ", "v", "MW"]),
    st.text(max_size=6),
)


@settings(max_examples=4 * FUZZ, deadline=None)
@given(UNITS)
def test_fuzz_unit_spellings(units):
    """Any unit text: as written (no classes), or a spelling of CLASSES with its classes, accepted."""
    found = ha_unit(units)
    if found.device_class is None and found.state_class is None:
        assert found.unit == units and not found.guesses
        return
    assert found.unit in CLASSES or found.device_class == "humidity"
    if found.device_class is not None:
        accepted_units, states = ACCEPTED[found.device_class]
        assert found.unit in accepted_units and found.state_class in states


KINDS = [
    {"format": "UINT16"},
    {"format": "INT32", "units": "kWh"},
    {"format": "BIT", "register_type": "coil"},
    {"format": "BIT"},
    {"format": "UINT8", "length": "Lower byte"},
    {"format": "INT16", "register_type": "input", "units": "Volts"},
    {"format": "UINT16", "not_implemented": "0xFFFF"},
    {"format": "UINT16", "multiplier": "0.1", "offset": "-40"},
    {"format": "UINT16", "read_function_code": "arg = r1 + 1;"},
    {"format": "UINT16", "units": "furlongs"},
]


@settings(max_examples=FUZZ, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.lists(
        st.tuples(
            st.sampled_from(range(len(KINDS))), st.sampled_from(["read", "write", "read_write"]), st.integers(0, 30)
        ),
        min_size=1,
        max_size=12,
    )
)
def test_fuzz_every_export_says_each_kind_once(tmp_path_factory, functions):
    """Random descriptions: every engine export says each kind once, naming each function at most once in it,
    and Home Assistant gets only the classes it accepts."""
    tmp_path = tmp_path_factory.mktemp("fuzz")
    xml = ""
    for i, (kind, access, address) in enumerate(functions):
        fields = dict(KINDS[kind])
        if fields.get("register_type") == "input":
            access = "read"
        xml += fn_xml(f"f{i}", address, access=access, **fields)
    path = tmp_path / "d.xml"
    path.write_text(device_xml(xml), encoding="ascii")
    if cli("validate", path).returncode != 0:
        event("refused by validate")
        return
    event("exported")
    for engine in ENGINES:
        proc = export(path, engine, tmp_path)
        if proc.returncode != 0:
            assert_clean_error(proc, 1, "can hold none")
            continue
        assert_one_per_kind(proc.stderr)
        if engine == "homeassistant":
            for sensor in yaml.safe_load(proc.stdout)[0].get("sensors", []):
                if "device_class" in sensor:
                    units, states = ACCEPTED[sensor["device_class"]]
                    assert sensor["unit_of_measurement"] in units and sensor["state_class"] in states, sensor


def test_a_function_with_two_details_is_named_once(tmp_path, write_device):
    """A BIT in a holding register is a sensor and a switch in Home Assistant: both can share their register
    with an earlier entity, each with its own detail; the function is named once, with both."""
    path = write_device(
        fn_xml("word", "0", format="UINT16", access="read")
        + fn_xml("bit1", "0", format="BIT")
        + fn_xml("bit2", "0", format="BIT")
    )
    proc = export(path, "homeassistant", tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert_one_per_kind(proc.stderr)
    (line,) = [text for text in proc.stderr.splitlines() if "shares its register" in text]
    assert (
        ": warning: functions 'bit1' (holding 0, device_address 1: 'word'), 'bit2' (holding 0, device_address 1: "
        "'word'; holding 0, device_address 1: 'bit1'): Home Assistant: shares its register"
    ) in line, line
