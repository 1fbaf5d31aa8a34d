"""`mdl read FILE@CONNECTION[#UNIT]...` (SPEC sections 9 and 11, docs/fleet.md): several devices polled from
one process, concurrently, each on its own schedule; one that does not answer delays no other; records
name their device; the target syntax and its errors."""

from __future__ import annotations

import csv
import io
import json
import math
import signal
import socket
import subprocess
from collections import defaultdict
from datetime import datetime, timezone

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device import output
from mdl.device.connection import looks_like_target
from mdl.device.fleet.run import device_ids, parse_target
from mdl.model import Function
from support.common import DATA
from support.devices import read_lines
from support.run import assert_clean_error, mdl_cmd, run_mdl

ALL = DATA / "all_tables.xml"
RUN = 60


def parse_time(text: str) -> datetime:
    return datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ")


def target(sim, unit: int, settings_: str = "") -> str:
    return f"{ALL}@tcp://{sim.host}:{sim.port}{settings_}#{unit}"


def test_records_name_their_device_and_equal_single_reads(sim_factory):
    sim = sim_factory([ALL, ALL], "--unit", "3", "--unit", "7", "--set", "setpoint=21.5")
    assert run_mdl("write", ALL, *sim.connection, "--unit", "7", "setpoint=19.5", "mode=1").returncode == 0
    proc = run_mdl(
        "read", target(sim, 3), target(sim, 7), "setpoint", "mode", "--interval", "0.2", "--count", "2",
        "--format", "json", timeout=RUN,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(records) == 4
    assert {r["device"] for r in records} == {"all_tables_u3", "all_tables_u7"}
    assert all(list(r) == ["time", "device", "values"] for r in records)
    assert "named all_tables_u3: several targets are all_tables" in proc.stderr
    for unit in (3, 7):
        single = run_mdl("read", ALL, *sim.connection, "--unit", unit, "setpoint", "mode", "--format", "json")
        mine = [r["values"] for r in records if r["device"] == f"all_tables_u{unit}"]
        assert mine == [json.loads(single.stdout)] * 2
    assert {r["values"]["setpoint"] for r in records} == {21.5, 19.5}


@pytest.mark.parametrize("fmt", ["json", "csv", "table"])
def test_one_device_prints_the_same_however_its_connection_is_written(sim_factory, fmt):
    """One-shot and poll output have one shape each (docs/fleet.md): FILE@CONNECTION#UNIT prints what FILE
    --host H --port P --unit U prints (issue 37: the target form printed a polled, timed record)."""
    sim = sim_factory(ALL, "--unit", "3", "--set", "setpoint=21.5")
    written = ([target(sim, 3)], [str(ALL), *sim.connection, "--unit", "3"])
    once = [run_mdl("read", *spelled, "setpoint", "mode", "--format", fmt) for spelled in written]
    assert once[0].returncode == once[1].returncode == 0, once[0].stderr + once[1].stderr
    assert once[0].stdout == once[1].stdout and "time" not in once[0].stdout
    polled = [
        run_mdl("read", *spelled, "setpoint", "--format", fmt, "--interval", "0.1", "--count", "2", timeout=RUN)
        for spelled in written
    ]
    shapes = [[line.split(",", 1)[-1] if fmt == "csv" else line for line in p.stdout.splitlines()] for p in polled]
    if fmt == "json":
        shapes = [[sorted(json.loads(line)) for line in lines] for lines in shapes]
    if fmt == "table":
        shapes = [[line for line in lines if not line.startswith("time ")] for lines in shapes]
    assert shapes[0] == shapes[1] and len(shapes[0]) >= 2


def test_csv_table_and_senml_name_the_device(sim_factory):
    sim = sim_factory([ALL, ALL], "--unit", "1", "--unit", "2", "--set", "setpoint=21.5")
    proc = run_mdl("read", target(sim, 1), target(sim, 2), "setpoint", "--format", "csv")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "time,device,name,value,units"
    assert sorted(line.split(",", 1)[1] for line in lines[1:]) == [
        "all_tables_u1,setpoint,21.5,°C",
        "all_tables_u2,setpoint,21.5,°C",
    ]
    proc = run_mdl("read", target(sim, 1), target(sim, 2), "setpoint")
    assert proc.returncode == 0 and proc.stdout.count("device    all_tables_u") == 2, proc.stdout
    proc = run_mdl("read", target(sim, 2), target(sim, 1), "setpoint", "--format", "senml")
    docs = [json.loads(line) for line in proc.stdout.splitlines()]
    assert sorted(doc["All Tables"]["bn"] for doc in docs) == ["all_tables_u1/All Tables", "all_tables_u2/All Tables"]


@pytest.fixture
def silent_port():
    """A TCP port that accepts connections (the kernel's backlog) and never answers: a dead device."""
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    try:
        yield sock.getsockname()[1]
    finally:
        sock.close()


def test_a_dead_device_delays_no_other(sim_factory, silent_port):
    """The live devices poll every 0.25 s while the dead one waits out 3 s timeouts: their records stay
    spaced well below the dead device's timeout, and each record names its device."""
    sim = sim_factory([ALL, ALL], "--unit", "1", "--unit", "2")
    dead = f"{ALL}@tcp://127.0.0.1:{silent_port}?timeout=3&retries=0#9"
    proc = subprocess.Popen(
        mdl_cmd("read", target(sim, 1), target(sim, 2), dead, "voltage", "--interval", "0.25", "--format", "json"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lines = read_lines(proc.stdout, lambda got: len(got) >= 40, proc, RUN)  # 5 s: the dead one failed once
        assert proc.poll() is None, proc.stderr.read()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=RUN)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 3, err  # the dead device's last poll failed
    assert "Traceback" not in err
    times = defaultdict(list)
    for line in lines + out.splitlines():
        record = json.loads(line)
        times[record["device"]].append(parse_time(record["time"]))
    assert set(times) == {"all_tables_u1", "all_tables_u2"}
    for device, stamps in times.items():
        gaps = [(b - a).total_seconds() for a, b in zip(stamps, stamps[1:], strict=False)]
        assert len(stamps) >= 20 and max(gaps) < 2.0, (device, gaps)  # never held up by a 3 s timeout
    assert f"all_tables_u9: error: 127.0.0.1:{silent_port} unit 9: reading" in err
    assert "no reply within 3 s" in err


def test_devices_on_one_serial_line_take_turns(serial_line, sim_factory):
    sim_end, client_end = serial_line.ends
    sim_factory([ALL, ALL], "--unit", "4", "--unit", "5", "--set", "voltage=230", serial=sim_end)
    targets = [f"{ALL}@rtu://{client_end}?baud=19200&parity=N#{unit}" for unit in (4, 5)]
    proc = run_mdl("read", *targets, "voltage", "--interval", "0.1", "--count", "3", "--format", "json", timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in proc.stdout.splitlines()]
    assert sorted(r["device"] for r in records) == ["all_tables_u4"] * 3 + ["all_tables_u5"] * 3
    assert all(r["values"] == {"voltage": 230} for r in records)


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["x.xml@tcp://127.0.0.1:5020#300"], "the unit id '300' after '#' is not a number from 0 to 255"),
        (["x.xml@tcp://127.0.0.1:5020?speed=3"], "unknown setting 'speed'"),
        (["x.xml@tcp://127.0.0.1:5020?baud=9600"], "unknown setting 'baud'"),
        (["x.xml@rtu:///dev/null?parity=X"], "parity=X: write N, E or O"),
        (["x.xml@rtu:///dev/null?baud=abc"], "baud=abc: not a number"),
        (["x.xml@tcp://127.0.0.1:99999"], "the port 99999 is not in the range"),
        (["x.xml@tcp://:5020"], "no host"),
        (["x.xml@rtu://"], "rtu:// needs the serial device"),
        (["x.xml@tcp://h", "--host", "h"], "gives its own connection"),
        (["x.xml@tcp://h", "--unit", "3"], "FILE@CONNECTION#UNIT"),
        (["x.xml", "y.xml@tcp://h"], "several devices are each FILE@tcp://"),
    ],
)
def test_target_errors_are_usage_errors(args, fragment):
    assert_clean_error(run_mdl("read", *args), 2, fragment)


