"""The fleet engines' own code for the esphome and thingsboard export proofs (SPEC 11), in cached venvs
exactly as tests/support/engines.py makes them (`python3 tests/support/engines_fleet.py [NAME...]` creates them
ahead).

Versions (checked with `pip index versions`, Python 3.11):
- ESPHome: esphome 2026.6.5, the newest release that installs on Python 3.11; `esphome config FILE.yaml`
  validates a node's configuration offline (no toolchain is fetched for it).
- ThingsBoard IoT Gateway: thingsboard-gateway 3.8.5, the newest release, with what pip resolves for it;
  its Modbus connector's own classes are driven directly (no ThingsBoard server).
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__":  # run as a script: tests/ holds the support package
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from support.engines import Engine, engine_python  # noqa: E402

ESPHOME = Engine("esphome", ("esphome==2026.6.5",), probe="import esphome.components.modbus_controller")
THINGSBOARD = Engine(
    "thingsboard-gateway",
    ("thingsboard-gateway==3.8.5",),
    probe="import thingsboard_gateway.connectors.modbus.modbus_connector",
)
FLEET_ENGINES = {engine.name: engine for engine in (ESPHOME, THINGSBOARD)}

if __name__ == "__main__":
    for name in sys.argv[1:] or list(FLEET_ENGINES):
        print(f"{name}: {engine_python(FLEET_ENGINES[name])}")
