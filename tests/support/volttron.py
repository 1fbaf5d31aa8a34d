"""VOLTTRON's own Modbus driver (volttron-lib-modbustk-driver, in its engine environment: support/engines.py)
reading an exported register map from a device."""

from __future__ import annotations

import csv
import json
import subprocess

from support.engines import VOLTTRON, require

# What the platform driver does with a device's config: the interface's configure() takes the
# driver_config (its register_map reference resolved to the map's rows) and the registry's rows;
# scrape_all() is one poll; set_point() one write.
DRIVER = r"""
import csv, json, sys
from volttron.driver.interfaces.modbus_tk.modbus_tk import ModbusTK

folder, stem, writes = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])

def rows(reference):
    assert reference.startswith("config://"), reference
    with open(f"{folder}/{reference[len('config://'):]}", newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))

with open(f"{folder}/{stem}.config", encoding="utf-8") as handle:
    config = json.load(handle)
assert config["driver_type"] == "modbus_tk"
driver = dict(config["driver_config"], register_map=rows(config["driver_config"]["register_map"]))
interface = ModbusTK()
interface.configure(driver, rows(config["registry_config"]))
before = interface.scrape_all()
for point, value in writes.items():
    interface.set_point(point, value)
print(json.dumps({"before": before, "after": interface.scrape_all()}))
"""


def run_volttron(folder, stem, writes=None) -> subprocess.CompletedProcess:
    python = require(VOLTTRON)
    return subprocess.run(
        [str(python), "-c", DRIVER, str(folder), stem, json.dumps(writes or {})],
        capture_output=True,
        text=True,
        timeout=120,
    )


def through_volttron(folder, stem, writes=None) -> dict:
    proc = run_volttron(folder, stem, writes)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def map_rows(folder, stem) -> dict[str, dict[str, str]]:
    with open(folder / f"{stem}_map.csv", newline="", encoding="utf-8") as handle:
        return {row["Register Name"]: row for row in csv.DictReader(handle)}
