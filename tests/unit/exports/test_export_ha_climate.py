"""Issue 37: what Home Assistant's modbus integration can write, the export writes with it. A thermostat is a
`climate` (its set point the target temperature, its room temperature the current one, an enumeration of
HVAC or fan modes its mode registers: ha_climate.py), and a writable register of range 0..1 a switch; every
other writable register stays a sensor with the modbus.write_register warning. Home Assistant's own schema and
entities check these exports in tests/engines/test_export_homeassistant.py; here, what the export writes and
says."""

from __future__ import annotations

import math

import pytest
import yaml

from support.common import EXAMPLE, fn_xml
from support.export_warnings import named
from support.run import cli

TEMCO = EXAMPLE / "temco_tstat.xml"


def export(path, *extra):
    proc = cli("export", path, "--to", "homeassistant", "--host", "192.0.2.10", *extra)
    assert proc.returncode == 0, proc.stderr
    return yaml.safe_load(proc.stdout)[0], proc.stderr


def test_the_thermostat_is_a_climate():
    """The TEMCO thermostat: occupied_setpoint (the first writable °C function) is the climate's target,
    room_temperature (the first read-only one, read alike) its current temperature."""
    hub, said = export(TEMCO)
    (climate,) = hub["climates"]
    assert climate == {
        "name": "occupied_setpoint",
        "unique_id": "temco_tstat_1_occupied_setpoint",
        "device_address": 1,
        "address": 121,
        "input_type": "holding",
        "data_type": "int16",
        "scale": 0.1,
        "precision": 1,
        "target_temp_register": 345,
        "temperature_unit": "C",
        "min_temp": 10,
        "max_temp": 30,
        "temp_step": 0.5,
        "scan_interval": 60,
    }
    # one entity per register: the climate reads 121, so room_temperature has no sensor of its own (warned)
    sensors = {s["name"] for s in hub["sensors"]}
    assert "room_temperature" not in sensors and "occupied_setpoint" in sensors
    assert named(said, "Home Assistant", "shows it as its current temperature") == {"room_temperature"}
    # the set point is written by the climate: no write_register warning, a note instead
    writes = named(said, "Home Assistant", "no entity that writes a register value")
    assert writes == {"modbus_address", "fan_speed", "system_mode", "unoccupied_setpoint", "occupied_heating_setpoint"}
    assert named(said, "Home Assistant", "written by Home Assistant's climate", "note") == {"occupied_setpoint"}


def test_the_climate_steps_by_targets_home_assistant_writes_as_mdl_does():
    """Home Assistant's climate writes int((value - offset) / scale): 10.1 / 0.1 is 100.99999999999999, written
    100 where mdl writes 101. The export steps by 0.5 (every half degree writes as mdl's) and says why."""
    from mdl.exports.ha_types import packed

    assert packed({"data_type": "int16", "scale": 0.1}, 10.1) == [100]  # the cut
    assert packed({"data_type": "int16", "scale": 0.1}, 10.5) == [105]
    assert packed({"data_type": "int16", "scale": 0.1}, -2.5) == [0x10000 - 25]
    assert packed({"data_type": "int32", "scale": 0.1, "swap": "word"}, 6553.7) == [1, 1]  # 65537, words swapped
    assert packed({"data_type": "int16"}, 40000) is None  # out of range: Home Assistant cannot pack it
    for half in range(20, 61):
        assert packed({"data_type": "int16", "scale": 0.1}, half / 2) == [half * 5]
    _, said = export(TEMCO)
    (line,) = [text for text in said.splitlines() if "it steps coarser" in text]
    assert "'occupied_setpoint' (temp_step 0.5: by 0.1, 10.1 written 100 where mdl writes 101)" in line


def test_an_unscaled_set_point_steps_by_one_without_a_warning(write_device):
    path = write_device(
        fn_xml("room", 0, format="INT16", units="degF", access="read")
        + fn_xml("setpoint", 1, format="INT16", units="degF", minimum="40", maximum="90")
    )
    hub, said = export(path)
    (climate,) = hub["climates"]
    assert (climate["temperature_unit"], climate["temp_step"], climate["min_temp"], climate["max_temp"]) == (
        "F",
        1,
        40,
        90,
    )
    assert "scale" not in climate and "precision" not in climate
    assert "coarser" not in said and "other than mdl does" not in said


MODES = {0: "Off", 1: "Heat", 2: "Cool", 3: "Auto", 4: "Emergency heat"}
FANS = {0: "auto", 1: "low", 2: "medium", 3: "high"}


