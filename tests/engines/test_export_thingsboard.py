"""`mdl export --to thingsboard`, proven with the ThingsBoard IoT Gateway's own connector code
(thingsboard-gateway 3.8.5 in a venv of its own: tests/support/engines_fleet.py): for each slave of the export, the
gateway's Master reads `mdl sim` with each point's function code, address and objectsCount (as
ModbusConnector.__read_slave_data does), and its BytesModbusUplinkConverter, configured by
BytesUplinkConverterConfig from the slave's own JSON, converts what it read; every point shows what
`mdl read` gives. No ThingsBoard server is involved."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest

from support.common import DATA, EXAMPLE, ROOT
from support.engines import installed_version, require
from support.engines_fleet import THINGSBOARD
from support.fleet_checks import WIDE, WIDE_RAW
from support.raw_images import ALL_TABLES_RAW, TEMCO_RAW
from support.run import assert_clean_error, run_mdl

pytestmark = pytest.mark.engines

ALL_TABLES = DATA / "all_tables.xml"
TEMCO = EXAMPLE / "temco_tstat.xml"

# the gateway's own classes read the device as the exported JSON says: {tag: value} of every point
READ = r"""
import asyncio, json, logging, sys
from pymodbus.client import AsyncModbusTcpClient
from thingsboard_gateway.connectors.modbus.entities.master import Master
from thingsboard_gateway.connectors.modbus.entities.bytes_uplink_converter_config import BytesUplinkConverterConfig
from thingsboard_gateway.connectors.modbus.bytes_modbus_uplink_converter import BytesModbusUplinkConverter

log = logging.getLogger("tb")
log.trace = lambda *args, **kwargs: None  # the gateway's logger has a TRACE level of its own

async def main():
    config = json.load(open(sys.argv[1]))
    out = {}
    for slave in config["master"]["slaves"]:
        master = Master(slave["type"], AsyncModbusTcpClient(slave["host"], port=slave["port"]))
        await master.connect()
        functions = master.get_available_functions()
        data = {"telemetry": {}, "attributes": {}}
        for section, key in (("timeseries", "telemetry"), ("attributes", "attributes")):
            for point in slave[section]:
                response = await functions[point["functionCode"]](
                    address=point["address"], count=point["objectsCount"], unit_id=slave["unitId"])
                data[key].setdefault(point["tag"], []).append(response)
        converter = BytesModbusUplinkConverter(BytesUplinkConverterConfig(log, **slave), log)
        converted = converter.convert(None, [data])
        for entry in converted.telemetry:
            out.update({key.key: value for key, value in entry.values.items()})
        out.update({key.key: value for key, value in converted.attributes.values.items()})
        await master.close()
    print(json.dumps(out))

asyncio.run(main())
"""


def export(path, *extra) -> subprocess.CompletedProcess:
    proc = run_mdl("export", path, "--to", "thingsboard", *extra)
    assert proc.returncode == 0, proc.stderr
    return proc


def through_the_gateway(tmp_path: Path, text: str) -> dict:
    python = require(THINGSBOARD)
    path = tmp_path / "modbus.json"
    path.write_text(text, encoding="utf-8")
    proc = subprocess.run([str(python), "-c", READ, str(path)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def same(got, want) -> bool:
    if isinstance(want, str):
        return isinstance(got, str) and got.rstrip("\x00 ") == want  # the padding the gateway keeps (warned)
    if isinstance(want, bool) or isinstance(got, bool):
        return bool(got) == want and got in (0, 1)
    return math.isclose(got, want, rel_tol=1e-12, abs_tol=0)


def points(text: str) -> int:
    return sum(len(slave[s]) for slave in json.loads(text)["master"]["slaves"] for s in ("timeseries", "attributes"))


@pytest.mark.parametrize(
    ("path", "raw"),
    [(ALL_TABLES, ALL_TABLES_RAW), (TEMCO, TEMCO_RAW), ("wide", WIDE_RAW)],
    ids=["all_tables", "temco", "wide"],
)
def test_the_gateway_reads_mdl_read_values(sim_factory, tmp_path, write_device, path, raw):
    if path == "wide":
        path = write_device("".join(WIDE))
    image = tmp_path / "raw.json"
    image.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", image, "--unit", "4")
    proc = export(path, *sim.connection, "--unit", "4", "--interval", "5")
    got = through_the_gateway(tmp_path, proc.stdout)
    read = run_mdl("read", path, *sim.connection, "--unit", "4", "--format", "json")
    assert read.returncode == 0, read.stderr
    expected = json.loads(read.stdout)
    assert len(got) == points(proc.stdout) > 0
    for tag, value in got.items():
        want = expected[tag]
        if want is None:  # no 'not implemented' value (warned): the gateway reads the value
            assert f"'{tag}'" in proc.stderr and "no 'not implemented' value" in proc.stderr
            continue
        assert same(value, want), (tag, value, want)


def test_export_structure_and_writes(tmp_path):
    doc = json.loads(export(ALL_TABLES, "--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E").stdout)
    slaves = doc["master"]["slaves"]
    assert {s["deviceName"] for s in slaves} == {"All Tables"}
    assert all(s["type"] == "serial" and s["method"] == "rtu" and s["baudrate"] == 9600 for s in slaves)
    writes = {p["tag"]: p["functionCode"] for s in slaves for p in s["attributeUpdates"]}
    assert writes["pump"] == 5 and writes["setpoint"] == 6 and writes["alarm_reset"] == 5
    assert {p["tag"] for s in slaves for p in s["rpc"]} == set(writes)


def test_thingsboard_refusal_is_clean(write_device):
    path = write_device(
        "<function><name>t</name><description>x</description><addresses>0</addresses>"
        "<format>UINT16</format><read_function_code>arg = r1;</read_function_code><access>read</access></function>"
    )
    assert_clean_error(
        run_mdl("export", path, "--to", "thingsboard"), 1, "ThingsBoard can hold none of this description's functions"
    )


def test_thingsboard_export_is_deterministic():
    assert export(ALL_TABLES).stdout == export(ALL_TABLES).stdout


def test_thingsboard_version_is_the_pinned_one():
    assert installed_version(require(THINGSBOARD), "thingsboard-gateway") == "3.8.5"


def test_every_example_exports(tmp_path):
    for path in sorted((ROOT / "examples").glob("*/*.xml")):
        doc = json.loads(export(path).stdout)
        assert doc["master"]["slaves"], path
