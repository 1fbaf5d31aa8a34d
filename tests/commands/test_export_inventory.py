"""`mdl export --inventory FLEET --to ENGINE -o DIR [--shards K]` (SPEC 15, issue 39): one configuration for a
fleet, each device's part what the single export gives for it (its connection, unit and interval from the
inventory), named after its id with its tags; Telegraf in K agents that never split a line."""

from __future__ import annotations

import json
import shutil

import pytest
import tomllib

from support.common import ROOT
from support.run import assert_clean_error, cli

SITE = ROOT / "examples" / "fleet" / "site.yml"


@pytest.fixture
def site(tmp_path):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    return tmp_path / "examples" / "fleet" / "site.yml"


def single(tmp_path, description, to, *args):
    out = tmp_path / f"single.{to}"
    proc = cli("export", description, "--to", to, "-o", out, *args)
    assert proc.returncode == 0, proc.stderr
    return out.read_text()


def test_telegraf_publish_gives_each_agent_one_mqtt_output(site, tmp_path):
    """`--publish mqtt://...` with --to telegraf: each agent sends its metrics to the broker (Telegraf's
    outputs.mqtt), one JSON message a metric at PREFIX/DEVICE (the device tag) for a fleet's agent and at
    PREFIX/STEM for one device, QoS 1, with the URL's user; a URL mdl would refuse is refused here too."""
    url = "mqtt://collector:s3cret@broker.lan:1884/site1"
    proc = cli("export", "--inventory", site, "--to", "telegraf", "--shards", "2", "--publish", url, "-o",
               tmp_path / "tg")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    for path in sorted((tmp_path / "tg").glob("shard-*/telegraf.conf")):
        (output,) = tomllib.loads(path.read_text())["outputs"]["mqtt"]
        assert output == {
            "servers": ["mqtt://broker.lan:1884"],
            "topic": 'site1/{{ .Tag "device" }}',
            "qos": 1,
            "keep_alive": 30,
            "data_format": "json",
            "username": "collector",
            "password": "s3cret",
        }
    alone = tomllib.loads(
        single(
            tmp_path,
            site.parent.parent / "temco_tstat" / "temco_tstat.xml",
            "telegraf",
            "--host",
            "10.0.0.5",
            "--publish",
            "mqtts://broker.lan/x",
        )  # fmt: skip
    )
    assert alone["outputs"]["mqtt"] == [
        {
            "servers": ["mqtts://broker.lan:8883"],
            "topic": "x/temco_tstat",
            "qos": 1,
            "keep_alive": 30,
            "data_format": "json",
        }  # fmt: skip
    ]
    bad = cli("export", "--inventory", site, "--to", "telegraf", "--publish", "mqtt://broker.lan/a/+", "-o",
              tmp_path / "bad")  # fmt: skip
    assert_clean_error(bad, 1)
    assert "--publish 'mqtt://broker.lan/a/+'" in bad.stderr and not (tmp_path / "bad").exists()
    other = cli("export", "--inventory", site, "--to", "volttron", "--publish", url, "-o", tmp_path / "v")
    assert_clean_error(other, 2)
    assert "it needs --to nodered or telegraf" in other.stderr and "s3cret" not in other.stderr


def test_telegraf_shards_keep_lines_whole_and_each_device_is_its_single_export(site, tmp_path):
    proc = cli("export", "--inventory", site, "--to", "telegraf", "--shards", "2", "-o", tmp_path / "tg")
    assert proc.returncode == 0, proc.stderr
    shards = {
        p.parent.name: tomllib.loads(p.read_text()) for p in sorted((tmp_path / "tg").glob("shard-*/telegraf.conf"))
    }
    assert sorted(shards) == ["shard-1", "shard-2"]
    where = {i["name"]: (shard, i) for shard, conf in shards.items() for i in conf["inputs"]["modbus"]}
    assert sorted(where) == ["hall-meter-1", "hall-meter-2", "office-tstat-3", "office-tstat-4", "roof-em100"]
    assert where["office-tstat-3"][0] == where["office-tstat-4"][0]  # one serial line: one agent
    assert where["hall-meter-1"][0] == where["hall-meter-2"][0]  # one gateway: one agent
    _, tstat = where["office-tstat-3"]
    assert tstat["tags"] == {"device": "office-tstat-3", "site": "plant1", "room": "office"}
    # the device's input is the single export's, for its connection, unit and interval
    alone = tomllib.loads(
        single(
            tmp_path, site.parent.parent / "temco_tstat" / "temco_tstat.xml", "telegraf",
            "--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E", "--unit", "3", "--interval", "10",
            "--timeout", "1", "--retries", "1",
        )
    )["inputs"]["modbus"][0]  # fmt: skip
    assert {k: v for k, v in tstat.items() if k not in ("name", "tags")} == {
        k: v for k, v in alone.items() if k != "name"
    }
    for conf in shards.values():  # each kind's processors once per agent, never once per device
        kinds = [p["namepass"][0] for p in conf.get("processors", {}).get("starlark", [])]
        assert len(kinds) == len(set(kinds))


