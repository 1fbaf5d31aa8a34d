"""The ThingsBoard IoT Gateway's own Modbus connector at scale (SPEC 15, issue 39): a site of 500 simulated
devices (support/fleet_site.py: 470 on six Modbus TCP ports, 30 on three RTU-over-TCP lines of 10, the third
a converter whose unit 1 is served by a sim of its own), the connector JSON `mdl export --inventory SITE.yml
--to thingsboard -o DIR` writes for it (a slave per byte and word order a device needs, three for
all_tables.xml: 1500 slaves, `deviceName` the device's id), and the gateway's own AsyncModbusConnector
(thingsboard-gateway 3.8.5 from PyPI, its venv support/engines_fleet.py THINGSBOARD) polling it for RUN s.

What runs is the gateway's code, unchanged (support/fleet_thingsboard.py RUNNER): its connector thread and
event loop, a timer task per slave that queues it every pollPeriod, its request loop, its pymodbus client per
host and port (requests one at a time on each: pymodbus's lock), its BytesModbusUplinkConverter and its
convert and save loops. Stubbed, and only that: the gateway service object the connector is given
(TBGatewayService), since there is no ThingsBoard server here for it to send to. The stand-in has the methods
3.8.5's connector calls on it: `send_to_storage(connector_name, connector_id, data)`, where the gateway
queues each ConvertedData for its storage and the server, records each with its time (time.time()) and
publishes it to Mosquitto at `tb/DEVICE`; `add_device`, `del_device` and `get_devices` keep the platform's
device list (a device added counts as connected, as with a server); `get_config_path`; and the attributes
the gateway's own remote-log handler reads (no server connection: it waits). Logging as the gateway's
shipped logs.json: the root logger at ERROR.

Proved: every device's every exported value arrives, in every poll, equal to `mdl read` of that unit (text
with the NUL padding the export warns of); every slave of every device is polled within 1.5 times its
interval, from the connector's start to its first poll, between polls and from its last to the end; the
unit whose sim is stopped mid-run (the first unit of the converter's line) is dropped from the platform by
the gateway (`del_device`) and is the only one its errors name, while the other nine units of its line keep
every value and their schedule to the end; and every poll that arrived is on the broker.

INTERVAL is 10 s, the inventory's default and the one mdl's own poller is held to (test_poller_at_scale).
The connector holds it at 500 devices with room: some 160 slave polls a second (53 device polls), 1.2 ms of
its process's CPU each (0.19 of a core), the worst gap 1.3 times the interval, on two cores shared with the
sims. That 1.3 is the silent unit's line, once: the gateway has no back-off for a unit that stops answering
(only for a connection it cannot open), so each of its slaves' polls spends one timeout (1 s) on the line
before failing, three a round, and its line mates' polls come that much later. Measured shorter
(support/fleet_thingsboard.py `bench_thingsboard`, one run each, the machine shared with other work): at
5 s the connector keeps up (300 slave polls a second) but those three timeouts push the line mates to 1.6
times; at 3 s the first round (every slave queued at once) takes 1.6 times; at 2 s, 650 slave polls a
second, 9 % of polls are late (the 90 units behind each port share one pymodbus client, one request at a
time, and the sims take most of a core).
"""

from __future__ import annotations

import json
import math
import time
from collections import defaultdict

from support.fleet_site import LINE_UNITS, Site, read_one
from support.fleet_thingsboard import CONNECTOR, Connector, export_site, gaps, gateway_python, slave_of
from support.mqtt import Subscriber, wait_for

UNITS = 500
INTERVAL = 10.0  # every device's (pollPeriod 10000 ms)
BOUND = 1.5  # every slave polled within 1.5 times its interval
RUN = 75.0  # s the connector runs: 7 polls of each device
SLAVES = 3  # all_tables.xml's slaves: BIG bytes with LITTLE words, BIG with BIG, LITTLE with BIG


def same(got, want) -> bool:
    """The gateway's value is mdl read's: text keeps its NUL padding (warned), a flag reads 0 or 1."""
    if isinstance(want, str):
        return isinstance(got, str) and got.rstrip("\x00 ") == want
    if isinstance(want, bool) or isinstance(got, bool):
        return bool(got) == want and got in (0, 1)
    return isinstance(got, (int, float)) and math.isclose(got, want, rel_tol=1e-12, abs_tol=0)


