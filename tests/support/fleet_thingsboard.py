"""The ThingsBoard IoT Gateway's own Modbus connector polling a fleet site (SPEC 15, issue 39), for
tests/fleet/test_thingsboard_at_scale.py and bench/fleet_bench.py.

`mdl export --inventory SITE.yml --to thingsboard -o DIR` writes DIR/modbus.json; RUNNER, run by the
python of the gateway's venv (thingsboard-gateway 3.8.5: support/engines_fleet.py THINGSBOARD), builds the
gateway's own `AsyncModbusConnector` (what the gateway loads for `"type": "modbus"`) on that JSON and starts
it: its event loop thread, a `Slave.__timer` task per slave, its request queue, its pymodbus client per
host and port (`Master`), its BytesModbusUplinkConverter and its convert and save loops, all unchanged.

Stubbed: only the gateway service object the connector is given (`TBGatewayService` in the gateway), as
there is no ThingsBoard server to send to. Gateway stands in for it with the methods 3.8.5's connector
calls: `get_config_path`, `get_devices`, `add_device` and `del_device` (the platform's device list: kept in a
dict, a device added counted as connected, as with a server), `send_to_storage(connector_name,
connector_id, data)` (where the gateway queues the ConvertedData for its storage and the server: here each
arrives as a JSON line `{"t": time.time(), "device": ..., "values": {key: value}}` in a file, and is
published to Mosquitto at `tb/DEVICE` when a broker port is given), and the attributes the gateway's own
remote-log handler reads (`stopped`, `tb_client` None: no server connection, `stop_event`).
"""

from __future__ import annotations

import json
import math
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from support.fleet_site import Site
from support.run import run_mdl

CONNECTOR = "Modbus"  # the connector's name (a gateway's tb_gateway.json names it), its logger's

RUNNER = r'''
import json, logging, os, resource, sys, threading, time

config_path, out_path, seconds, broker = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
# as the gateway's shipped config/logs.json: the root logger at ERROR (pymodbus's deprecation warnings, one
# per conversion, are not shown), the connector's own logger at its logLevel, to the console
logging.basicConfig(level=logging.ERROR, stream=sys.stderr, format="%(asctime)s %(levelname)s %(name)s: %(message)s")

from thingsboard_gateway.connectors.modbus.modbus_connector import AsyncModbusConnector

out = open(out_path, "w", buffering=1)
lock = threading.Lock()
client = None
published = []  # each publish's MQTTMessageInfo: all are acknowledged by the broker before the process ends
ended = False  # set at the run's end: what the connector hands over later is neither recorded nor published
if broker:
    import paho.mqtt.client as mqtt
    from paho.mqtt.enums import CallbackAPIVersion
    client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id="tb-gateway-stand-in")
    client.connect("127.0.0.1", broker)
    client.loop_start()


def write(record):
    with lock:
        out.write(json.dumps(record) + "\n")


class Gateway:
    """The stand-in for TBGatewayService: what AsyncModbusConnector 3.8.5 calls on it, no server."""

    stopped = False  # read by the gateway's remote-log handler (tb_handler.TBRemoteLoggerHandler)
    tb_client = None  # no connection to a ThingsBoard server: that handler's thread waits for one

    def __init__(self):
        self.stop_event = threading.Event()
        self.devices = {}

    def get_config_path(self):
        return os.path.dirname(os.path.abspath(config_path)) + os.sep

    def get_devices(self, connector_id=None):
        return self.devices

    def add_device(self, device_name, content, device_type=None):
        self.devices[device_name] = {"device_type": device_type or "default", **content}
        write({"t": time.time(), "event": "add_device", "device": device_name})
        return True

    def del_device(self, device_name, remove_device=True):
        self.devices.pop(device_name, None)
        write({"t": time.time(), "event": "del_device", "device": device_name})

    def send_to_storage(self, connector_name, connector_id, data):
        now = time.time()
        values = {}
        for entry in data.telemetry:
            values.update({key.key: value for key, value in entry.values.items()})
        values.update({key.key: value for key, value in data.attributes.values.items()})
        with lock:  # recorded and published together, so that the broker gets every arrival recorded
            if ended:
                return 0
            out.write(json.dumps({"t": now, "device": data.device_name, "values": values}) + "\n")
            if client is not None:
                message = json.dumps({"ts": int(now * 1000), "values": values})
                published.append(client.publish("tb/" + data.device_name, message, qos=1))
        return 0  # Status.SUCCESS

    def send_rpc_reply(self, *args, **kwargs):
        pass


config = json.load(open(config_path))
config.update({"name": "Modbus", "id": "modbus-fleet", "logLevel": "INFO"})
connector = AsyncModbusConnector(Gateway(), config, "modbus")
t0, c0 = time.time(), os.times()
write({"t": t0, "event": "open", "threads": threading.active_count()})
connector.open()
time.sleep(seconds)
t1, c1 = time.time(), os.times()
usage = resource.getrusage(resource.RUSAGE_SELF)
with lock:
    ended = True
    out.write(json.dumps({"t": t1, "event": "stop", "cpu": (c1.user - c0.user) + (c1.system - c0.system),
                          "wall": t1 - t0, "maxrss_kb": usage.ru_maxrss, "threads": threading.active_count()}) + "\n")
out.flush()
if client is not None:
    for info in published:  # paho's loop may be behind on a loaded machine: nothing queued is lost at exit
        info.wait_for_publish(60)
    client.loop_stop()
os._exit(0)  # the connector's close() takes 5 s or more (it cancels its tasks after a sleep): not measured
'''


