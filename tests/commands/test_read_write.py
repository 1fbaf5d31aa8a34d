"""`mdl read` / `mdl write` against `mdl sim`: output formats, refusals, device errors."""

from __future__ import annotations

import csv
import io
import json
import time

from support.common import DATA, EXAMPLE, device_xml, fn_xml
from support.hostile_server import hostile_server
from support.run import assert_clean_error, cli, run_mdl

ALL = DATA / "all_tables.xml"
TSTAT = EXAMPLE / "temco_tstat.xml"
NOWHERE = ["--host", "127.0.0.1", "--port", "1", "--timeout", "1"]  # refused at once: for what fails before it


def test_read_formats(sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5", "--set", "mode=1", "--set", "label=Hall")
    conn = ["--host", sim.host, "--port", sim.port]
    proc = run_mdl("read", ALL, *conn, "setpoint", "mode", "label", "voltage", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"setpoint": 21.5, "mode": "Heat", "label": "Hall", "voltage": 0.0}
    proc = run_mdl("read", ALL, *conn, "setpoint", "mode", "--format", "csv")
    assert list(csv.reader(io.StringIO(proc.stdout))) == [
        ["name", "value", "units"],
        ["setpoint", "21.5", "°C"],
        ["mode", "Heat", ""],
    ]
    proc = run_mdl("read", ALL, *conn, "setpoint")
    assert proc.stdout.split() == ["setpoint", "21.5", "°C"]
    proc = run_mdl("read", ALL, *conn, "--format", "json")
    values = json.loads(proc.stdout)
    assert "alarm_reset" not in values and len(values) == 19


def test_csv_keeps_a_carriage_return_inside_its_cell(sim_factory):
    """A device's text holding a bare CR is one quoted cell, not the end of a row (csv readers split on it)."""
    sim = sim_factory(ALL, "--set", "label=a\rb", "--set", "setpoint=21.5")
    proc = cli("read", ALL, "--host", sim.host, "--port", sim.port, "label", "setpoint", "--format", "csv")
    assert proc.returncode == 0, proc.stderr
    assert list(csv.reader(io.StringIO(proc.stdout, newline=""))) == [
        ["name", "value", "units"],
        ["label", "a\rb", ""],
        ["setpoint", "21.5", "°C"],
    ]
    assert proc.stdout.count("\n") == 3


def test_senml_format(sim_factory):
    sim = sim_factory(TSTAT, "--set", "room_temperature=21.5", "--set", "occupied_setpoint=22")
    proc = run_mdl(
        "read",
        TSTAT,
        "--host",
        sim.host,
        "--port",
        sim.port,
        "room_temperature",
        "occupied_setpoint",
        "--format",
        "senml",
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {
        "TEMCO Tstat": {
            "bn": "TEMCO Tstat",
            "e": [
                {"n": "room_temperature", "v": 21.5, "u": "°C", "asm": "r"},
                {"n": "occupied_setpoint", "v": 22.0, "u": "°C", "min": 10.0, "max": 30.0, "asm": "rw"},
            ],
        }
    }


def test_not_implemented_is_null(sim_factory, tmp_path):
    raw = tmp_path / "raw.json"
    raw.write_text('{"input": {"10": 65535}}')
    sim = sim_factory(ALL, "--registers", raw)
    proc = run_mdl("read", ALL, "--host", sim.host, "--port", sim.port, "voltage", "--format", "json")
    assert json.loads(proc.stdout) == {"voltage": None}


def test_write_round_trip_and_refusals(sim_factory):
    sim = sim_factory(TSTAT)
    conn = ["--host", sim.host, "--port", sim.port]
    proc = run_mdl("write", TSTAT, *conn, "occupied_setpoint=23.5", "fan_speed=3")
    assert proc.returncode == 0, proc.stderr
    proc = run_mdl("read", TSTAT, *conn, "occupied_setpoint", "fan_speed", "--format", "json")
    assert json.loads(proc.stdout) == {"occupied_setpoint": 23.5, "fan_speed": 3}
    # a refused write sends nothing: with an assignment refused, the good one before it is not written
    assert_clean_error(cli("write", TSTAT, *conn, "fan_speed=1", "occupied_setpoint=40"), 1, "above the maximum 30")
    proc = run_mdl("read", TSTAT, *conn, "fan_speed", "--format", "json")
    assert json.loads(proc.stdout) == {"fan_speed": 3}


def test_a_write_says_what_it_wrote_and_a_misspelled_name_what_was_meant(sim_factory):
    """`mdl write` says each value written on stderr, as csv2xml and gen say `wrote FILE` (not with -q);
    a name the device lacks names the nearest it has (issue 37)."""
    sim = sim_factory(TSTAT)
    conn = ["--host", sim.host, "--port", sim.port]
    proc = run_mdl("write", TSTAT, *conn, "occupied_setpoint=22.5", "fan_speed=2")
    assert proc.returncode == 0 and proc.stdout == ""
    assert proc.stderr.splitlines() == [
        f"wrote occupied_setpoint = 22.5 °C to {sim.host}:{sim.port} unit 1",
        f"wrote fan_speed = 2 to {sim.host}:{sim.port} unit 1",
    ]
    quiet = run_mdl("write", TSTAT, *conn, "fan_speed=1", "-q")
    assert quiet.returncode == 0 and quiet.stderr == ""
    proc = cli("write", TSTAT, *NOWHERE, "ocupied_setpoint=22")
    assert_clean_error(proc, 1, "no function 'ocupied_setpoint': did you mean 'occupied_setpoint'")
    assert_clean_error(cli("read", TSTAT, *NOWHERE, "fanspeed"), 1, "did you mean 'fan_speed'")
    for where in ("127.0.0.1:5020", "192.0.2.10", "meter.local:502"):  # a connection where NAMES go
        assert_clean_error(cli("read", TSTAT, where), 2, f"'{where}' looks like where the device is", f"--host {where}")


def test_refusals_before_anything_is_sent():
    """Each is refused before a connection is tried: NOWHERE would give exit 3."""
    for assignment, message in [
        ("occupied_setpoint=40", "above the maximum 30"),
        ("room_temperature=20", "read-only"),
        ("nosuch=1", "no function 'nosuch'"),
        ("fan_speed=fast", "expects a number"),
        ("occupied_setpoint=0x" + "F" * 300, "too large"),
    ]:
        assert_clean_error(cli("write", TSTAT, *NOWHERE, assignment), 1, message)
    assert_clean_error(cli("write", TSTAT, *NOWHERE, "fan_speed"), 2, "expected NAME=VALUE")
    assert_clean_error(cli("read", ALL, *NOWHERE, "alarm_reset"), 1, "write-only")


def test_unreachable_device_exits_3_naming_the_connection_and_the_unit():
    assert_clean_error(cli("read", TSTAT, *NOWHERE), 3, "cannot connect to 127.0.0.1:1 for unit 1: ")
    assert_clean_error(
        cli("write", TSTAT, *NOWHERE, "--unit", "7", "fan_speed=1"), 3, "cannot connect to 127.0.0.1:1 for unit 7: "
    )
    proc = cli("probe", *NOWHERE, "--units", "3-5,9")
    assert_clean_error(proc, 3, "cannot connect to 127.0.0.1:1 for units 3-5, 9: ")


def test_retries_resend_a_request_that_got_no_reply():
    for retries, tries in (("0", "1 try"), ("2", "3 tries")):
        with hostile_server("silent") as (host, port):
            started = time.monotonic()
            proc = cli(
                "read", ALL, "setpoint", "--host", host, "--port", port, "--timeout", "0.3", "--retries", retries
            )
            elapsed = time.monotonic() - started
        assert_clean_error(
            proc, 3, f"{host}:{port} unit 1: reading 1 holding from 100: ", f"no reply within 0.3 s ({tries})"
        )
        assert elapsed >= 0.3 * int(tries[0]), (retries, elapsed)  # each try waited for its reply
    assert_clean_error(cli("read", ALL, *NOWHERE, "--retries", "-1"), 2, "--retries")


def test_modbus_exception_exits_3(sim_factory, write_device):
    other = write_device(fn_xml("x", "5", format="UINT16"))
    sim = sim_factory(other)
    proc = run_mdl("read", TSTAT, "--host", sim.host, "--port", sim.port, "room_temperature")
    assert_clean_error(proc, 3, "Modbus exception 2 (ILLEGAL DATA ADDRESS)")
    proc = run_mdl("write", TSTAT, "--host", sim.host, "--port", sim.port, "fan_speed=1")
    assert_clean_error(proc, 3, "Modbus exception 2")


def test_read_falls_back_on_exception_2(sim_factory, write_device):
    described = write_device(
        fn_xml("a", "10", format="UINT16")
        + fn_xml("cmd", "11", format="UINT16", access="write")
        + fn_xml("b", "12", format="UINT16"),
        filename="described.xml",
    )
    actual = write_device(
        fn_xml("a", "10", format="UINT16") + fn_xml("b", "12", format="UINT16"), filename="actual.xml"
    )
    sim = sim_factory(actual, "--set", "a=7", "--set", "b=9")
    proc = run_mdl("read", described, "--host", sim.host, "--port", sim.port, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"a": 7, "b": 9}


def test_a_refused_group_is_read_as_smaller_requests_on_every_poll(write_device):
    """A device that refuses any request of more than one register (exception 2): the first read of
    a list of names finds the smaller requests, and every later read goes straight to them, values
    and all (a regression returned nulls from the second poll on)."""
    from mdl.device.connection import Connection
    from mdl.device.link import ModbusExceptionError
    from mdl.device.runtime import Session
    from mdl.formats.loading import load_resolved

    path = write_device("".join(fn_xml(name, str(i), format="INT16") for i, name in enumerate("abc")))
    resolved = load_resolved(path)
    session = Session(resolved, Connection())
    asked = []

    def read_request(req):
        asked.append((req.start, req.count))
        if req.count > 1:
            raise ModbusExceptionError("reading", 2)
        return [7 + req.start]

    session.read_request = read_request
    a_and_b = [resolved.by_name[n].fn for n in "ab"]
    assert session.read(a_and_b) == {"a": 7, "b": 8}
    assert asked == [(0, 2), (0, 1), (1, 1)]
    asked.clear()
    assert session.read(a_and_b) == {"a": 7, "b": 8}
    assert asked == [(0, 1), (1, 1)]


def test_a_float32_prints_as_the_shortest_decimal_that_is_the_same_float32(sim_factory):
    """230.1 stored as a float32 is 230.10000610351562 as a double; the table, csv and senml show 230.1, as
    mbpoll does."""
    sim = sim_factory(ALL, "--set", "power=230.1")
    conn = ["--host", sim.host, "--port", sim.port]
    assert cli("read", ALL, *conn, "power").stdout.split() == ["power", "230.1", "W"]
    # json carries the double the drivers return (docs/user-guide.md): programs compare it exactly
    assert json.loads(cli("read", ALL, *conn, "power", "--format", "json").stdout) == {"power": 230.10000610351562}
    assert list(csv.reader(io.StringIO(cli("read", ALL, *conn, "power", "--format", "csv").stdout)))[1] == [
        "power",
        "230.1",
        "W",
    ]
    senml = json.loads(cli("read", ALL, *conn, "power", "--format", "senml").stdout)
    assert [e["v"] for block in senml.values() for e in block["e"]] == [230.1]


def test_precision_rounds_a_float32_exactly_once(tmp_path, sim_factory):
    """The float32 nearest 0.045 is 0.04500000178...: with precision 2 it shows 0.05, rounded from the exact
    value, not 0.04 from the shortest text 0.045 (a review found the double rounding)."""
    path = tmp_path / "p.xml"
    path.write_text(device_xml(fn_xml("level", 0, format="FLOAT32", precision=2)))
    sim = sim_factory(path, "--set", "level=0.045")
    proc = cli("read", path, "--host", sim.host, "--port", sim.port)
    assert proc.stdout.split() == ["level", "0.05"], proc.stdout


def test_mdl_examples_copies_what_every_help_names(tmp_path):
    """`mdl examples` gives an installed mdl the files its --help examples name (issue 37), whole or not
    at all, and never over a folder that exists."""
    proc = run_mdl("examples", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "examples" / "temco_tstat" / "temco_tstat.xml").read_bytes() == TSTAT.read_bytes()
    assert not list((tmp_path / "examples").rglob("__pycache__")) and "wrote examples (" in proc.stderr
    proc = run_mdl("validate", "examples/temco_tstat/temco_tstat.xml", cwd=tmp_path)  # the overview's line, as written
    assert proc.returncode == 0, proc.stderr
    (tmp_path / "mine").mkdir()
    assert_clean_error(run_mdl("examples", tmp_path / "mine"), 1, "exists already: nothing is copied over it")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["examples", "mine"]  # no staging folder left behind
