"""`mdl read --publish mqtt[s]://` against hostile setups (issue 34, finding 8), with a real mosquitto
(tests/engines/test_publish_mqtt.py's Broker): a function named `status`, two sites under two prefixes, a flood of
Home Assistant births, a broker that refuses the password (at start and later), a password in a URL with a
mistake, and TLS with a private CA (openssl makes a throwaway one)."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
from pathlib import Path

import pytest

from support.common import DATA, skip_or_fail
from support.devices import read_lines
from support.mqtt import RUN, Broker, Subscriber, mqtt, times_in_order, wait_for
from support.run import assert_clean_error, mdl_cmd, run_mdl

ALL = DATA / "all_tables.xml"
engines = pytest.mark.engines  # a broker of its own
SECRET = "s3cr3t-Pa55"


def configs(sub: Subscriber) -> dict[str, dict]:
    return {t: json.loads(p) for t, p, _ in sub.messages if t.startswith("homeassistant/") and p}


@engines
def test_a_function_named_status_keeps_its_topic_apart_from_availability(tmp_path, sim_factory):
    """The inverter profile's role `status` is a function's identifier: its values and the device's
    online/offline must not share a topic (Home Assistant would show the device unavailable)."""
    xml = tmp_path / "inverter.xml"
    xml.write_text(ALL.read_text().replace("<name>pump</name>", "<name>status</name>", 1))
    broker = Broker(tmp_path)
    try:
        sim = sim_factory(xml)
        sub = Subscriber(broker.port, ["pfx/#", "homeassistant/#"])
        try:
            proc = run_mdl(
                "read", xml, *sim.connection, "status", "setpoint", "--interval", "0.2", "--count", "3",
                "--format", "json", "--publish", f"mqtt://127.0.0.1:{broker.port}/pfx", timeout=RUN,
            )  # fmt: skip
            assert proc.returncode == 0, proc.stderr
            wait_for(lambda: len(sub.payloads("pfx/all_tables/status")) >= 3, what="3 polls of status")
        finally:
            sub.close()
    finally:
        broker.stop()
    values = [p for t, p, _ in sub.messages if t == "pfx/all_tables/status"]
    assert all(json.loads(p).keys() == {"value", "time"} for p in values), values  # never `online`
    assert [p for t, p, _ in sub.messages if t == "pfx/all_tables/$status"] == [b"online"]
    config = configs(sub)["homeassistant/binary_sensor/pfx-all_tables/status/config"]
    assert config["state_topic"] == "pfx/all_tables/status"
    availability = {a["topic"] for a in config["availability"]}
    assert availability == {"pfx/status", "pfx/all_tables/$status"} and config["state_topic"] not in availability


@engines
def test_two_sites_under_two_prefixes_never_share_an_entity(tmp_path, sim_factory):
    """One description polled by two processes under `site1` and `site2`: their discovery topics and
    unique_ids differ (one site's meter no longer replaces the other's), and a run again gives the same."""
    broker = Broker(tmp_path)
    sim = sim_factory(ALL)
    sub = Subscriber(broker.port, ["homeassistant/#"])
    try:
        for prefix in ("site1", "site2", "site1"):
            proc = run_mdl(
                "read", ALL, *sim.connection, "setpoint", "pump", "--interval", "0.2", "--count", "1",
                "--publish", f"mqtt://127.0.0.1:{broker.port}/{prefix}", timeout=RUN,
            )  # fmt: skip
            assert proc.returncode == 0, proc.stderr
        wait_for(lambda: len(sub.messages) >= 6, what="3 runs' configs")
    finally:
        sub.close()
        broker.stop()
    by_site: dict[str, set[tuple[str, str]]] = {"site1": set(), "site2": set()}
    for topic, payload, _ in sub.messages:
        config = json.loads(payload)
        site = config["state_topic"].split("/")[0]
        by_site[site].add((topic, config["unique_id"]))
    assert len(by_site["site1"]) == len(by_site["site2"]) == 2  # site1 twice: the same topics and ids
    topics1, ids1 = zip(*by_site["site1"], strict=True)
    topics2, ids2 = zip(*by_site["site2"], strict=True)
    assert not set(topics1) & set(topics2) and not set(ids1) & set(ids2)


def test_node_ids_tell_every_prefix_apart():
    from mdl.device.fleet.mqtt import node_id

    nodes = [node_id(p, d) for p, d in [("a/b", "c"), ("a_b", "c"), ("a", "b_c"), ("a-b", "c"), ("a/b", "c_d")]]
    assert len(set(nodes)) == len(nodes)
    assert node_id("site/hall", "meter") == node_id("site/hall", "meter")  # deterministic
    assert all(c.isalnum() or c in "_-" for n in nodes for c in n)  # Home Assistant's node_id characters


@engines
def test_a_flood_of_home_assistant_births_costs_no_poll(tmp_path, sim_factory):
    """20,000 `online` on homeassistant/status: the configs go again at most once at a time (not once per
    birth, outside the queue's bound), and every poll is still delivered, in order."""
    broker = Broker(tmp_path)
    sim = sim_factory(ALL)
    sub = Subscriber(broker.port, ["pfx/#", "homeassistant/sensor/#", "homeassistant/binary_sensor/#"])
    flood = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="flood")
    try:
        publish = ["--publish", f"mqtt://127.0.0.1:{broker.port}/pfx"]
        proc = subprocess.Popen(
            mdl_cmd("read", ALL, *sim.connection, "setpoint", "pump", "--interval", "0.2", "--count", "10",
                    "--format", "json", *publish),
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        try:
            lines = read_lines(proc.stdout, lambda got: len(got) >= 1, proc, RUN)
            flood.connect("127.0.0.1", broker.port)
            flood.loop_start()
            for _ in range(20_000):
                flood.publish("homeassistant/status", b"online", qos=0)
            out, err = proc.communicate(timeout=RUN)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
        lines += out.splitlines()
        polled = [json.loads(line) for line in lines]
        assert proc.returncode == 0, err
        assert "not delivered" not in err, err
        last = polled[-1]["time"]
        wait_for(lambda: (sub.payloads("pfx/all_tables/setpoint") or [{}])[-1].get("time") == last, what="polls")
    finally:
        flood.loop_stop()
        flood.disconnect()
        sub.close()
        broker.stop()
    assert times_in_order(sub.payloads("pfx/all_tables/setpoint")) == [r["time"] for r in polled]
    resent = sum(t.startswith("homeassistant/") for t, _, _ in sub.messages)
    assert 2 <= resent <= 2 * 200, resent  # a resend per birth would be 40,000


def password_broker(folder: Path, user: str, password: str) -> Broker:
    exe = shutil.which("mosquitto_passwd") or "/usr/bin/mosquitto_passwd"
    if not Path(exe).exists():
        skip_or_fail("mosquitto_passwd is not installed (apt-get install mosquitto)")
    passwords = folder / "passwords"
    subprocess.run([exe, "-b", "-c", str(passwords), user, password], check=True, capture_output=True)
    passwords.chmod(0o600)
    return Broker(folder, f"allow_anonymous false\npassword_file {passwords}\n")


@engines
def test_a_broker_that_refuses_the_password_ends_with_exit_3(tmp_path, sim_factory):
    """Fatal at start: nothing is polled, exit 3, a message naming the refusal and never the password."""
    broker = password_broker(tmp_path, "mdl", "right")
    sim = sim_factory(ALL)
    try:
        url = f"mqtt://mdl:{SECRET}@127.0.0.1:{broker.port}/pfx"
        proc = run_mdl("read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--count", "3",
                       "--publish", url, timeout=RUN)  # fmt: skip
        assert_clean_error(proc, 3, "the broker refused the connection as 'mdl': not authorized")
        assert SECRET not in proc.stderr and proc.stdout == ""
        good = f"mqtt://mdl:right@127.0.0.1:{broker.port}/pfx"
        sub = Subscriber(broker.port, ["pfx/all_tables/setpoint"], auth=("mdl", "right"))
        try:
            proc = run_mdl("read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--count", "2",
                           "--publish", good, timeout=RUN)  # fmt: skip
            assert proc.returncode == 0, proc.stderr
            wait_for(lambda: len(sub.payloads("pfx/all_tables/setpoint")) >= 2, what="2 polls")
        finally:
            sub.close()
    finally:
        broker.stop()


@engines
def test_a_broker_that_refuses_later_ends_the_run_with_exit_3(tmp_path, sim_factory):
    """The broker comes back with another password file: polling ends at once, exit 3 (retrying cannot
    change the broker's answer), what was not delivered said."""
    broker = password_broker(tmp_path, "mdl", SECRET)
    sim = sim_factory(ALL)
    url = f"mqtt://mdl:{SECRET}@127.0.0.1:{broker.port}/pfx"
    proc = subprocess.Popen(
        mdl_cmd("read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--format", "json", "--publish", url),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        read_lines(proc.stdout, lambda got: len(got) >= 2, proc, RUN)
        broker.stop()
        subprocess.run(["mosquitto_passwd", "-b", str(tmp_path / "passwords"), "mdl", "changed"], check=True)
        broker.start()
        out, err = proc.communicate(timeout=RUN)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            proc.communicate(timeout=RUN)
        broker.stop()
    assert proc.returncode == 3, err
    assert "the broker refused the connection as 'mdl': not authorized" in err and "Traceback" not in err
    assert SECRET not in err


@pytest.mark.parametrize(
    ("url", "fragment"),
    [
        (f"mqtt://mdl:{SECRET}@127.0.0.1:99999/p", "not in the range"),
        (f"mqtt://mdl:{SECRET}@127.0.0.1/p?qos=1", "unknown setting 'qos'"),
        (f"mqtt://mdl:{SECRET}@127.0.0.1", "no topic prefix"),
        (f"mqtt://mdl:{SECRET[:4]}/{SECRET[4:]}@127.0.0.1/p", "a password's '/'"),
        (f"mqtt://mdl:{SECRET[:4]}?{SECRET[4:]}@127.0.0.1/p", "a password's '/'"),
        (f"http://mdl:{SECRET}@127.0.0.1/p", "publish to mqtt[s]://"),
    ],
)
def test_no_message_prints_the_password(url, fragment):
    proc = run_mdl("read", ALL, "--host", "127.0.0.1", "--interval", "1", "--publish", url)
    assert_clean_error(proc, 2, "--publish", fragment, "mdl:***@")
    assert SECRET[:4] not in proc.stderr and SECRET[4:] not in proc.stderr, proc.stderr


@pytest.fixture(scope="module")
def pki(tmp_path_factory) -> Path:
    """A throwaway CA and a certificate it signed for 127.0.0.1 (openssl CLI)."""
    if shutil.which("openssl") is None:
        skip_or_fail("openssl is not installed: the TLS tests make their certificates with it")
    d = tmp_path_factory.mktemp("pki")
    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]

    def openssl(*args: str) -> None:
        subprocess.run(["openssl", *args], check=True, capture_output=True, cwd=d)

    ca_ext = ["-addext", "basicConstraints=critical,CA:TRUE", "-addext", "keyUsage=critical,keyCertSign,cRLSign"]
    openssl("req", "-x509", *ec, "-keyout", "ca.key", "-out", "ca.pem", "-subj", "/CN=mdl test CA", *ca_ext)
    openssl("req", *ec, "-keyout", "server.key", "-out", "server.csr", "-subj", "/CN=127.0.0.1")
    (d / "ext.cnf").write_text(
        "subjectAltName=IP:127.0.0.1\nbasicConstraints=CA:FALSE\nkeyUsage=digitalSignature\n"
        "extendedKeyUsage=serverAuth\nauthorityKeyIdentifier=keyid\nsubjectKeyIdentifier=hash\n"
    )
    openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
            "-out", "server.pem", "-days", "2", "-extfile", "ext.cnf")  # fmt: skip
    (d / "server.key").chmod(0o600)
    return d


