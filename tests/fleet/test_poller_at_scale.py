"""mdl's own poller at scale (SPEC 15, issue 39): `mdl read --inventory` of a site of 500 simulated devices
(support/fleet_site.py: 470 on six Modbus TCP ports, 30 on three RTU-over-TCP lines of 10, the third a
converter whose unit 1 is served by a sim of its own), publishing to Mosquitto on loopback. Every device's every
value arrives, in its records on stdout and on the broker, and equals `mdl read` of that unit; every device
is polled within 1.5 times its interval; the unit whose sim is stopped mid-run is backed off, said once,
and the other units of its line keep their values and their schedule."""

from __future__ import annotations

import json
import subprocess
import time
from collections import defaultdict
from datetime import datetime, timezone
from pathlib import Path

from support.fleet_site import LINE_UNITS, Site, read_one
from support.mqtt import Subscriber, wait_for
from support.run import mdl_cmd

UNITS = 500
INTERVAL = 10.0  # every device's: the inventory's default (50 polls a second, 550 requests, 950 values)
POLLS = 4  # --count: the stopped unit's last three polls fail, the third says `backing off`
BOUND = 1.5  # every device polled within 1.5 times its interval
RUN = 180


def parse_time(text: str) -> datetime:
    return datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ")


def records_so_far(path: Path) -> list[dict]:
    text = path.read_text(encoding="utf-8")
    return [json.loads(line) for line in text.splitlines(keepends=True) if line.endswith("\n")]


def test_500_devices_every_value_on_time_and_a_stopped_unit_backed_off(sim_factory, broker, tmp_path):
    site = Site(tmp_path, sim_factory, UNITS, lines=3, tcp_interval=INTERVAL, line_interval=INTERVAL)
    proc = None
    sub = None
    try:
        lone = site.lone
        assert len(site.units) == UNITS and lone is not None and len(site.sims) == 10
        mates = [u.ident for u in site.units if u.connection == lone.connection and u is not lone]
        assert len(mates) == LINE_UNITS - 1
        expected = {u.ident: read_one(u.connection, u.unit) for u in site.units}
        assert len({json.dumps(v, sort_keys=True) for v in expected.values()}) == UNITS  # each unit its own values
        inventory = site.inventory()
        sub = Subscriber(broker.port, ["site/#"])
        out, err = tmp_path / "records.jsonl", tmp_path / "stderr.txt"
        url = f"mqtt://127.0.0.1:{broker.port}/site"
        read = mdl_cmd("read", "--inventory", inventory, "--format", "json", "--count", POLLS, "--publish", url)
        with out.open("w") as stdout, err.open("w") as stderr:
            proc = subprocess.Popen(read, stdout=stdout, stderr=stderr)
        wait_for(lambda: any(r["device"] == lone.ident for r in records_so_far(out)), RUN, "the lone unit's first poll")
        stopped = datetime.now(timezone.utc).replace(tzinfo=None)
        site.lone_sim.stop()  # the unit goes silent: its converter gets no answer for it
        proc.wait(timeout=RUN)
        records = records_so_far(out)
        said = err.read_text(encoding="utf-8")
        topics: dict[str, list[dict]] = defaultdict(list)
        polls = len(records) * len(expected[lone.ident])

        def values_arrived() -> int:
            return sum(t.count("/") == 2 and not t.endswith("/$status") for t, _, _ in sub.messages)  # site/ID/FN

        deadline = time.monotonic() + 60
        while values_arrived() < polls and time.monotonic() < deadline:
            time.sleep(0.2)
        assert values_arrived() >= polls, f"{values_arrived()} of {polls} values on the broker; stderr: {said[-2000:]}"
        time.sleep(0.5)  # a message sent twice (at least once) would follow its first copy
        for topic, payload, _ in list(sub.messages):
            topics[topic].append(json.loads(payload) if payload.startswith(b"{") else {"status": payload.decode()})
    finally:
        if sub is not None:
            sub.close()
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
        site.close()

    # the run: exit 3 (the stopped unit's last poll failed), and nothing said of the devices that answer
    assert proc.returncode == 3, said
    assert "Traceback" not in said
    problems = [line for line in said.splitlines() if ": note: " not in line]
    assert all(f": {lone.ident}: " in line for line in problems), problems[:5]
    assert said.count(f"{lone.ident}: error: ") == 3, said
    assert said.count(f"{lone.ident}: backing off: ") == 1 and "answering again" not in said, said

    # every device's every value, in its records, equal to `mdl read` of that unit
    by_device: dict[str, list[dict]] = defaultdict(list)
    for record in records:
        assert list(record) == ["time", "device", "values"]
        by_device[record["device"]].append(record)
    assert set(by_device) == set(expected)
    for ident, mine in by_device.items():
        assert all(r["values"] == expected[ident] for r in mine), ident
        if ident != lone.ident:
            assert len(mine) == POLLS, (ident, len(mine))
    lone_polls = by_device[lone.ident]
    assert lone_polls and all(parse_time(r["time"]) < stopped for r in lone_polls)

    # every device polled within 1.5 times its interval: its first poll after the site's first, then each
    first = min(parse_time(r["time"]) for r in records)
    interval = {u.ident: u.interval for u in site.units}
    late = []
    for ident, mine in by_device.items():
        stamps = [first] + [parse_time(r["time"]) for r in mine]
        gaps = [(b - a).total_seconds() for a, b in zip(stamps, stamps[1:], strict=False)]
        late += [(ident, round(gap, 2)) for gap in gaps if gap > BOUND * interval[ident]]
    assert not late, late[:10]
    for ident in mates:  # the stopped unit's line: polled on after it went silent, whole and on time
        assert sum(parse_time(r["time"]) > stopped for r in by_device[ident]) >= POLLS - 1, ident

    # and on the broker: `site/ID/FUNCTION`, each poll's value at its time, in order
    for ident, mine in by_device.items():
        for name in expected[ident]:
            got = topics[f"site/{ident}/{name}"]
            kept = [p for i, p in enumerate(got) if i == 0 or p["time"] != got[i - 1]["time"]]  # at least once
            assert [p["time"] for p in kept] == [r["time"] for r in mine], (ident, name)
            assert [p["value"] for p in kept] == [r["values"][name] for r in mine], (ident, name)
    assert topics[f"site/{lone.ident}/$status"][-1] == {"status": "offline"}
    assert all(topics[f"site/{ident}/$status"] == [{"status": "online"}] for ident in mates)