def test_500_devices_through_the_gateways_own_connector(sim_factory, broker, tmp_path):
    python = gateway_python()
    site = Site(tmp_path, sim_factory, UNITS, lines=3, tcp_interval=INTERVAL, line_interval=INTERVAL)
    connector = None
    sub = None
    try:
        lone = site.lone
        assert len(site.units) == UNITS and lone is not None and len(site.sims) == 10
        mates = [u.ident for u in site.units if u.connection == lone.connection and u is not lone]
        assert len(mates) == LINE_UNITS - 1
        expected = {u.ident: read_one(u.connection, u.unit) for u in site.units}
        assert len({json.dumps(v, sort_keys=True) for v in expected.values()}) == UNITS  # each unit its own values
        config, warned = export_site(site.inventory(), tmp_path)
        sub = Subscriber(broker.port, ["tb/#"])
        connector = Connector(python, tmp_path / "export" / "modbus.json", tmp_path, RUN, broker.port)

        def lone_read_whole() -> bool:
            run = connector.run_so_far()
            assert run.returncode is None, run.stderr[-3000:]
            return len({slave_of(a["values"]) for a in run.arrivals if a["device"] == lone.ident}) == SLAVES

        wait_for(lone_read_whole, RUN, "every slave of the lone unit polled")
        stopped = time.time()
        site.lone_sim.stop()  # the unit goes silent: its converter gets no answer for it
        run = connector.wait()
        wait_for(lambda: len(sub.messages) >= len(run.arrivals), 60, "every poll on the broker")
        time.sleep(0.5)  # a message sent twice (at least once) would follow its first copy
        messages = list(sub.messages)
    finally:
        if sub is not None:
            sub.close()
        if connector is not None:
            connector.kill()
        site.close()

    # the run: the connector ran to the end, and what it said names the stopped unit only
    assert run.returncode == 0, run.stderr[-3000:]
    assert "Traceback" not in run.stderr, run.stderr[-3000:]
    said = [line.split(" ", 2)[-1] for line in run.stderr.splitlines() if " INFO " not in line]
    own = [line for line in said if line.startswith(f"ERROR {CONNECTOR}: ")]  # the connector's own logger
    assert own and all(f"Failed to poll {lone.ident} device: " in line for line in own), own[:5]
    pymodbus = [line for line in said if line.startswith("ERROR pymodbus.logging: No response received")]
    assert len(pymodbus) == len(own) and len(own) + len(pymodbus) == len(said), said[:10]  # one for each

    # the export: a slave per byte and word order each device needs, named after the device, on its line
    slaves = config["master"]["slaves"]
    assert len(slaves) == SLAVES * UNITS
    tags: dict[str, dict[frozenset, list[str]]] = defaultdict(dict)  # device -> its slaves' keys
    units = {u.ident: u for u in site.units}
    for slave in slaves:
        unit = units[slave["deviceName"]]
        host, port = unit.connection.split("://")[1].rsplit(":", 1)
        method = "rtu" if unit.connection.startswith("rtu+tcp") else "socket"
        assert (slave["type"], slave["method"], slave["host"], slave["port"]) == ("tcp", method, host, int(port))
        assert (slave["unitId"], slave["pollPeriod"], slave["timeout"]) == (unit.unit, 10000, unit.timeout)
        keys = [p["tag"] for section in ("timeseries", "attributes") for p in slave[section]]
        tags[unit.ident][frozenset(keys)] = keys
    assert all(len(mine) == SLAVES for mine in tags.values())

    # every device's every value, in every poll, equal to `mdl read` of that unit
    by_device: dict[str, list[dict]] = defaultdict(list)
    for arrival in run.arrivals:
        by_device[arrival["device"]].append(arrival)
    assert set(by_device) == set(expected)
    for ident, mine in by_device.items():
        seen = {slave_of(a["values"]) for a in mine}
        assert seen == set(tags[ident]), ident  # each poll a slave's every value, every slave polled
        for arrival in mine:
            for key, value in arrival["values"].items():
                want = expected[ident][key]
                if want is None:  # no 'not implemented' value (warned): the gateway shows the raw value
                    assert f"'{key}'" in warned and "no 'not implemented' value" in warned
                    continue
                assert same(value, want), (ident, key, value, want)
    assert all(a["t"] < stopped + 2 * units[lone.ident].timeout for a in by_device[lone.ident])

    # the gateway dropped the silent unit from the platform, and no other
    dropped = [e for e in run.events if e["event"] == "del_device"]
    assert dropped and {e["device"] for e in dropped} == {lone.ident}, dropped[:5]
    assert all(e["t"] > stopped for e in dropped)

    # every slave of every device polled within 1.5 times its interval; the silent unit's until it went
    intervals = {u.ident: u.interval for u in site.units}
    found = gaps(run, until={lone.ident: stopped})
    assert len(found) == SLAVES * UNITS
    late = [(d, round(g, 2)) for (d, _), row in found.items() for g in row if g > BOUND * intervals[d]]
    assert not late, late[:10]
    end = run.stopped["t"]
    for ident in mates:  # the silent unit's line: every slave polled on after it went silent, to the end
        after = [a for a in by_device[ident] if a["t"] > stopped]
        assert len(after) >= SLAVES * math.floor((end - stopped) / (BOUND * INTERVAL)), ident

    # and on the broker: each device's polls at `tb/ID`, in order, each as it arrived
    topics: dict[str, list[dict]] = defaultdict(list)
    for topic, payload, _ in messages:
        got = json.loads(payload)
        mine = topics[topic]
        if not mine or mine[-1] != got:  # at least once: a copy follows its first
            mine.append(got)
    assert set(topics) == {f"tb/{ident}" for ident in expected}
    for ident, mine in by_device.items():
        sent = [{"ts": int(a["t"] * 1000), "values": a["values"]} for a in mine]
        assert topics[f"tb/{ident}"] == sent, ident