@pytest.fixture
def tls_broker(tmp_path, pki):
    b = Broker(tmp_path, f"cafile {pki / 'ca.pem'}\ncertfile {pki / 'server.pem'}\nkeyfile {pki / 'server.key'}\n")
    try:
        yield b
    finally:
        b.stop()


@engines
def test_mqtts_with_a_private_ca_delivers_every_poll(tls_broker, pki, sim_factory):
    sim = sim_factory(ALL)
    sub = Subscriber(tls_broker.port, ["pfx/all_tables/setpoint"], ca=pki / "ca.pem")
    try:
        url = f"mqtts://127.0.0.1:{tls_broker.port}/pfx"
        proc = run_mdl("read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--count", "3",
                       "--format", "json", "--publish", url, "--mqtt-ca", pki / "ca.pem", timeout=RUN)  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        polled = [json.loads(line)["time"] for line in proc.stdout.splitlines()]
        wait_for(lambda: len(sub.payloads("pfx/all_tables/setpoint")) >= 3, what="3 polls over TLS")
    finally:
        sub.close()
    assert times_in_order(sub.payloads("pfx/all_tables/setpoint")) == polled


@engines
def test_mqtts_refuses_a_certificate_the_system_does_not_trust(tls_broker, sim_factory):
    sim = sim_factory(ALL)
    url = f"mqtts://127.0.0.1:{tls_broker.port}/pfx"
    proc = run_mdl("read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--count", "2",
                   "--publish", url, timeout=RUN)  # fmt: skip
    assert_clean_error(proc, 3, "the broker's TLS certificate is not trusted", "--mqtt-ca")
    assert proc.stdout == ""