def _profiled(write_device):
    """A thermostat described with the thermostat profile's roles (SPEC 13), a temperature before its set point
    that is no role's, an HVAC mode with a label Home Assistant has no mode for, a fan written with function 16."""
    return write_device(
        fn_xml("outdoor", 0, format="INT16", multiplier="0.1", units="°C".encode("ascii", "xmlcharrefreplace").decode())
        + fn_xml("limit", 1, format="INT16", multiplier="0.5", units="degC")
        + fn_xml("room", 2, format="INT16", multiplier="0.5", units="degC", access="read", role="room_temperature_c")
        + fn_xml("heat_sp", 3, format="INT16", multiplier="0.5", minimum="5", maximum="30", role="heating_setpoint_c")
        + fn_xml("sp", 4, format="INT16", multiplier="0.5", minimum="5", maximum="30", role="setpoint_c")
        + fn_xml("hvac", 5, format="UINT16", values=MODES, role="mode")
        + fn_xml("fan", 6, format="UINT16", values=FANS, write_multiple="true"),
        name="Zone",
    )


def test_roles_choose_the_climate_and_its_mode_registers(write_device):
    """setpoint_c before heating_setpoint_c before any other writable temperature; room_temperature_c the current
    one; the `mode` role's enumeration the HVAC modes (a label without a mode warned); an enumeration of fan
    modes the fan modes, written with function 16 as mdl writes it (an address in a list)."""
    hub, said = export(_profiled(write_device))
    (climate,) = hub["climates"]
    assert (climate["name"], climate["address"], climate["target_temp_register"]) == ("sp", 2, 4)
    assert (climate["scale"], climate["temp_step"], climate["min_temp"], climate["max_temp"]) == (0.5, 0.5, 5, 30)
    assert "precision" in climate and climate["precision"] == 1
    assert climate["hvac_mode_register"] == {
        "address": 5,
        "values": {"state_off": 0, "state_heat": 1, "state_cool": 2, "state_auto": 3},
    }
    assert climate["fan_mode_register"] == {
        "address": [6],
        "values": {"state_fan_auto": 0, "state_fan_low": 1, "state_fan_medium": 2, "state_fan_high": 3},
    }
    assert "'hvac' (4 'Emergency heat'): Home Assistant: Home Assistant's climate shows no HVAC mode" in said
    assert named(said, "Home Assistant", "written by Home Assistant's climate", "note") == {"sp", "hvac", "fan"}
    assert named(said, "Home Assistant", "no entity that writes a register value") == {"outdoor", "limit", "heat_sp"}


def test_labels_alone_make_an_hvac_mode_register(write_device):
    """Without the role, an enumeration is the HVAC mode where every label is one of Home Assistant's modes
    (in any case and spacing) and one of them heats, cools, dries or ventilates; several values may name one
    mode (a list). An on/off enumeration is no mode register."""
    path = write_device(
        fn_xml("room", 0, format="UINT16", units="°F".encode("ascii", "xmlcharrefreplace").decode(), access="read")
        + fn_xml("target", 1, format="UINT16", units="F")
        + fn_xml("power", 2, format="UINT16", values={0: "off", 1: "auto"})
        + fn_xml("mode", 3, format="UINT16", values={0: "OFF", 1: "Heating", 2: "cooling", 3: "Fan only", 4: "heat"})
    )
    hub, said = export(path)
    (climate,) = hub["climates"]
    assert climate["temperature_unit"] == "F"
    assert climate["hvac_mode_register"] == {
        "address": 3,
        "values": {"state_off": 0, "state_heat": [1, 4], "state_cool": 2, "state_fan_only": 3},
    }
    assert "fan_mode_register" not in climate
    assert named(said, "Home Assistant", "its labels taken as Home Assistant's HVAC modes", "note") == {"mode"}


