"""`mdl capture` (SPEC 14): a device's registers -> the raw image `mdl sim --registers` serves back identically
(capture -> sim -> `mdl read` gives the original's values), or a test scenario that `mdl test` passes; with
`--ranges`, the addresses `mdl probe` found. Bad inputs are clean errors; FILE is never overwritten unasked."""

from __future__ import annotations

import json

import pytest

from support.common import fn_xml
from support.run import assert_clean_error, run_mdl

FUNCTIONS = (
    fn_xml("temp", 0, format="FLOAT32", multiplier="0.5")
    + fn_xml("flow", 2, format="FLOAT32", word_order="little")
    + fn_xml("mode", 4, format="UINT16", values={1: "Auto", 2: "Manual"})
    + fn_xml("label", 10, format="STRING", count=4)
    + fn_xml("total", 20, format="INT64")
    + fn_xml("alarm", 30, format="UINT16", bits="3")
    + fn_xml("volts", 100, format="UINT16", register_type="input", multiplier="0.1")
    + fn_xml("door", 3, format="BIT", register_type="coil")
    + fn_xml("flag", 9, format="BIT", register_type="discrete")
)
SETS = ("temp=40.5", "flow=-3.25", "mode=2", "label=Pump", "total=-123456789", "alarm=true", "volts=231.4", "door=1")


@pytest.fixture
def device(write_device, sim_factory):
    path = write_device(FUNCTIONS, "Captured")
    return path, sim_factory(path, *(a for s in SETS for a in ("--set", s)))