def gateway_python() -> Path:
    """The python of the gateway's venv for a fleet test (support.engines.require is the engines tier's); the
    test skipped with the reason when it cannot be installed (a failure in CI)."""
    from support.common import skip_or_fail
    from support.engines import EngineUnavailable, engine_python
    from support.engines_fleet import THINGSBOARD

    try:
        return engine_python(THINGSBOARD)
    except EngineUnavailable as exc:
        skip_or_fail(f"thingsboard-gateway is not available: {exc}")
        raise AssertionError("unreachable") from None


def export_site(inventory: Path, folder: Path) -> tuple[dict, str]:
    """`mdl export --inventory INVENTORY --to thingsboard -o FOLDER/export`: the connector JSON (its path
    FOLDER/export/modbus.json) and the warnings."""
    proc = run_mdl("export", "--inventory", inventory, "--to", "thingsboard", "-o", folder / "export", timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads((folder / "export" / "modbus.json").read_text(encoding="utf-8")), proc.stderr


@dataclass
class Run:
    """The connector's run: what arrived (`send_to_storage`), the platform's device events, its stderr."""

    arrivals: list[dict] = field(default_factory=list)  # {"t", "device", "values"}
    events: list[dict] = field(default_factory=list)  # {"t", "event", "device"?, ...}
    stderr: str = ""
    returncode: int | None = None

    @property
    def opened(self) -> float:
        return next(e["t"] for e in self.events if e["event"] == "open")

    @property
    def stopped(self) -> dict:
        return next(e for e in self.events if e["event"] == "stop")


class Connector:
    """RUNNER as a process of the gateway's python, started at once and running `seconds`: `run_so_far`
    while it runs, `wait` for the whole run, `kill` if it is still running."""

    def __init__(self, python: Path, config: Path, folder: Path, seconds: float, broker: int = 0) -> None:
        self.out, self.err = folder / "arrivals.jsonl", folder / "gateway-stderr.txt"
        self.out.write_text("")
        with self.err.open("w") as stderr:
            cmd = [str(python), "-c", RUNNER, str(config), str(self.out), str(seconds), str(broker)]
            # cwd: the gateway writes its own log files (modbus_connector.log ...) where it runs
            self.proc = subprocess.Popen(cmd, stdout=stderr, stderr=stderr, cwd=folder)
        self.seconds = seconds

    def run_so_far(self) -> Run:
        run = Run(stderr=self.err.read_text(encoding="utf-8", errors="replace"), returncode=self.proc.poll())
        text = self.out.read_text(encoding="utf-8")
        for line in text.splitlines(keepends=True):
            if line.endswith("\n"):
                record = json.loads(line)
                (run.events if "event" in record else run.arrivals).append(record)
        return run

    def wait(self) -> Run:
        self.proc.wait(timeout=self.seconds + 120)
        return self.run_so_far()

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def slave_of(values: dict) -> frozenset[str]:
    """A slave of a device, by the keys it reads (each slave of a device reads keys of its own)."""
    return frozenset(values)


def gaps(run: Run, until: dict[str, float] | None = None) -> dict[tuple[str, frozenset[str]], list[float]]:
    """Each (device, slave)'s gaps between polls: from the connector's start to its first arrival, between its
    arrivals, and from its last to the run's end (or to `until[device]`, when it stopped answering: arrivals
    after it are not counted)."""
    stamps: dict[tuple[str, frozenset[str]], list[float]] = {}
    for a in run.arrivals:
        stamps.setdefault((a["device"], slave_of(a["values"])), []).append(a["t"])
    out: dict[tuple[str, frozenset[str]], list[float]] = {}
    for key, times in stamps.items():
        last = (until or {}).get(key[0], run.stopped["t"])
        row = [run.opened, *sorted(t for t in times if t <= last), last]
        out[key] = [b - a for a, b in zip(row, row[1:], strict=False)]
    return out


def figures(run: Run, intervals: dict[str, float], bound: float = 1.5) -> dict[str, Any]:
    """Polls a second (a poll: one slave's reads and conversion, one send_to_storage), device polls a second
    (each device's slaves taken as one), the gateway process's CPU ms per poll (from the connector's start to
    the end: its loop, pymodbus, the converter, and the stand-in's JSON lines), the share of polls later than
    `bound` times their interval, the worst gap over the interval, peak RSS, threads."""
    stop = run.stopped
    polls = len(run.arrivals)
    slaves = len({(a["device"], slave_of(a["values"])) for a in run.arrivals})
    devices = len({a["device"] for a in run.arrivals})
    # each poll's gap: from the start to the first poll, and between polls (the last, to the end, is cut short)
    every = [(device, g) for (device, _), row in gaps(run).items() for g in row[:-1]]
    late = [g for device, g in every if g > bound * intervals[device]]
    return {
        "seconds": round(stop["wall"], 1),
        "devices": devices,
        "slaves": slaves,
        "polls": polls,
        "polls_per_s": round(polls / stop["wall"], 1),
        "device_polls_per_s": round(polls * devices / max(slaves, 1) / stop["wall"], 1),
        "cpu_ms_per_poll": round(1000 * stop["cpu"] / max(polls, 1), 2),
        "cpu_share": round(stop["cpu"] / stop["wall"], 3),
        "late_share": round(len(late) / max(len(every), 1), 4),
        "worst_gap_over_interval": round(max((g / intervals[d] for d, g in every), default=math.nan), 2),
        "peak_rss_mb": round(stop["maxrss_kb"] / 1024, 1),
        "threads": stop["threads"],
    }


def bench_thingsboard(site: Site, seconds: float, folder: Path | None = None) -> dict[str, Any]:
    """For bench/fleet_bench.py: the gateway's connector polling `site` for `seconds`, and its figures."""
    from support.engines import engine_python
    from support.engines_fleet import THINGSBOARD

    folder = folder or site.folder / "thingsboard"
    folder.mkdir(parents=True, exist_ok=True)
    export_site(site.inventory(), folder)
    connector = Connector(engine_python(THINGSBOARD), folder / "export" / "modbus.json", folder, seconds)
    try:
        run = connector.wait()
    finally:
        connector.kill()
    assert run.returncode == 0, run.stderr[-3000:]
    return figures(run, {u.ident: u.interval for u in site.units})