@pytest.mark.parametrize(
    ("functions", "why"),
    [
        (  # the room temperature is read as another type than the set point: the climate reads both alike
            fn_xml("room", 0, format="INT16", multiplier="0.1", units="degC", access="read")
            + fn_xml("sp", 1, format="UINT16", multiplier="0.1", units="degC"),
            "types",
        ),
        (  # another scale
            fn_xml("room", 0, format="INT16", multiplier="0.01", units="degC", access="read")
            + fn_xml("sp", 1, format="INT16", multiplier="0.1", units="degC"),
            "scale",
        ),
        (  # kelvin: Home Assistant's climate takes °C or °F
            fn_xml("room", 0, format="INT16", units="K", access="read") + fn_xml("sp", 1, format="INT16", units="K"),
            "unit",
        ),
        (  # no room temperature
            fn_xml("sp", 1, format="INT16", multiplier="0.1", units="degC"),
            "alone",
        ),
        (  # a set point in an input register is read-only; one in a byte no data_type the climate writes
            fn_xml("room", 0, format="INT16", units="degC", access="read")
            + fn_xml("sp", 1, format="UINT8", length="Lower byte", units="degC"),
            "byte",
        ),
    ],
)
def test_no_climate_where_home_assistant_cannot_read_it_as_mdl(write_device, functions, why):
    hub, said = export(write_device(functions))
    assert "climates" not in hub, why
    assert named(said, "Home Assistant", "no entity that writes a register value") == {"sp"}, why


def test_two_state_registers_are_switches(write_device):
    """A writable register of range 0..1 is a switch writing what mdl writes for 1 and 0, verified by reading
    the register back; a byte of a register is verified too, warned (Home Assistant compares the whole
    register); write-only, a switch showing what it wrote; an enumeration or a wider range stays a sensor."""
    path = write_device(
        fn_xml("relay", 0, format="UINT16", minimum="0", maximum="1")
        + fn_xml("swapped", 1, format="UINT16", byte_order="little", minimum="0", maximum="1", write_multiple="true")
        + fn_xml("lo", 2, format="UINT8", length="Lower byte", minimum="0", maximum="1")
        + fn_xml("hi", 3, format="UINT8", length="Upper byte", minimum="0", maximum="1")
        + fn_xml("pulse", 4, format="UINT16", minimum="0", maximum="1", access="write")
        + fn_xml("named", 5, format="UINT16", values={0: "off", 1: "on"})
        + fn_xml("level", 6, format="UINT16", minimum="0", maximum="2")
    )
    hub, said = export(path)
    switches = {s["name"]: s for s in hub["switches"]}
    assert sorted(switches) == ["hi", "lo", "pulse", "relay", "swapped"]
    assert switches["relay"]["write_type"] == "holding" and switches["relay"]["verify"] == {}
    assert "command_on" not in switches["relay"]  # 1 and 0: Home Assistant's defaults
    assert switches["swapped"]["write_type"] == "holdings"
    assert (switches["swapped"]["command_on"], switches["swapped"]["command_off"]) == (0x0100, 0)
    assert (switches["hi"]["command_on"], switches["lo"].get("command_on", 1)) == (0x0100, 1)
    assert "verify" not in switches["pulse"]
    assert named(said, "Home Assistant", "verify compares the whole register") == {"lo", "hi"}
    assert named(said, "Home Assistant", "write-only: the switch shows the state it last wrote") == {"pulse"}
    assert named(said, "Home Assistant", "no entity that writes a register value") == {"named", "level"}
    sensors = {s["name"] for s in hub["sensors"]}
    assert {"relay", "swapped", "lo", "hi", "named", "level"} <= sensors and "pulse" not in sensors


def test_the_switch_writes_what_mdl_writes(write_device):
    """command_on and command_off are mdl's own encoding of 1 and 0 (mdl.ir.codec)."""
    from mdl.formats.loading import load_resolved
    from mdl.ir.codec import compile_encoder

    path = write_device(
        fn_xml("swapped", 1, format="INT16", byte_order="little", minimum="0", maximum="1")
        + fn_xml("hi", 3, format="UINT8", length="Upper byte", minimum="0", maximum="1")
    )
    hub, _ = export(path)
    for f in load_resolved(path).functions:
        encode = compile_encoder(f.codec, f.codec.encode)
        (switch,) = [s for s in hub["switches"] if s["name"] == f.name]
        assert [switch.get("command_on", 1), switch.get("command_off", 0)] == encode(1) + encode(0)


def test_a_float_set_point(write_device):
    path = write_device(
        fn_xml("room", "0 1", format="FLOAT32", units="degC", access="read")
        + fn_xml("sp", "2 3", format="FLOAT32", units="degC", minimum="5", maximum="35", precision="1")
    )
    hub, said = export(path)
    (climate,) = hub["climates"]
    assert (climate["data_type"], climate["precision"], climate["temp_step"]) == ("float32", 1, 0.1)
    assert "target_temp_write_registers" not in climate  # two registers: Home Assistant writes them with 16
    assert "other than mdl does" not in said and "coarser" not in said
    assert math.isclose(climate["max_temp"], 35)
