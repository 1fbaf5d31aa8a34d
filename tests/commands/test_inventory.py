"""A fleet's inventory (SPEC 15, docs/fleet.md "Inventory"): `mdl validate --inventory` says every mistake at
its FILE:LINE at once; the CSV form reads as the YAML form does; `mdl read --inventory` polls every device on
its own interval, and a device that stops answering is backed off, said once going and once coming back,
while the others on its line keep their schedule."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
from collections import defaultdict
from dataclasses import replace
from datetime import datetime
from pathlib import Path

import pytest

from mdl.device.fleet.inventory import read_inventory
from support.common import DATA, ROOT
from support.devices import read_lines
from support.run import assert_clean_error, mdl_cmd, run_mdl

ALL = DATA / "all_tables.xml"
SITE = ROOT / "examples" / "fleet" / "site.yml"
SITE_CSV = ROOT / "examples" / "fleet" / "site.csv"
RUN = 60


def parse_time(text: str) -> datetime:
    return datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ")


def fleet(folder: Path, *devices: str, defaults: str = "", name: str = "fleet.yaml") -> Path:
    """An inventory in `folder` beside a copy of all_tables.xml: `defaults` on line 1, `devices:` on line 2,
    then one flow mapping per device, so device i (from 1) is on line i + 2."""
    shutil.copy(ALL, folder / "all_tables.xml")
    text = f"defaults: {{{defaults}}}\ndevices:\n" + "".join(f"  - {{{device}}}\n" for device in devices)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def device(ident: str, unit: int = 1, connection: str = "tcp://127.0.0.1:5020", more: str = "") -> str:
    return f"id: {ident}, description: all_tables.xml, connection: '{connection}', unit: {unit}{more}"


def validate(path: Path):
    return run_mdl("validate", "--inventory", path)


# -- mdl validate --inventory -------------------------------------------------------------------------------


def test_the_example_inventories_are_valid_and_said_a_line_per_device():
    for path in (SITE, SITE_CSV):
        proc = validate(path)
        assert proc.returncode == 0, proc.stderr
        lines = proc.stdout.splitlines()
        assert len(lines) == 6 and lines[-1] == f"{path}: valid inventory of 5 devices"
        assert lines[0] == (
            "hall-meter-1: Meter A (../profiles/meter_a.xml) on 192.0.2.15:502 unit 1, every 5 s, profile meter, "
            "tags site=plant1;feeder=A"
        )
        assert lines[2].startswith("office-tstat-3: TEMCO Tstat (../temco_tstat/temco_tstat.xml) on /dev/ttyUSB0 (9600")


def test_the_documented_inventory_is_the_example():
    doc = (ROOT / "docs" / "fleet.md").read_text(encoding="utf-8")
    shown = doc.split("`examples/fleet/site.yml`:\n\n```yaml\n", 1)[1].split("```", 1)[0]
    assert SITE.read_text(encoding="utf-8").endswith(shown)


def test_csv_and_yaml_read_the_same():
    yaml_entries, csv_entries = read_inventory(SITE).entries, read_inventory(SITE_CSV).entries
    assert [replace(e, line=0, lines={}, written={}) for e in yaml_entries] == [
        replace(e, line=0, lines={}, written={}) for e in csv_entries
    ]
    assert [e.tags for e in csv_entries][:2] == [{"site": "plant1", "feeder": "A"}, {"site": "plant1", "feeder": "B"}]
    yaml_out, csv_out = validate(SITE).stdout.splitlines(), validate(SITE_CSV).stdout.splitlines()
    assert yaml_out[:-1] == csv_out[:-1]


@pytest.mark.parametrize(
    ("devices", "defaults", "line", "fragment"),
    [
        ([device("a"), device("a", 2)], "", 4, "device id 'a' is given twice: first at line 3"),
        ([device("a"), device("A", 2)], "", 4, "ids are compared ignoring case"),
        ([device("a b")], "", 3, "device id 'a b' is not one"),
        ([device("..")], "", 3, "device id '..' is not one"),
        (["id: a, description: missing.xml, connection: tcp://h"], "", 3, "description 'missing.xml' cannot be used"),
        ([device("a", more=", intervall: 5")], "", 3, "unknown key 'intervall' in a device"),
        ([device("a", connection="tcp://h:99999")], "", 3, "device 'a': connection 'tcp://h:99999': the port 99999"),
        ([device("a", connection="ftp://h")], "", 3, "unknown scheme 'ftp://'"),
        ([device("a", connection="tcp://h?speed=9")], "", 3, "unknown setting 'speed'"),
        ([device("a", 256)], "", 3, "device 'a': unit 256 is not in the range 0 to 255"),
        ([device("a", more=", interval: 0.01")], "", 3, "interval 0.01 is not in the range 0.1 to 86400 s"),
        ([device("a", more=", interval: fast")], "", 3, "interval 'fast' is not a number"),
        ([device("a", connection="tcp://h#3", more="")], "", 3, "the unit is given twice"),
        ([device("a", connection="tcp://h?timeout=2", more=", timeout: 3")], "", 3, "timeout is given twice"),
        ([device("a", more=", profile: nosuch")], "", 3, "device 'a': profile 'nosuch': no profile named 'nosuch'"),
        (
            [device("a", more=", profile: meter")],
            "",
            3,
            "device 'a': profile 'meter': description 'all_tables.xml' does not fit it",
        ),  # fmt: skip
        ([device("a", more=", tags: 'site=x;floor'")], "", 3, "tag 'floor' has no value"),
        ([device("a", more=", tags: {'a b': x}")], "", 3, "tag name 'a b' is not one"),
        ([device("a")], "interval: 0", 1, "defaults: interval 0 is not in the range"),
        ([device("a")], "timeut: 1", 1, "unknown key 'timeut' in defaults"),
        ([], "", None, "the inventory lists no devices"),
    ],
)
def test_each_mistake_is_said_at_its_line(tmp_path, devices, defaults, line, fragment):
    path = fleet(tmp_path, *devices, defaults=defaults)
    proc = validate(path)
    where = f"{path}:{line}" if line else f"{path}"
    assert_clean_error(proc, 1, fragment)
    said = next(x for x in proc.stderr.splitlines() if fragment in x)
    assert said.startswith(f"{where}:" if line else f"{where}:"), said


def test_a_line_is_never_claimed_with_two_settings(tmp_path):
    path = fleet(
        tmp_path,
        device("a", 1, "rtu:///dev/ttyUSB0?baud=9600&parity=E"),
        device("b", 2, "rtu:///dev/ttyUSB0?baud=19200&parity=E"),
        device("c", 3, "rtu+tcp://10.0.0.5:4001"),
        device("d", 4, "rtu+tcp://10.0.0.5:4001?timeout=0.5"),
        device("e", 5, "tcp://10.0.0.5:4001"),
        device("f", 6, "rtu:///dev/ttyUSB1?baud=9600"),  # another line: its own settings
    )
    proc = validate(path)
    assert_clean_error(proc, 1)
    errors = [x for x in proc.stderr.splitlines() if ": error: " in x]
    assert errors == [
        f"{path}:4: error: device 'b' gives the line /dev/ttyUSB0 (19200 8E1, timeout 3 s, retries 1), but device 'a' "
        "(line 3) gives it (9600 8E1, timeout 3 s, retries 1): a line has one setting; give them the same",
        f"{path}:6: error: device 'd' gives the line 10.0.0.5:4001 (RTU over TCP) (timeout 0.5 s, retries 1), but "
        "device 'c' (line 5) gives it (timeout 3 s, retries 1): a line has one setting; give them the same",
        f"{path}:7: error: device 'e' speaks Modbus TCP to 10.0.0.5:4001, but device 'c' (line 5) speaks RTU over "
        "TCP: a port speaks one",
    ]


def test_an_invalid_description_is_said_with_its_own_errors(tmp_path):
    (tmp_path / "broken.xml").write_text("<Device>", encoding="utf-8")
    path = fleet(tmp_path, device("a"), "id: b, description: broken.xml, connection: tcp://h",
                 "id: c, description: broken.xml, connection: tcp://h, unit: 2")  # fmt: skip
    proc = validate(path)
    assert_clean_error(proc, 1, f"{path}:4: error: device 'b': description 'broken.xml' cannot be used:")
    assert f"{path}:5: error: device 'c': description 'broken.xml' cannot be used (above)" in proc.stderr
    assert proc.stderr.count(f"{tmp_path / 'broken.xml'}:") == 1  # the description's own errors, once


def test_every_mistake_is_said_at_once(tmp_path):
    path = fleet(
        tmp_path,
        device("a"),
        device("a", 2),
        device("b", 300),
        device("c", connection="tcp://h:0"),
        "id: d, description: nothere.xml, connection: tcp://h",
        defaults="retries: 11",
    )
    proc = validate(path)
    assert_clean_error(proc, 1)
    lines = sorted({int(x.split(":")[1]) for x in proc.stderr.splitlines() if x.startswith(f"{path}:")})
    assert lines == [1, 4, 5, 6, 7], proc.stderr


def test_csv_mistakes_are_said_at_their_row(tmp_path):
    shutil.copy(ALL, tmp_path / "all_tables.xml")
    path = tmp_path / "fleet.csv"
    path.write_text(
        "id,description,connection,unit,tags,timeout\n"
        "# a comment, and an empty row\n"
        "\n"
        "a,all_tables.xml,tcp://h,1,site=x;room,\n"
        "b,all_tables.xml,tcp://h,2,,0\n"
        "a,all_tables.xml,tcp://h,3,,\n"
        "c,all_tables.xml,tcp://h,4,,,surplus\n",
        encoding="utf-8",
    )
    proc = validate(path)
    assert_clean_error(
        proc,
        1,
        f"{path}:4: error: device 'a': tag 'room' has no value",
        f"{path}:5: error: device 'b': timeout 0 is not in the range 0.1 to 600 s",
        f"{path}:6: error: device id 'a' is given twice: first at line 4",
        f"{path}:7: error: 7 cells where the header names 6 columns",
    )
    path.write_text("id;description;connection\na;all_tables.xml;tcp://h\n", encoding="utf-8")
    assert_clean_error(validate(path), 1, f"{path}:1: error: unknown column", "columns are separated by commas")
    path.write_text("id,description,colour\n", encoding="utf-8")
    assert_clean_error(validate(path), 1, f"{path}:1: error: unknown column 'colour'", "no column connection")


def test_a_device_named_twice_is_a_warning(tmp_path):
    path = fleet(tmp_path, device("a", 3), device("b", 3))
    proc = validate(path)
    assert proc.returncode == 0, proc.stderr
    assert f"{path}:4: warning: device 'b' is the same device as 'a' (line 3): 127.0.0.1:5020 unit 3" in proc.stderr
    assert_clean_error(run_mdl("validate", "--inventory", path, "--fail-on-warning"), 1, "--fail-on-warning")


@pytest.mark.parametrize(
    "content",
    [b"\xff\xfe\x00garbage", b"devices: " + b"[" * 200, b"a: &x 1\nb: *x\n", b"- just a list\n", b"devices: 3\n"],
)
def test_hostile_files_are_clean_errors(tmp_path, content):
    path = tmp_path / "fleet.yaml"
    path.write_bytes(content)
    assert_clean_error(validate(path), 1, str(path))


def test_an_inventory_too_large_is_refused(tmp_path):
    path = tmp_path / "fleet.csv"
    row = "meter-{},all_tables.xml,tcp://10.0.0.1,1\n"
    with path.open("w") as f:
        f.write("id,description,connection,unit\n")
        for i in range(60_000):
            f.write(row.format(i))
    assert_clean_error(validate(path), 1, f"{path}: error: larger than 2,097,152 bytes")


# -- mdl read --inventory -----------------------------------------------------------------------------------


def test_each_device_is_polled_on_its_own_interval(sim_factory, tmp_path):
    sim = sim_factory([ALL, ALL], "--unit", "1", "--unit", "2", "--set", "setpoint=21.5")
    where = f"tcp://{sim.host}:{sim.port}"
    for name in ("fleet.yaml", "fleet.csv"):
        if name == "fleet.yaml":
            fast, slow = device("fast", 1, where, ", interval: 0.2"), device("slow", 2, where, ", interval: 0.6")
            path = fleet(tmp_path, fast, slow)
        else:
            path = tmp_path / name
            path.write_text(
                f"id,description,connection,unit,interval\nfast,all_tables.xml,{where},1,0.2\n"
                f"slow,all_tables.xml,{where},2,0.6\n"
            )
        proc = run_mdl("read", "--inventory", path, "setpoint", "--count", "3", "--format", "json", timeout=RUN)
        assert proc.returncode == 0, proc.stderr
        records = [json.loads(line) for line in proc.stdout.splitlines()]
        assert all(list(r) == ["time", "device", "values"] for r in records)
        assert all(r["values"] == {"setpoint": 21.5} for r in records)
        times = defaultdict(list)
        for r in records:
            times[r["device"]].append(parse_time(r["time"]))
        assert {d: len(t) for d, t in times.items()} == {"fast": 3, "slow": 3}
        fast, slow = ((t[-1] - t[0]).total_seconds() for t in (times["fast"], times["slow"]))
        assert 0.35 <= fast < 0.9 and 1.15 <= slow < 1.9, (fast, slow)
    proc = run_mdl("read", "--inventory", path, "setpoint", "--count", "1", "--format", "csv", timeout=RUN)
    assert proc.returncode == 0 and proc.stdout.splitlines()[0] == "time,device,name,value,units", proc.stdout


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--interval", "1"], "--inventory gives each device its interval"),
        (["--host", "127.0.0.1"], "--inventory gives each device its connection"),
        (["--unit", "3"], "--inventory gives each device its unit"),
        (["x.xml@tcp://h#1"], "leave out FILE@CONNECTION targets"),
        (["--raw", "hr:0"], "--raw"),
    ],
)
def test_what_the_inventory_gives_is_not_given_beside_it(args, fragment):
    assert_clean_error(run_mdl("read", "--inventory", SITE, *args), 2, fragment)


def test_an_invalid_inventory_polls_nothing(tmp_path):
    path = fleet(tmp_path, device("a"), device("a", 2))
    proc = run_mdl("read", "--inventory", path, "--count", "1", timeout=RUN)
    assert_clean_error(proc, 1, f"{path}:4: error: device id 'a' is given twice")
    assert proc.stdout == ""


def _gaps(stamps: list[datetime]) -> list[float]:
    return [(b - a).total_seconds() for a, b in zip(stamps, stamps[1:], strict=False)]


def _run_until(proc, stream, wanted) -> list[str]:
    lines = read_lines(stream, wanted, proc, RUN)
    assert proc.poll() is None and wanted(lines), lines
    return lines


def test_a_unit_nothing_serves_is_backed_off_and_delays_no_other_on_its_line(sim_factory, tmp_path):
    """An RTU-over-TCP line with units 1 and 2 and a ghost unit 9 that never answers (0.2 s timeout): the
    ghost's first three failures are printed, then `ghost: backing off` once and nothing more; the others
    keep their intervals."""
    sim = sim_factory([ALL, ALL], "--unit", "1", "--unit", "2", "--framer", "rtu")
    line = f"rtu+tcp://{sim.host}:{sim.port}"
    path = fleet(
        tmp_path,
        device("a", 1, line, ", interval: 0.5"),
        device("b", 2, line, ", interval: 1"),
        device("ghost", 9, line, ", interval: 0.5"),
        defaults="timeout: 0.2, retries: 0",
    )
    proc = subprocess.Popen(
        mdl_cmd("read", "--inventory", path, "voltage", "--format", "json"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lines = _run_until(proc, proc.stdout, lambda got: len(got) >= 18)  # some 6 s of a's and b's polls
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=RUN)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err  # a site's poller ends on SIGINT with exit 0, a ghost or not (SPEC 15)
    assert "Traceback" not in err
    assert err.count("ghost: error: ") == 3, err
    assert err.count("ghost: backing off: ") == 1 and "answering again" not in err, err
    assert "no reply within 0.2 s" in err.split("ghost: backing off: ")[1].splitlines()[0]
    times = defaultdict(list)
    for record in map(json.loads, lines + out.splitlines()):
        times[record["device"]].append(parse_time(record["time"]))
    assert set(times) == {"a", "b"}
    for ident, interval in (("a", 0.5), ("b", 1.0)):
        gaps = _gaps(times[ident])
        assert max(gaps) < interval + 0.8, (ident, gaps)  # at most one ghost timeout (0.2 s) late, and slack


def test_a_device_that_comes_back_is_said_once_each_way(sim_factory, tmp_path):
    """A device whose sim stops: three failures printed, `x: backing off` once; the sim starts again on its
    port: `x: answering again` once and its polls go on; the other device polled on time throughout."""
    gone = sim_factory(ALL, "--set", "setpoint=11")
    stays = sim_factory(ALL, "--set", "setpoint=12")
    path = fleet(
        tmp_path,
        device("x", 1, f"tcp://{gone.host}:{gone.port}", ", interval: 0.3"),
        device("y", 1, f"tcp://{stays.host}:{stays.port}", ", interval: 0.3"),
        defaults="timeout: 0.5, retries: 0",
    )
    proc = subprocess.Popen(
        mdl_cmd("read", "--inventory", path, "setpoint", "--format", "json"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    records: list[str] = []
    try:
        records += _run_until(proc, proc.stdout, lambda got: len(got) >= 4)
        port = gone.port
        gone.stop()
        errors = _run_until(proc, proc.stderr, lambda got: any("x: backing off" in x for x in got))
        sim_factory(ALL, "--set", "setpoint=13", port=port)
        errors += _run_until(proc, proc.stderr, lambda got: any("x: answering again" in x for x in got))
        records += _run_until(
            proc, proc.stdout, lambda got: sum('"x"' in x and '"setpoint": 13' in x for x in got) >= 2
        )
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=RUN)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    err = "".join(errors) + err
    assert "Traceback" not in err
    assert err.count("x: error: ") == 3, err  # the first may be the connection lost, then none is made
    assert err.count("x: backing off: cannot connect to") == 1 and err.count("x: answering again") == 1, err
    assert "y: " not in err
    polled = [json.loads(line) for line in records + out.splitlines()]
    assert {r["values"]["setpoint"] for r in polled if r["device"] == "x"} == {11, 13}
    gaps = _gaps([parse_time(r["time"]) for r in polled if r["device"] == "y"])
    assert max(gaps) < 1.2, gaps  # y never waited for x (nor for its 0.5 s timeout)


def test_inventory_ids_make_home_assistant_node_ids():
    """An id may hold `.`, which Home Assistant's node ids may not: spelled `_` with a digest of the id, so
    `meter.3` and `meter_3` stay two devices."""
    from mdl.device.fleet.mqtt import node_id

    nodes = [node_id("site", ident) for ident in ("meter.3", "meter_3", "meter-3", "Meter.3")]
    assert len(set(nodes)) == 4
    assert all(c.isalnum() or c in "_-" for n in nodes for c in n)
    assert nodes[1:3] == ["site-meter_3", "site-meter-3"]  # ids without `.` are themselves