def test_a_missing_file_is_invalid_input():
    proc = run_mdl("read", "absent.xml@tcp://127.0.0.1:1#1")
    assert_clean_error(proc, 1, "absent.xml")


def test_target_forms():
    t = parse_target("m.xml@tcp://[::1]:5020?timeout=0.5&retries=0#3")
    assert (t.connection.host, t.connection.port, t.connection.rtu, t.unit) == ("::1", 5020, False, 3)
    assert (t.connection.timeout, t.connection.retries) == (0.5, 0)
    t = parse_target("a@b.xml@rtu+tcp://10.0.0.1#2")
    assert (str(t.file), t.connection.port, t.connection.rtu, t.unit) == ("a@b.xml", 502, True, 2)
    t = parse_target("m.xml@rtu:///dev/ttyUSB0?baud=9600&parity=e&stopbits=2")
    assert (t.connection.serial, t.connection.baud, t.connection.parity, t.connection.stopbits) == (
        "/dev/ttyUSB0",
        9600,
        "E",
        2,
    )
    assert not looks_like_target("meter.xml") and not looks_like_target("user@host")


def test_device_ids_are_unique_and_said():
    ids, notes = device_ids(["a", "b", "a", "a"], [1, 1, 2, 2])
    assert ids == ["a_u1", "b", "a_u2", "a_u2_2"]
    assert len(notes) == 3


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=60), st.sampled_from(["", "m.xml@tcp://", "m.xml@rtu://", "m.xml@rtu+tcp://"]))
def test_fuzz_any_target_text_parses_or_says_why(text, head):
    try:
        t = parse_target(head + text)
    except ValueError as exc:
        assert str(exc)
    else:
        assert 0 <= t.unit <= 255 and t.connection.timeout >= 0.1


