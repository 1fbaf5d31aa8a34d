"""Node-RED with node-red-contrib-modbus polling a fleet site (SPEC 11.1 and 15, issue 39), for the fleet tier
(tests/fleet/test_nodered_at_scale.py) and bench/fleet_bench.py.

Node-RED 4.1.15 and node-red-contrib-modbus 5.23.3 come from npm, cached (support/node_engines.py). `NodeRed`
starts Node-RED headless (no editor, no HTTP) from a user folder holding the flows file and its settings, as
tests/engines/test_export_nodered.py starts it. The flow is what `mdl export --inventory SITE.yml --to nodered
--publish mqtt://127.0.0.1:PORT/PREFIX -o DIR` writes (one flow, a tab per line), unchanged: only Node-RED's
own code reads the devices, and the tests and the bench only observe what reaches Mosquitto on loopback
(`Arrivals`: every message under PREFIX/# with the monotonic time it arrived; a poll's message is
`{device, unit, values}` on PREFIX/ID). `peak_rss_mb` reads the node process's memory from /proc
(support.fleet_site.Usage samples its CPU).

`figures(site, folder, duration)` runs a whole measurement for the bench: a broker, the export, Node-RED for
`duration` seconds of steady polling, and the figures (polls/s, CPU ms per poll, the share of polls late
beyond 1.5 times the interval, peak RSS).
"""

from __future__ import annotations

import json
import threading
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from support.engines import EngineUnavailable
from support.fleet_site import Site, Usage, read_one
from support.mqtt import Broker, mqtt, wait_for
from support.node_engines import NODE_RED, NodeRed, engine_dir
from support.run import run_mdl

BOUND = 1.5  # a device is polled within 1.5 times its interval (SPEC 15)
PREFIX = "site"
SAFE = (1 << 53) - 1  # the largest integer a JavaScript number holds, with every one below it


def node_red_home() -> Path:
    """The cached Node-RED install's folder for a fleet test or the bench (support.node_engines.require_node_engine
    is the engines tier's); the test skipped with the reason when it cannot be installed (a failure in CI)."""
    from support.common import skip_or_fail

    try:
        return engine_dir(NODE_RED)
    except EngineUnavailable as exc:
        skip_or_fail(f"node-red is not available: {exc}")
        raise AssertionError("unreachable") from None


class Arrivals:
    """Every message published under `PREFIX/#` on the broker at `port`, as (monotonic time of arrival, topic,
    payload), in arrival order (QoS 1, a session of its own, subscribed before Node-RED starts)."""

    def __init__(self, port: int, prefix: str = PREFIX) -> None:
        from paho.mqtt.enums import CallbackAPIVersion

        self.messages: list[tuple[float, str, bytes]] = []
        self.ready = threading.Event()
        self.client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=f"arrivals-{port}", clean_session=True)

        def on_connect(c, u, flags, reason, props):
            c.subscribe([(f"{prefix}/#", 1)])

        self.client.on_connect = on_connect
        self.client.on_subscribe = lambda *args: self.ready.set()
        self.client.on_message = lambda c, u, m: self.messages.append((time.monotonic(), m.topic, m.payload))
        self.client.connect("127.0.0.1", port)
        self.client.loop_start()
        assert self.ready.wait(60), "the subscriber did not subscribe"

    def polls(self) -> dict[str, list[tuple[float, dict]]]:
        """device id -> its polls' (arrival, payload), in order."""
        out: dict[str, list[tuple[float, dict]]] = defaultdict(list)
        for at, _, payload in list(self.messages):
            message = json.loads(payload)
            out[message["device"]].append((at, message))
        return out

    def close(self) -> None:
        self.client.loop_stop()
        self.client.disconnect()


