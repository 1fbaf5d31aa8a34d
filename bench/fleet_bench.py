#!/usr/bin/env python3
"""Polling a fleet from one process: `mdl read FILE@CONNECTION#UNIT...` of 200 simulated devices. Prints
figures; asserts nothing.

    python3 bench/fleet_bench.py                                  # 200 devices, 4 sims, 1 s and 0.1 s
    python3 bench/fleet_bench.py --devices 200 --sims 4 --intervals 1,0.25,0.1 --seconds 20

`--sims` `mdl sim` processes each serve `--devices / --sims` units of one description on one port
(units 1, 2, ...; each unit is a device of its own to the poller: its own connection, its own schedule).
One `mdl read` polls all of them, every S seconds each, for `--seconds`, then gets SIGINT. From its
records (json, one per device and poll) and its resource usage (`wait4`: user + system CPU of the
poller alone, not of the sims): polls per second, CPU milliseconds per poll, the share of polls that
started late (more than S/2 after the one before) and the machine's load average before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from datetime import datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEVICE = ROOT / "tests" / "data" / "all_tables.xml"
READY = re.compile(r"mdl sim: serving .* on (\S+):(\d+) unit (\d+)")


def mdl(*args: str) -> list[str]:
    return [sys.executable, "-m", "mdl", *args]


def start_sims(count: int, units: int, device: Path) -> tuple[list[subprocess.Popen[str]], list[tuple[str, int, int]]]:
    """`count` sims of `units` units each on free ports; their processes and (host, port, unit) of every unit."""
    procs, where = [], []
    for _ in range(count):
        args = [str(device)] * units + [a for u in range(1, units + 1) for a in ("--unit", str(u))]
        proc = subprocess.Popen(mdl("sim", *args, "--port", "0"), stdout=subprocess.PIPE, text=True)
        procs.append(proc)
        assert proc.stdout is not None
        for _ in range(units):
            m = READY.match(proc.stdout.readline())
            if m is None:
                raise SystemExit("mdl sim did not start")
            where.append((m.group(1), int(m.group(2)), int(m.group(3))))
    return procs, where


def poll(targets: list[str], interval: float, seconds: float) -> dict[str, float]:
    load_before = os.getloadavg()[0]
    err, records = (
        tempfile.TemporaryFile("w+"),
        tempfile.TemporaryFile("w+"),
    )  # files: a pipe left unread would stall it
    proc = subprocess.Popen(
        mdl("read", *targets, "--interval", str(interval), "--format", "json"), stdout=records, stderr=err, text=True
    )
    time.sleep(seconds)
    proc.send_signal(signal.SIGINT)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    records.seek(0)
    out = records.read()
    times: dict[str, list[datetime]] = defaultdict(list)
    for line in out.splitlines():
        record = json.loads(line)
        times[record["device"]].append(datetime.strptime(record["time"], "%Y-%m-%dT%H:%M:%S.%fZ"))
    polls = sum(len(t) for t in times.values())
    gaps = [(b - a).total_seconds() for t in times.values() for a, b in zip(t, t[1:], strict=False)]
    first = min(min(t) for t in times.values())
    last = max(max(t) for t in times.values())
    span = max((last - first).total_seconds(), 1e-9)
    cpu = usage.ru_utime + usage.ru_stime
    err.seek(0)
    failed = [line for line in err if ": error: " in line]
    if failed:
        print(f"  {len(failed)} failed polls, e.g. {failed[0].strip()}")
    return {
        "devices": len(times),
        "polls": polls,
        "polls_per_s": polls / span,
        "cpu_ms_per_poll": 1000 * cpu / max(polls, 1),
        "late": sum(g > 1.5 * interval for g in gaps) / max(len(gaps), 1),
        "load_before": load_before,
        "load_after": os.getloadavg()[0],
        "maxrss_mb": usage.ru_maxrss / 1024,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--devices", type=int, default=200)
    ap.add_argument("--sims", type=int, default=4)
    ap.add_argument("--intervals", default="1,0.1", help="seconds between a device's polls, comma separated")
    ap.add_argument("--seconds", type=float, default=15.0, help="how long each run polls")
    ap.add_argument("--device", type=Path, default=DEVICE)
    args = ap.parse_args()
    units = -(-args.devices // args.sims)
    procs, where = start_sims(args.sims, units, args.device)
    try:
        targets = [f"{args.device}@tcp://{host}:{port}#{unit}" for host, port, unit in where[: args.devices]]
        print(f"{len(targets)} devices ({args.device.name}, every readable function) on {args.sims} mdl sim processes")
        print(
            f"{'interval s':>10} {'polls/s':>9} {'CPU ms/poll':>12} {'late':>6} {'RSS MB':>7} {'load before/after':>18}"
        )
        for interval in (float(i) for i in args.intervals.split(",")):
            r = poll(targets, interval, args.seconds)
            print(
                f"{interval:>10g} {r['polls_per_s']:>9.1f} {r['cpu_ms_per_poll']:>12.2f} {r['late']:>6.1%} "
                f"{r['maxrss_mb']:>7.0f} {r['load_before']:>9.2f}/{r['load_after']:<8.2f}"
            )
    finally:
        for proc in procs:
            proc.send_signal(signal.SIGTERM)
        for proc in procs:
            proc.wait(timeout=30)


if __name__ == "__main__":
    main()