@settings(max_examples=200, deadline=None)
@given(
    st.text(min_size=1, max_size=20),
    st.text(max_size=20),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["json", "csv", "table", "senml"]),
)
def test_fuzz_device_records_read_back(device, label, setpoint, fmt):
    """Any device name, text and number: a json record loads back whole, csv rows parse back to the device
    and the values, and every format ends its record with a newline."""
    functions = [Function("label", "t", [1], format="STRING"), Function("setpoint", "s", [2], units="°C")]
    values = {"label": label, "setpoint": setpoint}
    when = datetime(2026, 11, 26, tzinfo=timezone.utc)
    text = output.device_record(device, functions, values, fmt, when, "Dev")
    assert text.endswith("\n")
    if fmt == "json":
        doc = json.loads(text)
        assert doc["device"] == device and doc["values"]["label"] == label
        assert doc["values"]["setpoint"] == (setpoint if math.isfinite(setpoint) else str(setpoint))
    elif fmt == "csv":
        rows = list(csv.reader(io.StringIO(text)))
        assert [row[1:3] for row in rows] == [[device, "label"], [device, "setpoint"]]
        assert rows[0][3] == label and rows[1][4] == "°C"
    elif fmt == "senml":
        assert json.loads(text)["Dev"]["bn"] == f"{device}/Dev"


def test_records_that_cannot_be_written_end_the_run_with_the_reason(sim_factory):
    """stdout on a full disk: the run ends at once with exit 1 and the reason, in every format, never a
    clean exit after polling nothing (review) nor a traceback."""
    sim = sim_factory([ALL, ALL], "--unit", "3", "--unit", "7")
    for fmt in ("json", "csv"):
        with open("/dev/full", "w") as full:
            proc = subprocess.run(
                mdl_cmd("read", target(sim, 3), target(sim, 7), "setpoint", "--interval", "0.2", "--count", "3",
                        "--format", fmt),
                stdout=full, stderr=subprocess.PIPE, text=True, timeout=RUN,
            )  # fmt: skip
        assert proc.returncode == 1, (fmt, proc.stderr)
        assert "cannot write the records: No space left on device" in proc.stderr
        assert "Traceback" not in proc.stderr


def test_targets_sharing_a_line_must_give_it_the_same_settings(sim_factory):
    sim = sim_factory([ALL, ALL], "--unit", "3", "--unit", "7", "--framer", "rtu")
    one = f"{ALL}@rtu+tcp://{sim.host}:{sim.port}?timeout=0.2#3"
    other = f"{ALL}@rtu+tcp://{sim.host}:{sim.port}?timeout=5#7"
    proc = run_mdl("read", one, other, "setpoint", "--interval", "0.2", "--count", "1", timeout=RUN)
    assert_clean_error(proc, 1, "share a line but give it different settings")


def test_one_device_polled_onto_a_full_disk_is_a_clean_error(sim_factory):
    sim = sim_factory(ALL)
    with open("/dev/full", "w") as full:
        proc = subprocess.run(
            mdl_cmd("read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--count", "2"),
            stdout=full, stderr=subprocess.PIPE, text=True, timeout=RUN,
        )  # fmt: skip
    assert proc.returncode == 1 and "cannot write the records: No space left on device" in proc.stderr
    assert "Traceback" not in proc.stderr