def test_thingsboard_is_one_connector_with_each_device_named_by_its_id(site, tmp_path):
    proc = cli("export", "--inventory", site, "--to", "thingsboard", "-o", tmp_path / "tb")
    assert proc.returncode == 0, proc.stderr
    slaves = json.loads((tmp_path / "tb" / "modbus.json").read_text())["master"]["slaves"]
    assert [s["deviceName"] for s in slaves] == [
        "hall-meter-1", "hall-meter-2", "office-tstat-3", "office-tstat-4", "roof-em100"
    ]  # fmt: skip
    assert "ThingsBoard's connector has no place for tags" in proc.stderr
    alone = json.loads(
        single(tmp_path, site.parent.parent / "profiles" / "meter_a.xml", "thingsboard", "--host", "192.0.2.15",
               "--port", "502", "--unit", "2", "--interval", "5", "--timeout", "1", "--retries", "1")
    )["master"]["slaves"][0]  # fmt: skip
    assert {**slaves[1], "deviceName": "x"} == {**alone, "deviceName": "x"}


def test_wot_gives_each_device_its_folder_and_a_device_an_engine_cannot_reach_is_named(site, tmp_path):
    proc = cli("export", "--inventory", site, "--to", "wot", "-o", tmp_path / "wot")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "wot" / "roof-em100" / "roof-em100.td.jsonld").is_file()
    assert sorted(p.name for p in (tmp_path / "wot").iterdir()) == [
        "hall-meter-1", "hall-meter-2", "office-tstat-3", "office-tstat-4", "roof-em100"
    ]  # fmt: skip
    # a device the engine cannot reach is an error naming it, and nothing is written
    proc = cli("export", "--inventory", site, "--to", "volttron", "-o", tmp_path / "vt")
    assert_clean_error(proc, 1, "device roof-em100 (inventory line", "not RTU framing over TCP")
    assert not (tmp_path / "vt").exists()


def test_what_a_fleet_export_cannot_do_is_said(site, tmp_path):
    out = tmp_path / "out"
    proc = cli("export", "--inventory", site, "--to", "esphome", "-o", out)
    assert_clean_error(proc, 1, "is not written for a fleet")
    assert_clean_error(cli("export", "--inventory", site, "--to", "thingsboard", "--shards", "2", "-o", out), 1,
                       "--shards splits Telegraf's agents")  # fmt: skip
    assert_clean_error(cli("export", str(SITE.parent.parent / "temco_tstat" / "temco_tstat.xml"), "--inventory", site,
                           "--to", "telegraf", "-o", out), 2, "give FILE (one description) or --inventory")  # fmt: skip
    assert_clean_error(cli("export", "--inventory", site, "--to", "telegraf"), 2, "give -o DIR")
    assert not out.exists()
    proc = cli("export", "--inventory", site, "--to", "telegraf", "--shards", "9", "-o", out)
    assert proc.returncode == 0 and "--shards 9: the fleet has 3 lines, and a line is not split" in proc.stderr


def test_node_red_is_one_flow_with_a_tab_per_line(site, tmp_path):
    """A tab per line; the two thermostats on one serial line share its one modbus-client (a port opens once),
    the meters behind one gateway have a connection each; with --publish, one broker for the fleet."""
    proc = cli("export", "--inventory", site, "--to", "nodered", "--publish", "mqtt://127.0.0.1/site", "-o",
               tmp_path / "nr")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    nodes = json.loads((tmp_path / "nr" / "flows.json").read_text())
    tabs = {n["id"]: n["label"] for n in nodes if n["type"] == "tab"}
    clients = {n["id"]: n for n in nodes if n["type"] == "modbus-client"}
    assert len(tabs) == 3 and len([n for n in nodes if n["type"] == "mqtt-broker"]) == 1
    serial = [c for c in clients.values() if c["clienttype"] == "simpleser"]
    assert len(serial) == 1 and len(clients) == 4  # ttyUSB0 once; hall-meter-1, -2 and roof-em100 their own
    reads = [n for n in nodes if n["type"] == "modbus-read"]
    assert {n["server"] for n in reads} == set(clients) and {n["z"] for n in nodes if "z" in n} == set(tabs)
    decoders = sorted(n["name"] for n in nodes if n["type"] == "function" and n["name"].startswith("decode "))
    assert decoders == [f"decode {i}" for i in ("hall-meter-1", "hall-meter-2", "office-tstat-3", "office-tstat-4",
                                                "roof-em100")]  # fmt: skip
