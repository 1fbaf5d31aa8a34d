"""`mdl read --interval S --publish prometheus://[HOST]:PORT` (SPEC section 11, docs/fleet.md): the last poll of
every device as Prometheus metrics, read back with prometheus-client's own parser (and `promtool check
metrics` where it is installed): one gauge per numeric function, labelled by device and unit."""

from __future__ import annotations

import json
import re
import shutil
import signal
import socket
import subprocess
import urllib.request

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device.fleet.prometheus import parse_url
from support.common import DATA, fn_xml
from support.devices import read_lines
from support.run import assert_clean_error, mdl_cmd, run_mdl

parser = pytest.importorskip("prometheus_client.parser")

ALL = DATA / "all_tables.xml"
RUN = 60
SERVING = re.compile(r"serving Prometheus metrics on (http://\S+/metrics)")


class Exporter:
    """`mdl read ... --publish prometheus://127.0.0.1:0` as its own process, and its metrics page."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            mdl_cmd("read", *args, "--format", "json", "--publish", "prometheus://127.0.0.1:0"),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        said = read_lines(self.proc.stderr, lambda got: any(SERVING.search(line) for line in got), self.proc, RUN)
        found = [SERVING.search(line) for line in said]
        assert any(found), said
        self.url = next(m.group(1) for m in found if m)
        self.said = said

    def records(self, n: int) -> list[dict]:
        return [json.loads(line) for line in read_lines(self.proc.stdout, lambda got: len(got) >= n, self.proc, RUN)]

    def page(self) -> str:
        with urllib.request.urlopen(self.url, timeout=RUN) as reply:
            return reply.read().decode()

    def stop(self) -> tuple[int, str]:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            _, err = self.proc.communicate(timeout=RUN)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.communicate()
            raise
        return self.proc.returncode, err


def samples(page: str) -> dict[tuple[str, tuple[tuple[str, str], ...]], float]:
    out = {}
    for family in parser.text_string_to_metric_families(page):
        assert family.type == "gauge", family
        for s in family.samples:
            out[(s.name, tuple(sorted(s.labels.items())))] = s.value
    return out


def test_gauges_carry_the_last_poll_of_every_device(sim_factory):
    sim = sim_factory([ALL, ALL], "--unit", "1", "--unit", "2", "--set", "setpoint=21.5", "--set", "pump=1")
    assert run_mdl("write", ALL, *sim.connection, "--unit", "2", "setpoint=19.5").returncode == 0
    targets = [f"{ALL}@tcp://{sim.host}:{sim.port}#{unit}" for unit in (1, 2)]
    exporter = Exporter(*targets, "setpoint", "pump", "mode", "label", "--interval", "0.2")
    try:
        records = exporter.records(4)
        page = exporter.page()
    finally:
        status, err = exporter.stop()
    assert status == 0, err
    assert "text is not a metric: label left out" in "".join(exporter.said)
    got = samples(page)
    for unit, setpoint in ((1, 21.5), (2, 19.5)):
        labels = (("device", f"all_tables_u{unit}"), ("unit", str(unit)))
        assert got[("mdl_setpoint", labels)] == setpoint
        assert got[("mdl_pump", labels)] == 1.0
        assert got[("mdl_mode", labels)] == 0.0  # an enumeration: its number
        assert got[("mdl_poll_up", labels)] == 1.0
        assert ("mdl_label", labels) not in got
    assert {r["values"]["setpoint"] for r in records} == {21.5, 19.5}


def test_a_failed_device_has_no_values_and_poll_up_0(sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5")
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        dead_port = sock.getsockname()[1]  # closed again: nobody listens there
    live, dead = f"{ALL}@tcp://{sim.host}:{sim.port}#1", f"{ALL}@tcp://127.0.0.1:{dead_port}?timeout=0.2#5"
    exporter = Exporter(live, dead, "setpoint", "--interval", "0.2")
    try:
        exporter.records(3)
        got = samples(exporter.page())
    finally:
        status, err = exporter.stop()
    assert status == 3, err  # the dead device's last poll failed
    assert got[("mdl_poll_up", (("device", "all_tables_u5"), ("unit", "5")))] == 0.0
    assert ("mdl_setpoint", (("device", "all_tables_u5"), ("unit", "5"))) not in got
    assert got[("mdl_setpoint", (("device", "all_tables_u1"), ("unit", "1")))] == 21.5


def test_promtool_accepts_the_page(sim_factory, tmp_path):
    promtool = shutil.which("promtool")
    if promtool is None:  # optional: the client's own parser above is the check CI relies on
        pytest.skip("promtool is not installed (Debian package prometheus): the page is checked with the parser only")
    sim = sim_factory(ALL)
    exporter = Exporter(ALL, *sim.connection, "--interval", "0.2")
    try:
        exporter.records(1)
        page = exporter.page()
    finally:
        exporter.stop()
    check = subprocess.run([promtool, "check", "metrics"], input=page, capture_output=True, text=True, timeout=RUN)
    assert check.returncode == 0, check.stdout + check.stderr


def test_a_port_in_use_is_a_clean_error(sim_factory):
    sim = sim_factory(ALL)
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(1)
        port = sock.getsockname()[1]
        publish = ["--publish", f"prometheus://127.0.0.1:{port}"]
        proc = run_mdl("read", ALL, *sim.connection, "--interval", "1", "--count", "1", *publish)
    assert_clean_error(proc, 1, f"cannot serve Prometheus metrics on 127.0.0.1:{port}")


@pytest.mark.parametrize(
    ("url", "fragment"),
    [
        ("prometheus://127.0.0.1", "no port"),
        ("prometheus://:http", "is not a number"),
        ("prometheus://:70000", "not in the range"),
        ("prometheus://:9105/other", "write prometheus://[HOST]:PORT"),
    ],
)
def test_bad_urls_are_usage_errors(url, fragment):
    proc = run_mdl("read", ALL, "--host", "127.0.0.1", "--interval", "1", "--publish", url)
    assert_clean_error(proc, 2, "--publish", fragment)


def test_url_forms():
    assert parse_url("prometheus://:9105") == parse_url("prometheus://0.0.0.0:9105/metrics")
    assert (parse_url("prometheus://[::1]:9105").host, parse_url("prometheus://[::1]:9105").port) == ("::1", 9105)


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=40))
def test_fuzz_any_url_parses_or_says_why(text):
    try:
        url = parse_url("prometheus://" + text)
    except ValueError as exc:
        assert str(exc)
    else:
        assert 0 <= url.port <= 65535 and url.host


def test_function_names_that_meet_the_built_in_metrics_stay_apart(sim_factory, write_device):
    """A function `poll_up` is mdl_poll_up_value, as is a function `poll_up_value`: the second is numbered,
    with a note, so the page never holds one series twice (Prometheus refuses such a scrape whole)."""
    path = write_device(fn_xml("poll_up", 0, format="UINT16") + fn_xml("poll_up_value", 1, format="UINT16"))
    sim = sim_factory(path, "--set", "poll_up=5", "--set", "poll_up_value=7")
    exporter = Exporter(f"{path}@tcp://{sim.host}:{sim.port}", "--interval", "0.2")
    try:
        exporter.records(1)
        page = exporter.page()
    finally:
        exporter.stop()
    got = {name: value for (name, _), value in samples(page).items()}
    assert got["mdl_poll_up_value"] == 5.0 and got["mdl_poll_up_value_2"] == 7.0 and got["mdl_poll_up"] == 1.0
    assert "metric names taken already: poll_up_value as mdl_poll_up_value_2" in "".join(exporter.said)
