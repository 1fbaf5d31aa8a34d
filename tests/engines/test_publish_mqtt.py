"""`mdl read --interval S --publish mqtt://HOST[:PORT]/PREFIX` (SPEC section 11, docs/fleet.md) against a real
broker: Debian's mosquitto, started here on a free loopback port with a temporary configuration. Every poll
arrives, in order, retained, with Home Assistant's discovery configs; the broker and the device stopped and
started again mid-run: polling and publishing go on, order kept, the process alive."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device.fleet.mqtt import parse_url
from support.common import DATA
from support.devices import read_lines
from support.mqtt import RUN, Broker, Subscriber, free_port, times_in_order, wait_for
from support.run import assert_clean_error, mdl_cmd, run_mdl

pytestmark = pytest.mark.engines  # a broker of its own


ALL = DATA / "all_tables.xml"
NAMES = ["setpoint", "mode", "pump", "energy"]
FAST = ["--timeout", "0.5", "--retries", "0"]  # a device that went away fails its polls quickly


@pytest.fixture
def broker(tmp_path):
    b = Broker(tmp_path)
    try:
        yield b
    finally:
        b.stop()


def test_every_poll_arrives_in_order_with_discovery_configs(broker, sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5", "--set", "energy=1234")
    sub = Subscriber(broker.port, ["pfx/#", "homeassistant/#"])
    try:
        url = f"mqtt://127.0.0.1:{broker.port}/pfx"
        proc = run_mdl(
            "read", ALL, *sim.connection, *NAMES, "--interval", "0.2", "--count", "4", "--format", "json",
            "--publish", url, timeout=RUN,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        records = [json.loads(line) for line in proc.stdout.splitlines()]
        wait_for(lambda: len(sub.payloads("pfx/all_tables/pump")) >= 4, what="4 polls")
        wait_for(lambda: any(t == "pfx/status" and p == b"offline" for t, p, _ in sub.messages), what="offline")
    finally:
        sub.close()
    for name in NAMES:
        got = sub.payloads(f"pfx/all_tables/{name}")
        assert [p["time"] for p in got] == [r["time"] for r in records], name
        assert [p["value"] for p in got] == [r[name] for r in records], name
    assert all(retain is False for t, _, retain in sub.messages)  # it was listening: live, not the retained copy
    configs = {t: json.loads(p) for t, p, _ in sub.messages if t.startswith("homeassistant/")}
    assert set(configs) == {
        "homeassistant/sensor/pfx-all_tables/setpoint/config",
        "homeassistant/sensor/pfx-all_tables/mode/config",
        "homeassistant/binary_sensor/pfx-all_tables/pump/config",
        "homeassistant/sensor/pfx-all_tables/energy/config",
    }
    setpoint = configs["homeassistant/sensor/pfx-all_tables/setpoint/config"]
    assert setpoint["state_topic"] == "pfx/all_tables/setpoint"
    assert (setpoint["device_class"], setpoint["state_class"], setpoint["unit_of_measurement"]) == (
        "temperature",
        "measurement",
        "°C",
    )
    energy = configs["homeassistant/sensor/pfx-all_tables/energy/config"]
    assert (energy["device_class"], energy["state_class"]) == ("energy", "total_increasing")
    assert "a meter's counter" in proc.stderr  # the guess is said
    mode = configs["homeassistant/sensor/pfx-all_tables/mode/config"]
    assert "device_class" not in mode  # an enumeration
    assert mode["device"]["identifiers"] == ["mdl-pfx-all_tables"]
    assert mode["unique_id"] == "mdl-pfx-all_tables-mode"
    assert mode["availability"] == [{"topic": "pfx/status"}, {"topic": "pfx/all_tables/$status"}]
    first = [t for t, _, _ in sub.messages].index
    assert first("homeassistant/sensor/pfx-all_tables/setpoint/config") < first("pfx/all_tables/setpoint")
    # retained: a client that comes later finds the last poll and the configs
    late = Subscriber(broker.port, ["pfx/#", "homeassistant/#"])
    try:
        wait_for(lambda: len(late.payloads("pfx/all_tables/setpoint")) == 1, what="the retained value")
    finally:
        late.close()
    assert late.payloads("pfx/all_tables/setpoint")[0]["time"] == records[-1]["time"]


def test_broker_and_device_outages_lose_no_poll_and_no_order(broker, sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5")
    sub = Subscriber(broker.port, ["pfx/all_tables/#"])
    publish = ["--publish", f"mqtt://127.0.0.1:{broker.port}/pfx"]
    proc = subprocess.Popen(
        mdl_cmd("read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--format", "json", *FAST, *publish),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines: list[str] = []

    def records(n: int) -> None:
        lines.extend(read_lines(proc.stdout, lambda got: len(got) >= n, proc, RUN))
        assert proc.poll() is None, proc.stderr.read()

    try:
        records(3)
        broker.stop()  # polls queue in mdl
        records(5)
        broker.start()
        records(3)
        port = sim.port
        sim.stop()  # the device goes away: failed polls, publishing goes on
        time.sleep(1.0)
        assert proc.poll() is None
        sim = sim_factory(ALL, "--set", "setpoint=22.5", port=port)
        records(3)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=RUN)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    lines += out.splitlines()
    polled = [json.loads(line) for line in lines]
    assert "the broker is unreachable" in err and "the broker is back: sending the queued polls in order" in err
    assert f"cannot connect to 127.0.0.1:{port}" in err
    try:
        wait_for(lambda: (sub.payloads("pfx/all_tables/setpoint") or [{}])[-1].get("time") == polled[-1]["time"])
    finally:
        sub.close()
    got = sub.payloads("pfx/all_tables/setpoint")
    assert times_in_order(got) == [r["time"] for r in polled]
    assert {p["value"] for p in got} == {21.5, 22.5}
    statuses = [p for t, p, _ in sub.messages if t == "pfx/all_tables/$status"]
    assert b"offline" in statuses and statuses[-1] == b"online"


def test_the_queue_is_bounded_and_says_what_it_drops(sim_factory):
    sim = sim_factory(ALL)
    url = f"mqtt://127.0.0.1:{free_port()}/pfx?queue=2"  # nobody listens there
    proc = run_mdl("read", ALL, *sim.connection, "setpoint", "--interval", "0.1", "--count", "5", "--publish", url)
    assert proc.returncode == 0, proc.stderr  # the device answered every poll
    assert "warning: the broker is unreachable" in proc.stderr
    assert "the queue holds 2 polls of each device: dropping the oldest (the poll of all_tables at" in proc.stderr
    assert "not delivered: the broker did not take them before the end" in proc.stderr
    assert proc.stdout.count("setpoint") == 5


@pytest.mark.parametrize(
    ("url", "fragment"),
    [
        ("mqtt://127.0.0.1:1883", "no topic prefix"),
        ("mqtt://127.0.0.1:1883/a/+/b", "is not a topic"),
        ("mqtt://127.0.0.1:99999/p", "not in the range"),
        ("mqtt://127.0.0.1/p?queue=0", "queue=0"),
        ("mqtt://127.0.0.1/p?qos=2", "unknown setting 'qos'"),
        ("http://127.0.0.1/p", "publish to mqtt[s]://"),
        ("mqtt://127.0.0.1/$SYS/x", "leading '$'"),
    ],
)
def test_bad_urls_are_usage_errors(url, fragment, tmp_path):
    proc = run_mdl("read", ALL, "--host", "127.0.0.1", "--interval", "1", "--publish", url)
    assert_clean_error(proc, 2, "--publish", fragment)


def test_publish_needs_interval():
    assert_clean_error(
        run_mdl("read", ALL, "--host", "127.0.0.1", "--publish", "mqtt://h/p"), 2, "--publish needs --interval"
    )


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=40))
def test_fuzz_any_url_parses_or_says_why(text):
    try:
        url = parse_url("mqtt://" + text)
    except ValueError as exc:
        assert str(exc)
    else:
        assert url.prefix and "+" not in url.prefix and 1 <= url.port <= 65535 and url.queue >= 1


def test_a_full_queue_drops_polls_never_a_devices_status():
    """The queue's bound drops the oldest polls, never a device's online/offline (a retained offline would
    outlive the values that follow it); a status not yet begun is superseded by the newer one (review)."""
    import io

    from mdl.device.fleet.mqtt import MqttPublisher, _Batch, parse_url

    pub = MqttPublisher(parse_url("mqtt://127.0.0.1:1/p?queue=2"), io.StringIO())  # never started: a queue only
    pub._status("d", b"offline", "t0")
    pub._status("d", b"online", "t1")  # supersedes the offline nobody was sent
    for i in range(3):
        pub._add(_Batch([("p/d/x", str(i).encode())], f"poll {i}"))
    kept = [(b.status_of, b.messages) for b in pub._pending]
    assert kept == [("d", [("p/d/$status", b"online")]), (None, [("p/d/x", b"1")]), (None, [("p/d/x", b"2")])]


def test_a_nan_is_published_as_null():
    from mdl.device.fleet.mqtt import _mqtt_value
    from mdl.model import Function

    fn = Function("t", "", [0], format="FLOAT32")
    assert [_mqtt_value(fn, v) for v in (math.nan, math.inf, -math.inf, 1.5, None)] == [None, None, None, 1.5, None]
