#!/usr/bin/env python3
"""mdl's own fleet poller at scale (SPEC 15; issues 39 and 40): `mdl read --inventory` of hundreds and
thousands of simulated devices, its figures beside the targets. Prints figures; asserts nothing.

    python3 bench/fleet_bench.py                        # 500 and 2,000 units at 10 s, 200 at 0.5 s
    python3 bench/fleet_bench.py --runs 500@10,2000@10 --polls 5 --publish none,mqtt --keep /tmp/fleet

The site is the fleet tier's (tests/support/fleet_site.py): `mdl sim` processes serving units of
tests/data/all_tables.xml (19 functions, 11 requests a poll), each unit with raw values of its own, 90
units to a Modbus TCP port (a sim holds 100 connections; the poller opens one per Modbus TCP device) and
10 to an RTU-over-TCP line (`--framer rtu`; a tenth of the units on lines, none at intervals under 2 s: a
line's units take turns, 110 requests a round). One `mdl read --inventory SITE --format json --count N`
polls every unit every S seconds, with records to a file and, for `mqtt`, `--publish mqtt://...` to a
Mosquitto on loopback (the Debian package; its rows are left out without it). From its records and its
CPU (/proc, sampled; wait4 at the end), for each run:

- polls/s: once every device has polled once (from S after the first poll), records per second;
- CPU ms/poll: the poller's user + system CPU per poll over that same time (imports, the inventory,
  connections and the first polls excluded), and over the whole run;
- core: the poller's CPU over that same time, as a share of one core;
- late: the share of a device's polls that started more than 1.5 S after its previous one (the fleet tier's
  bound); max late: the most any poll started after S had passed since its device's previous one;
- start: from starting the process to its first poll (imports, the inventory, MQTT's first connection);
  first round: from the first poll to the last device's first (first polls are STAGGERed);
- RSS: the poller's peak resident memory (wait4);
- sims: the `mdl sim` processes' CPU over the run, as a share of one core, and the load average
  (1 minute) before and after: what else was on the cores.

Beside mdl's poller, on the same site and for as long, each engine the fleet tier proves (`--engines`): the
ThingsBoard gateway's own Modbus connector (tests/support/fleet_thingsboard.py) and Node-RED with
node-red-contrib-modbus (tests/support/fleet_nodered.py), each from its export of the same inventory, with
their own figures: device polls a second, CPU ms per device poll and share of a core of the engine's
process, late (a poll more than 1.5 S after the one before) and the worst gap, and peak RSS. An engine
not installed here (tests/support/engines_fleet.py, node_engines.py) is left out with the reason.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))  # the fleet tier's site and broker

from support.devices import Sim  # noqa: E402
from support.fleet_site import LINE_UNITS, Site, Usage, cpu_seconds  # noqa: E402

MIN_SECONDS = 10.0  # a run polls for this long at least (more polls at short intervals)
TARGETS = {  # (units, interval): what the poller must hold (issue 40)
    (2000, 10.0): "none late, on one core",
    (200, 0.5): "none late",
}


def parse_time(text: str) -> float:
    return datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ").replace(tzinfo=timezone.utc).timestamp()


def poll(site: Site, folder: Path, interval: float, polls: int, broker_port: int | None, keep: Path | None):
    """One `mdl read --inventory` of the site, and its figures; its records and stderr copied to `keep`."""
    inventory = site.inventory()
    args = ["read", "--inventory", str(inventory), "--format", "json", "--count", str(polls)]
    if broker_port is not None:
        args += ["--publish", f"mqtt://127.0.0.1:{broker_port}/site"]
    sims_before = sum(cpu_seconds(s.proc.pid) or 0.0 for s in site.sims)
    load_before = os.getloadavg()[0]
    with (folder / "records.jsonl").open("w+") as out, (folder / "stderr.txt").open("w+") as err:
        started = time.time()
        proc = subprocess.Popen([sys.executable, "-m", "mdl", *args], stdout=out, stderr=err, text=True)
        sampler = Usage(proc.pid, every=0.25, clock=time.time)
        _, status, usage = os.wait4(proc.pid, 0)
        ended = time.time()
        sampler.stop()
        out.seek(0)
        records = [json.loads(line) for line in out]
        err.seek(0)
        failed = [line.strip() for line in err if ": error: " in line]
    if keep is not None:
        keep.mkdir(parents=True, exist_ok=True)
        name = f"{len(site.units)}-{interval:g}-{'mqtt' if broker_port else 'none'}"
        shutil.copy(folder / "records.jsonl", keep / f"{name}.jsonl")
        shutil.copy(folder / "stderr.txt", keep / f"{name}.stderr.txt")
    sims_cpu = sum(cpu_seconds(s.proc.pid) or 0.0 for s in site.sims) - sims_before
    times: dict[str, list[float]] = defaultdict(list)
    for record in records:
        times[record["device"]].append(parse_time(record["time"]))
    intervals = {u.ident: u.interval for u in site.units}
    gaps = [(b - a, intervals[d]) for d, t in times.items() for a, b in zip(t, t[1:], strict=False)]
    stamps = sorted(t for ts in times.values() for t in ts)
    first = stamps[0] if stamps else ended
    steady_from = first + interval  # every device has polled once (first polls are spread over S at most)
    steady = [t for t in stamps if t >= steady_from]
    last = stamps[-1] if stamps else ended
    steady_cpu = sampler.at(last) - sampler.at(steady_from)
    total_cpu = usage.ru_utime + usage.ru_stime
    return {
        "status": os.waitstatus_to_exitcode(status),
        "devices": len(times),
        "polls": len(stamps),
        "failed": len(failed),
        "first_failure": failed[0] if failed else "",
        "polls_per_s": len(steady) / max(last - steady_from, 1e-9),
        "cpu_ms_steady": 1000 * steady_cpu / max(len(steady), 1),
        "cpu_ms_all": 1000 * total_cpu / max(len(stamps), 1),
        "core": steady_cpu / max(last - steady_from, 1e-9),
        "late": sum(g > 1.5 * s for g, s in gaps) / max(len(gaps), 1),
        "max_late": max((g - s for g, s in gaps), default=0.0),
        "start": first - started,
        "first_round": max(t[0] for t in times.values()) - first if times else 0.0,
        "rss_mb": usage.ru_maxrss / 1024,
        "sims_core": sims_cpu / max(ended - started, 1e-9),
        "load_before": load_before,
        "load_after": os.getloadavg()[0],
    }


def bench_thingsboard(site: Site, seconds: float) -> dict:
    from support.fleet_thingsboard import bench_thingsboard as run

    return run(site, seconds)


def bench_nodered(site: Site, seconds: float) -> dict:
    from support.fleet_nodered import figures

    r = figures(site, site.folder / "nodered", seconds)  # after a warm-up of two intervals
    return {
        "device_polls_per_s": r["polls_per_s"],  # a poll: one device's message
        "cpu_share": r["core"],
        "late_share": r["late_share"],
        "worst_gap_over_interval": r["max_gap_ratio"],
        "peak_rss_mb": r["rss_mb"],
    }


# an engine's name -> its run on a site for some seconds: a dict with device_polls_per_s, cpu_share (of one
# core), late_share, worst_gap_over_interval and peak_rss_mb
ENGINES = {"thingsboard": bench_thingsboard, "nodered": bench_nodered}


def engine_row(name: str, site: Site, units: int, interval: float, seconds: float) -> str:
    """One engine's row, or why it is left out."""
    try:
        r = ENGINES[name](site, seconds)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001  (an engine missing here, a skip, or a failure: said in its row)
        why = " ".join(str(exc).split())[:160]
        return f"{units:>5} {interval:>5g} {name:>11}  left out: {type(exc).__name__}: {why}"
    polls = r["device_polls_per_s"]
    cpu_ms = 1000 * r["cpu_share"] / polls if polls else math.nan
    max_late = (r["worst_gap_over_interval"] - 1) * interval
    return (
        f"{units:>5} {interval:>5g} {name:>11} {polls:>8.1f} {cpu_ms:>12.2f} {r['cpu_share']:>5.0%} "
        f"{r['late_share']:>6.1%} {max_late:>8.2f}s {'':>6} {'':>9} {r['peak_rss_mb']:>6.0f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", default="500@10,2000@10,200@0.5", help="UNITS@INTERVAL_S, comma separated")
    ap.add_argument("--polls", type=int, default=5, help="polls of each device in a run (--count)")
    ap.add_argument("--publish", default="none,mqtt", help="none (records only) and/or mqtt (records and MQTT)")
    ap.add_argument("--keep", type=Path, help="copy each run's records and stderr into this folder")
    ap.add_argument("--engines", default=",".join(ENGINES), help="engines beside mdl's poller ('' for none)")
    args = ap.parse_args()
    runs = [(int(u), float(s)) for u, s in (run.split("@") for run in args.runs.split(","))]
    modes = args.publish.split(",")
    engines = [e for e in args.engines.split(",") if e]
    mosquitto = shutil.which("mosquitto") or shutil.which("/usr/sbin/mosquitto")
    if "mqtt" in modes and mosquitto is None:
        print("mosquitto is not installed (apt-get install mosquitto): the mqtt rows are left out")
        modes = [m for m in modes if m != "mqtt"]
    print(
        f"mdl read --inventory of all_tables.xml units (19 functions, 11 requests a poll), {args.polls} polls each"
        f" (or {MIN_SECONDS:g} s of polls);"
        f" {os.cpu_count()} cores, load {' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min)"
    )
    head = (
        f"{'units':>5} {'S':>5} {'run':>11} {'polls/s':>8} {'CPU ms/poll':>12} {'core':>5} {'late':>6} "
        f"{'max late':>9} {'start':>6} {'1st round':>9} {'RSS MB':>6} {'sims':>5} {'load':>11}  target"
    )
    print(head)
    for units, interval in runs:
        lines = 0 if interval < 2 else max(1, units // (10 * LINE_UNITS))  # a tenth of the units on lines
        with tempfile.TemporaryDirectory(prefix="fleet_bench_") as tmp:
            folder = Path(tmp)
            sims: list[Sim] = []

            def start(paths, *extra, sims=sims):
                sim = Sim(paths, *extra, timeout=120)
                sims.append(sim)
                return sim

            site = None
            try:
                site = Site(folder, start, units, lines=lines, tcp_interval=interval, line_interval=interval,
                            converter=False)  # fmt: skip
                for mode in modes:
                    broker = None
                    if mode == "mqtt":
                        from support.mqtt import Broker

                        (folder / "broker").mkdir(exist_ok=True)
                        broker = Broker(folder / "broker")
                    try:
                        polls = max(args.polls, math.ceil(MIN_SECONDS / interval) + 1)
                        r = poll(site, folder, interval, polls, broker.port if broker else None, args.keep)
                    finally:
                        if broker is not None:
                            broker.stop()
                    target = TARGETS.get((units, interval), "")
                    print(
                        f"{units:>5} {interval:>5g} {'mdl ' + mode:>11} {r['polls_per_s']:>8.1f} "
                        f"{r['cpu_ms_steady']:>5.2f} /{r['cpu_ms_all']:>5.2f} {r['core']:>5.0%} {r['late']:>6.1%} "
                        f"{r['max_late']:>8.2f}s {r['start']:>5.1f}s {r['first_round']:>8.1f}s {r['rss_mb']:>6.0f} "
                        f"{r['sims_core']:>5.0%} "
                        f"{r['load_before']:>5.2f}/{r['load_after']:<5.2f}  {target}",
                        flush=True,
                    )
                    if r["failed"] or r["devices"] != units or r["status"] not in (0, 3):
                        print(
                            f"      {r['devices']} of {units} devices answered; {r['failed']} failed polls "
                            f"(exit {r['status']}) {r['first_failure']}"
                        )
                seconds = max(args.polls * interval, MIN_SECONDS)
                for name in engines:  # the same site, for as long as the poller's run
                    print(engine_row(name, site, units, interval, seconds), flush=True)
            finally:
                if site is not None:
                    site.close()
                for sim in sims:
                    sim.proc.send_signal(signal.SIGTERM)
                for sim in sims:
                    sim.stop()
    print("CPU ms/poll: once every device has polled / over the whole run (start-up included); core: of one")
    print("core once every device has polled; late: polls more than 1.5 S after the one before; sims: CPU of")
    print("the mdl sim processes (share of one core), on the same cores. Engine rows: device polls a second, CPU")
    print("ms per device poll and share of a core of the engine's process, late and the worst poll's lateness, RSS")


if __name__ == "__main__":
    main()