def read_json(path, connection):
    proc = run_mdl("read", path, *connection, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_capture_served_back_reads_as_the_original(device, sim_factory, tmp_path):
    path, sim = device
    original = read_json(path, sim.connection)
    raw = tmp_path / "raw.json"
    proc = run_mdl("capture", path, *sim.connection, "-o", raw)
    assert proc.returncode == 0 and proc.stdout == "", proc.stderr
    image = json.loads(raw.read_text())
    assert image["holding"]["4"] == 2 and image["coil"] == {"3": 1} and image["discrete"] == {"9": 0}
    replay = sim_factory(path, "--registers", raw)
    assert read_json(path, replay.connection) == original
    blank = sim_factory(path)  # control: a sim without the image reads otherwise
    assert read_json(path, blank.connection) != original


def test_a_captured_scenario_passes_mdl_test(device, tmp_path):
    path, sim = device
    before = path.read_text()
    shown = run_mdl("capture", path, *sim.connection, "--scenario", "site_a")
    assert shown.returncode == 0, shown.stderr
    assert path.read_text() == before  # without -o the description is not touched: the XML goes to stdout
    tested = tmp_path / "tested.xml"
    assert run_mdl("capture", path, *sim.connection, "--scenario", "site_a", "-o", tested).returncode == 0
    same = [line for line in shown.stdout.splitlines() if "captured from" not in line]  # but the time
    assert [line for line in tested.read_text().splitlines() if "captured from" not in line] == same
    proc = run_mdl("test", tested)
    assert (proc.returncode, proc.stdout) == (0, "1 passed, 0 failed\n"), proc.stdout
    assert "<value>-123456789</value>" in tested.read_text() and "<value>true</value>" in tested.read_text()
    broken = tmp_path / "broken.xml"  # control: a scenario the values do not match fails
    broken.write_text(tested.read_text().replace("<value>-123456789</value>", "<value>5</value>"))
    assert run_mdl("test", broken).stdout.endswith("0 passed, 1 failed\n")
    again = run_mdl("capture", tested, *sim.connection, "--scenario", "site_a", "-o", tmp_path / "x.xml")
    assert_clean_error(again, 1, "it already has a test scenario 'site_a'")
    assert not (tmp_path / "x.xml").exists()


def test_capture_of_the_ranges_a_probe_found(device, tmp_path):
    path, sim = device
    probe = tmp_path / "probe.json"
    proc = run_mdl("probe", *sim.connection, "--units", "1", "--range", "0-120", "--rate", "0", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    probe.write_text(proc.stdout)
    by_ranges = run_mdl("capture", "--ranges", probe, *sim.connection)
    by_file = run_mdl("capture", path, *sim.connection)
    assert by_ranges.returncode == 0, by_ranges.stderr
    assert json.loads(by_ranges.stdout) == json.loads(by_file.stdout)


def test_bad_uses_and_inputs(device, tmp_path):
    path, sim = device
    assert_clean_error(run_mdl("capture", *sim.connection), 2, "give FILE (a description) or --ranges")
    probe = tmp_path / "probe.json"
    probe.write_text('[{"unit": 1, "ranges": {"holding": [[0, 1]]}}, {"unit": 2, "ranges": {}}]')
    assert_clean_error(run_mdl("capture", path, "--ranges", probe, *sim.connection), 2, "one of them")
    assert_clean_error(
        run_mdl("capture", "--ranges", probe, "--scenario", "x", *sim.connection), 2, "--scenario needs FILE"
    )
    assert_clean_error(
        run_mdl("capture", "--ranges", probe, *sim.connection), 1, "holds units 1, 2: pick one with --unit"
    )
    assert_clean_error(run_mdl("capture", "--ranges", probe, "--unit", "9", *sim.connection), 1, "no unit 9")
    ok = run_mdl("capture", "--ranges", probe, "--unit", "1", *sim.connection)
    assert ok.returncode == 0 and json.loads(ok.stdout)["holding"] == {"0": 17058, "1": 0}  # 40.5 / 0.5 as float32
    for text, message in [
        ('[{"unit": 1,', f"{probe}:1:13: error: invalid JSON"),
        ('{"unit": 1}', "expected the output of mdl probe --format json"),
        ('[{"unit": 1, "ranges": {"holding": [[5, 2]]}}]', "holding: [5, 2] is not a range [FIRST, LAST]"),
        ('[{"unit": 1, "ranges": {"cheese": []}}]', "unknown table 'cheese'"),
        ('[{"unit": -1, "ranges": {}}]', '"unit": U (0-255)'),
        ('[{"unit": 300, "ranges": {}}]', '"unit": U (0-255)'),
        ('[{"unit": true, "ranges": {}}]', '"unit": U (0-255)'),
    ]:
        probe.write_text(text)
        assert_clean_error(run_mdl("capture", "--ranges", probe, *sim.connection), 1, message)
    out = tmp_path / "never.json"
    assert_clean_error(run_mdl("capture", path, "--host", "127.0.0.1", "--port", "1", "-o", out), 3, "cannot connect")
    assert not out.exists()


def test_a_range_the_device_refuses_whole_is_captured_in_parts(device, tmp_path):
    """A probe file whose range crosses gaps (or a device that refuses reads across its blocks): the read
    is split down to single addresses, what is defined is captured, what is refused alone is said; a
    table left null (not probed) is skipped."""
    path, sim = device
    probe = tmp_path / "probe.json"
    probe.write_text('[{"unit": 1, "ranges": {"holding": [[0, 12]], "input": null, "coil": [[3, 3]]}}]')
    proc = run_mdl("capture", "--ranges", probe, *sim.connection)
    assert proc.returncode == 0, proc.stderr
    image = json.loads(proc.stdout)
    assert sorted(map(int, image["holding"])) == [0, 1, 2, 3, 4, 10, 11, 12]
    assert image["coil"] == {"3": 1} and image["input"] == {}
    assert "mdl capture: warning:" in proc.stderr and "not captured" in proc.stderr


def test_a_write_only_functions_registers_are_captured_too(write_device, sim_factory, tmp_path):
    """SPEC 14: every register the description names. A write-only coil's state, which the device lets be
    read, is replayed as it was (`mdl read --raw` of the replay equals the original's)."""
    path = write_device(
        fn_xml("level", 0, format="UINT16") + fn_xml("reset", 5, format="BIT", register_type="coil", access="write")
    )
    sim = sim_factory(path, "--set", "level=7", "--set", "reset=1")
    raw = tmp_path / "raw.json"
    proc = run_mdl("capture", path, *sim.connection, "-o", raw)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(raw.read_text())["coil"] == {"5": 1}
    replay = sim_factory(path, "--registers", raw)
    for server in (sim, replay):
        got = run_mdl("read", *server.connection, "--raw", "co:5", "--format", "json")
        assert got.returncode == 0 and json.loads(got.stdout) == {"co:5": True}, got.stdout + got.stderr


def test_a_write_only_register_the_device_will_not_read_is_a_warning(write_device, monkeypatch):
    """However the device refuses reading a write-only function's registers (any exception, a timeout),
    the rest of the image is kept and a warning says what was not captured."""
    from mdl.device import link
    from mdl.device.connection import Connection
    from mdl.device.survey import capture
    from mdl.formats.loading import load_resolved

    path = write_device(fn_xml("level", 0, format="UINT16") + fn_xml("reset", 10, format="UINT16", access="write"))
    resolved = load_resolved(path)

    def read_request(self, req):
        if req.start == 10:
            raise link.ModbusExceptionError("read of registers 10", 1)
        return [7] * req.count

    monkeypatch.setattr(link.Link, "read_request", read_request)
    monkeypatch.setattr(link.Link, "connect", lambda self: None)
    image, warnings = capture.capture_described(resolved, Connection(host="127.0.0.1"), 1)
    assert image["holding"] == {0: 7}
    assert warnings == [
        "reset is write-only, and read of registers 10: Modbus exception 1 (ILLEGAL FUNCTION): not captured"
    ]
