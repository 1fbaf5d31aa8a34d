"""`mdl read` / `mdl write` against `mdl sim`: output formats, refusals, device errors."""

from __future__ import annotations

import csv
import io
import json

from conftest import DATA, EXAMPLE, assert_clean_error, fn_xml, run_mdl

ALL = DATA / "all_tables.xml"
TSTAT = EXAMPLE / "temco_tstat.xml"


def test_read_formats(sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5", "--set", "mode=1", "--set", "label=Hall")
    conn = ["--host", sim.host, "--port", sim.port]
    proc = run_mdl("read", ALL, *conn, "setpoint", "mode", "label", "voltage", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"setpoint": 21.5, "mode": "Heat", "label": "Hall", "voltage": 0.0}
    proc = run_mdl("read", ALL, *conn, "setpoint", "mode", "--format", "csv")
    assert list(csv.reader(io.StringIO(proc.stdout))) == [["name", "value", "units"], ["setpoint", "21.5", "°C"],
                                                          ["mode", "Heat", ""]]
    proc = run_mdl("read", ALL, *conn, "setpoint")
    assert proc.stdout.split() == ["setpoint", "21.5", "°C"]
    proc = run_mdl("read", ALL, *conn, "--format", "json")
    values = json.loads(proc.stdout)
    assert "alarm_reset" not in values and len(values) == 19


def test_senml_format(sim_factory):
    sim = sim_factory(TSTAT, "--set", "room_temperature=21.5", "--set", "occupied_setpoint=22")
    proc = run_mdl("read", TSTAT, "--host", sim.host, "--port", sim.port, "room_temperature", "occupied_setpoint",
                   "--format", "senml")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"TEMCO Tstat": {"bn": "TEMCO Tstat", "e": [
        {"n": "room_temperature", "v": 21.5, "u": "°C", "asm": "r"},
        {"n": "occupied_setpoint", "v": 22.0, "u": "°C", "min": 10.0, "max": 30.0, "asm": "rw"}]}}


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
    assert_clean_error(run_mdl("write", TSTAT, *conn, "occupied_setpoint=40"), 1, "above the maximum 30")
    assert_clean_error(run_mdl("write", TSTAT, *conn, "room_temperature=20"), 1, "read-only")
    assert_clean_error(run_mdl("write", TSTAT, *conn, "nosuch=1"), 1, "no function 'nosuch'")
    assert_clean_error(run_mdl("write", TSTAT, *conn, "fan_speed=fast"), 1, "expects a number")
    assert_clean_error(run_mdl("write", TSTAT, *conn, "fan_speed"), 2)
    assert_clean_error(run_mdl("write", TSTAT, *conn, "occupied_setpoint=0x" + "F" * 300), 1, "too large")
    # nothing was written by the refused commands
    proc = run_mdl("read", TSTAT, *conn, "occupied_setpoint", "--format", "json")
    assert json.loads(proc.stdout) == {"occupied_setpoint": 23.5}


def test_write_only_function_cannot_be_read(sim_factory):
    sim = sim_factory(ALL)
    assert_clean_error(run_mdl("read", ALL, "--host", sim.host, "--port", sim.port, "alarm_reset"), 1, "write-only")


def test_unreachable_device_exits_3():
    proc = run_mdl("read", TSTAT, "--host", "127.0.0.1", "--port", "1", "--timeout", "1")
    assert_clean_error(proc, 3, "cannot connect to 127.0.0.1:1")
    proc = run_mdl("write", TSTAT, "--host", "127.0.0.1", "--port", "1", "--timeout", "1", "fan_speed=1")
    assert_clean_error(proc, 3, "cannot connect")


def test_modbus_exception_exits_3(sim_factory, write_device):
    other = write_device(fn_xml("x", "5", format="UINT16"))
    sim = sim_factory(other)
    proc = run_mdl("read", TSTAT, "--host", sim.host, "--port", sim.port, "room_temperature")
    assert_clean_error(proc, 3, "Modbus exception 2 (ILLEGAL DATA ADDRESS)")
    proc = run_mdl("write", TSTAT, "--host", sim.host, "--port", sim.port, "fan_speed=1")
    assert_clean_error(proc, 3, "Modbus exception 2")


def test_read_falls_back_on_exception_2(sim_factory, write_device):
    described = write_device(fn_xml("a", "10", format="UINT16") + fn_xml("cmd", "11", format="UINT16", access="write")
                             + fn_xml("b", "12", format="UINT16"), filename="described.xml")
    actual = write_device(fn_xml("a", "10", format="UINT16") + fn_xml("b", "12", format="UINT16"), filename="actual.xml")
    sim = sim_factory(actual, "--set", "a=7", "--set", "b=9")
    proc = run_mdl("read", described, "--host", sim.host, "--port", sim.port, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"a": 7, "b": 9}