def test_a_bad_ca_file_is_a_clear_error(tmp_path):
    bad = tmp_path / "ca.pem"
    bad.write_text("-----BEGIN CERTIFICATE-----\nnot base64 at all\n-----END CERTIFICATE-----\n")
    base = ["read", ALL, "--host", "127.0.0.1", "--interval", "1", "--publish", "mqtts://127.0.0.1/pfx"]
    assert_clean_error(run_mdl(*base, "--mqtt-ca", bad), 1, str(bad), "not a CA certificate file (PEM)")
    assert_clean_error(run_mdl(*base, "--mqtt-ca", tmp_path / "missing.pem"), 2, "--mqtt-ca", "does not exist")
    plain = ["read", ALL, "--host", "127.0.0.1", "--interval", "1", "--publish", "mqtt://127.0.0.1/pfx"]
    assert_clean_error(run_mdl(*plain, "--mqtt-ca", bad), 2, "--mqtt-ca goes with --publish mqtts://")


def test_mqtts_defaults_to_port_8883():
    from mdl.device.fleet.mqtt import parse_url

    url = parse_url("mqtts://u:hunter2@broker.lan/site")
    assert (url.port, url.tls, str(url), url.password) == (8883, True, "mqtts://broker.lan:8883/site", "hunter2")
    assert "hunter2" not in repr(url)  # the password is never shown