def peak_rss_mb(pid: int) -> float | None:
    """The process's peak resident memory so far (VmHWM), in MiB."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    for line in status.splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return None


def read_site(site: Site) -> dict[str, dict]:
    """`mdl read` of every unit of the site, one after another (in process): device id -> its values."""
    return {u.ident: read_one(u.connection, u.unit) for u in site.units}


def same(got: Any, want: Any) -> bool:
    """A value of a message equals mdl read's: booleans as booleans, numbers as the same double (JSON has one
    number: 20 and 20.0), an integer beyond 2^53 - 1 as its digits in a string (the export warns), text
    exactly."""
    if isinstance(want, bool) or isinstance(got, bool):
        return got is want
    if isinstance(want, int) and abs(want) > SAFE:
        return got == str(want)
    if isinstance(want, (int, float)) and isinstance(got, (int, float)):
        return float(got) == float(want)
    return got == want


def export_flow(inventory: Path, folder: Path, broker_port: int, prefix: str = PREFIX) -> tuple[list[dict], str]:
    """`mdl export --inventory INVENTORY --to nodered --publish mqtt://127.0.0.1:PORT/PREFIX -o FOLDER`: the
    flow's nodes, and what the export said."""
    url = f"mqtt://127.0.0.1:{broker_port}/{prefix}"
    proc = run_mdl("export", "--inventory", inventory, "--to", "nodered", "--publish", url, "-o", folder, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads((folder / "flows.json").read_text(encoding="utf-8")), proc.stderr


def gaps(times: list[float], start: float) -> list[float]:
    """The gaps between a device's polls, the first from `start` (the site's first poll)."""
    stamps = [start, *times]
    return [b - a for a, b in zip(stamps, stamps[1:], strict=False)]


def figures(site: Site, folder: Path, duration: float, warmup: float | None = None) -> dict[str, Any]:
    """Node-RED polling the whole site (the exported flow, publishing to a Mosquitto of its own on loopback)
    for `warmup` (default: twice the longest interval: every device connected and polled) and then `duration`
    seconds; returns the figures over those `duration` seconds:

    - polls_per_s: polls (MQTT messages) a second;
    - cpu_ms_per_poll: the node process's user + system CPU per poll (from /proc), and core: that CPU as a
      share of one core;
    - late_share: the share of polls that came more than 1.5 times their device's interval after the device's
      previous one (arrival on the broker), and max_gap_ratio: the longest gap over the interval;
    - silent: devices with no poll in the window;
    - rss_mb: the node process's peak resident memory (VmHWM) over the whole run;
    - start_s: from starting Node-RED to its first poll; first_round_s: from that to the last device's first.
    """
    folder.mkdir(parents=True, exist_ok=True)
    interval = {u.ident: u.interval for u in site.units}
    warmup = 2 * max(interval.values()) if warmup is None else warmup
    (folder / "broker").mkdir(exist_ok=True)
    broker = Broker(folder / "broker", "max_queued_messages 0\n")
    arrivals = red = usage = None
    try:
        nodes, _ = export_flow(site.inventory(), folder / "flow", broker.port)
        arrivals = Arrivals(broker.port)
        began = time.monotonic()
        red = NodeRed(folder / "node-red", nodes, node_red_home())
        usage = Usage(red.pid)
        wait_for(lambda: arrivals.messages, 120 + 2 * max(interval.values()), "Node-RED's first poll")
        first = arrivals.messages[0][0]
        time.sleep(max(0.0, first + warmup - time.monotonic()))
        window = (time.monotonic(), time.monotonic() + duration)
        time.sleep(duration)
        rss = peak_rss_mb(red.pid)
        cpu = usage.at(window[1]) - usage.at(window[0])
        polls = arrivals.polls()
    finally:
        if usage is not None:
            usage.stop()
        if red is not None:
            red.stop()
        if arrivals is not None:
            arrivals.close()
        broker.stop()
    in_window = late = count = 0
    worst = 0.0
    for ident, mine in polls.items():
        times = [at for at, _ in mine]
        for before, at in zip(times, times[1:], strict=False):
            if window[0] <= at <= window[1]:
                count += 1
                ratio = (at - before) / interval[ident]
                worst = max(worst, ratio)
                late += ratio > BOUND
        in_window += sum(window[0] <= at <= window[1] for at in times)
    silent = [u.ident for u in site.units if not any(window[0] <= at <= window[1] for at, _ in polls.get(u.ident, []))]
    seconds = window[1] - window[0]
    return {
        "units": len(site.units),
        "interval_s": max(interval.values()),
        "polls_per_s": in_window / seconds,
        "cpu_ms_per_poll": 1000 * cpu / in_window if in_window else float("nan"),
        "core": cpu / seconds,
        "late_share": late / count if count else float("nan"),
        "max_gap_ratio": worst,
        "silent": silent,
        "rss_mb": rss,
        "start_s": first - began,
        "first_round_s": max(times[0][0] for times in polls.values()) - first if polls else float("nan"),
    }
