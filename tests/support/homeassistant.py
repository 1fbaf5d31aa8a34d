"""Home Assistant's own modbus entities (homeassistant in its engine environment: support/engines.py) reading an
exported configuration from a device: the states they show."""

from __future__ import annotations

import json
import subprocess

from support.engines import HOMEASSISTANT, require

# Home Assistant's own entities on the exported hub: the schema fills the defaults, a ModbusHub connects,
# each switch is turned as asked (then updated: verify reads it back), each sensor and binary sensor
# updated once. States as Home Assistant holds them: a sensor's native_value, the others' is_on.
ENTITIES = r"""
import asyncio, json, sys
from homeassistant.core import HomeAssistant
from homeassistant.util.yaml import load_yaml
from homeassistant.components.modbus import CONFIG_SCHEMA
from homeassistant.components.modbus.modbus import ModbusHub
from homeassistant.components.modbus.sensor import ModbusRegisterSensor
from homeassistant.components.modbus.binary_sensor import ModbusBinarySensor
from homeassistant.components.modbus.switch import ModbusSwitch

async def main():
    hub_config = CONFIG_SCHEMA(load_yaml(sys.argv[1]))["modbus"][0]
    turns = json.loads(sys.argv[2])
    hass = HomeAssistant(sys.argv[3])
    kinds = ("sensors", "binary_sensors", "switches")
    hub = ModbusHub(hass, {k: v for k, v in hub_config.items() if k not in kinds})
    assert await hub.async_setup()
    await hass.async_block_till_done()
    out = {kind: {} for kind in kinds}
    entities = [("switches", ModbusSwitch(hass, hub, e)) for e in hub_config.get("switches", [])]
    entities += [("sensors", ModbusRegisterSensor(hass, hub, e, 0)) for e in hub_config.get("sensors", [])]
    entities += [("binary_sensors", ModbusBinarySensor(hass, hub, e, 0)) for e in hub_config.get("binary_sensors", [])]
    for kind, entity in entities:
        entity.async_write_ha_state = lambda: None  # not added to a running Home Assistant: no state machine
        if kind == "switches" and entity.name in turns:
            await (entity.async_turn_on() if turns[entity.name] else entity.async_turn_off())
        await entity.async_update()
        out[kind][entity.name] = entity.native_value if kind == "sensors" else entity.is_on
    await hass.async_stop(force=True)
    print(json.dumps(out))

asyncio.run(main())
"""


def configuration(folder, text: str):
    """configuration.yaml in `folder` as a Home Assistant user writes it, `modbus: !include modbus.yaml`, beside
    the export saved as modbus.yaml: its path (Home Assistant's load_yaml reads the include)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "modbus.yaml").write_text(text, encoding="utf-8")
    path = folder / "configuration.yaml"
    path.write_text("modbus: !include modbus.yaml\n", encoding="utf-8")
    return path


def through_home_assistant(tmp_path, text: str, turns: dict | None = None) -> dict:
    """The states Home Assistant's own entities show for the exported YAML (ENTITIES)."""
    python = require(HOMEASSISTANT)
    path = configuration(tmp_path / "entities", text)
    config_dir = tmp_path / "ha_config"
    config_dir.mkdir(exist_ok=True)
    proc = subprocess.run(
        [str(python), "-c", ENTITIES, str(path), json.dumps(turns or {}), str(config_dir)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])
