"""`mdl discover` (SPEC 10) against `mdl sim`: markers matched on their raw values, a device family with
several marker values, descriptions that must not match, one without markers, FC43 identification per
unit, several units behind one port and several ports, the table and JSON outputs, exit statuses 0/1/2/3,
RTU over TCP and on a serial line (a silent unit costs one timeout), progress on a terminal or not."""

from __future__ import annotations

import json
import os
import pty
import select
import socket
import subprocess
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from mdl.device.survey.discover import parse_units
from support.common import ROOT, device_xml, fn_xml
from support.run import assert_clean_error, cli, mdl_cmd, run_mdl

EXAMPLES = ROOT / "examples" / "discovery"
RUN = 60


def identity(manufacturer: str, product: str, version: str) -> str:
    return (
        f"  <manufacturer>{manufacturer}</manufacturer>\n  <product>{product}</product>\n"
        f"  <product_version>{version}</product_version>\n"
    )


def model_functions(model: str, phases: str) -> str:
    return (
        fn_xml("model", 0, format="UINT16", access="read", marker=model)
        + fn_xml("phases", 1, format="UINT16", access="read", marker=phases)
        + fn_xml("voltage", 2, format="UINT16", multiplier=0.1, access="read")
    )


@pytest.fixture
def library(tmp_path):
    """name -> path of the descriptions the tests discover with (and serve)."""
    files = {
        # a family: either model number, one or three phases
        "family": device_xml(identity("Acme Meters", "EM", "3") + model_functions("23854 23855", "1 3"), "Acme EM"),
        "em200": device_xml(identity("Acme Meters", "EM200", "1.0") + model_functions("23855", "3"), "Acme EM200"),
        # the same register layout, another model number: must never match the Acme devices
        "other": device_xml(identity("Other Co", "X1", "0.9") + model_functions("4242", "1 2 3"), "Other X1"),
        # raw values: before multiplier, fragment, with word order, signed, a bit, a float
        "sensor": device_xml(
            fn_xml(
                "device_type",
                "30 31",
                format="UINT32",
                multiplier=0.001,
                register_type="input",
                word_order="little",
                marker=70004,
            )
            + fn_xml("status", 5, format="UINT16", read_function_code="arg = r1 &amp; 1;", marker=5)
            + fn_xml("calibration", 6, format="INT16", marker=-2)
            + fn_xml("ratio", 8, format="FLOAT32", marker=3)
            + fn_xml("alarm", 2, format="BIT", register_type="coil", marker=1),
            "Sensor",
        ),
        "plain": device_xml(fn_xml("value", 0, format="UINT16"), "Plain"),
    }
    paths = {}
    for name, text in files.items():
        paths[name] = tmp_path / f"{name}.xml"
        paths[name].write_text(text, encoding="utf-8")
    return paths


def registers(tmp_path, name: str, data: dict) -> str:
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(data))
    return str(path)


def meter(tmp_path, name: str, model: int, phases: int) -> str:
    return registers(tmp_path, name, {"holding": {"0": model, "1": phases, "2": 2304}})


SENSOR_REGISTERS = {
    "input": {"30": 70004 & 0xFFFF, "31": 70004 >> 16},
    "holding": {"5": 5, "6": 0xFFFE, "8": 0x4040},
    "coil": {"2": 1},
}


@pytest.fixture
def bus(library, sim_factory, tmp_path):
    """Four devices behind one Modbus TCP port: an EM200 at 3, a single-phase EM at 4, the sensor at 7 and
    a two-phase meter (no family member) at 9."""
    return sim_factory(
        [library["em200"], library["family"], library["sensor"], library["family"]],
        "--unit",
        "3",
        "--unit",
        "4",
        "--unit",
        "7",
        "--unit",
        "9",
        "--registers",
        meter(tmp_path, "em200", 23855, 3),
        "--registers",
        meter(tmp_path, "em100", 23854, 1),
        "--registers",
        registers(tmp_path, "sensor", SENSOR_REGISTERS),
        "--registers",
        meter(tmp_path, "two", 23854, 2),
    )


EM = {"VendorName": "Acme Meters", "ProductCode": "EM", "MajorMinorRevision": "3"}
EM200 = {"VendorName": "Acme Meters", "ProductCode": "EM200", "MajorMinorRevision": "1.0"}


def discover(*args, **kw):
    return run_mdl("discover", *args, timeout=RUN, **kw)


def test_units_behind_one_port_match_by_their_markers(library, bus):
    order = ["family", "em200", "other", "sensor", "plain"]
    proc = discover(*(library[n] for n in order), *bus.connection, "--units", "1-10", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [
        {"unit": 3, "matches": [str(library["family"]), str(library["em200"])], "identification": EM200},
        {"unit": 4, "matches": [str(library["family"])], "identification": EM},
        {"unit": 7, "matches": [str(library["sensor"])], "identification": None},
        {"unit": 9, "matches": [], "identification": EM},  # answers, but two phases is no family member
    ]
    assert "Traceback" not in proc.stderr
    assert f"{library['plain']}: warning: no function has a marker" in proc.stderr
    assert proc.stderr.count("warning") == 1
    # not a terminal: a plain line per unit, then the counts
    assert (
        f"mdl discover: unit 3: {library['family']}, {library['em200']} (identification: Acme Meters EM200 1.0)"
        in proc.stderr
    )
    assert "mdl discover: unit 1: no answer" in proc.stderr
    assert "mdl discover: unit 9: no description matches (identification: Acme Meters EM 3)" in proc.stderr
    assert proc.stderr.rstrip().endswith("mdl discover: 4 units answered, 3 matched a description")


def test_the_table(library, bus):
    proc = discover(library["family"], library["sensor"], *bus.connection, "--units", "3-7,9")
    assert proc.returncode == 0, proc.stderr
    family, sensor = str(library["family"]), str(library["sensor"])
    w = len(sensor)
    assert proc.stdout.splitlines() == [
        f"UNIT  {'FILE'.ljust(w)}  DEVICE   VendorName   ProductCode  MajorMinorRevision",
        f"3     {family.ljust(w)}  Acme EM  Acme Meters  EM200        1.0",
        f"4     {family.ljust(w)}  Acme EM  Acme Meters  EM           3",
        f"7     {sensor}  Sensor   -            -            -",
        f"9     {'-'.ljust(w)}  -        Acme Meters  EM           3",
    ]


def test_no_match_is_exit_1_and_still_lists_who_answered(library, bus):
    proc = discover(library["other"], library["plain"], *bus.connection, "--units", "1-10", "--format", "json")
    assert proc.returncode == 1, proc.stderr
    assert [(r["unit"], r["matches"]) for r in json.loads(proc.stdout)] == [(3, []), (4, []), (7, []), (9, [])]
    proc = discover(library["other"], *bus.connection, "--units", "1,2")  # nobody answers: exit 3 (SPEC 9, 10)
    assert_clean_error(proc, 3, f"error: {bus.host}:{bus.port}: no unit answered (asked 1-2)")
    assert proc.stdout == ""


def test_several_ports(library, bus, sim_factory, tmp_path):
    other = sim_factory(library["other"], "--unit", "1", "--registers", meter(tmp_path, "x1", 4242, 2))
    lib = [library["family"], library["em200"], library["other"]]
    found = {}
    for sim in (bus, other):
        proc = discover(*lib, *sim.connection, "--units", "1-9", "--format", "json")
        assert proc.returncode == 0, proc.stderr
        found[sim.port] = {r["unit"]: r["matches"] for r in json.loads(proc.stdout)}
    assert found[other.port] == {1: [str(library["other"])]}
    assert found[bus.port] == {
        3: [str(library["family"]), str(library["em200"])],
        4: [str(library["family"])],
        7: [],
        9: [],
    }


XIF = """#filetype,Modbus_xif
#program_ID,9F00960528040F01
#version,1.2
#product_name,EM-9
#manufacturer,Example Metering
Block Name,Block Index,Datapoint Name,Address,Native Type,IAP Type,Write Enable,Function Code,Marker Value,Description
Identity,0,Model Code,11,UINT16,SNVT_count,-,FC04,341,Model code
Phase,0,Voltage,0,UINT16,SNVT_volt,-,FC04,,Voltage
"""


def test_a_xif_file_discovers_by_its_marker_value_and_serves_its_product_lines(tmp_path, sim_factory, library):
    mod = tmp_path / "em9.mod"
    mod.write_text(XIF)
    sim = sim_factory(mod, "--unit", "5", "--registers", registers(tmp_path, "em9", {"input": {"11": 341}}))
    proc = discover(library["family"], mod, *sim.connection, "--units", "4-6", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [
        {
            "unit": 5,
            "matches": [str(mod)],
            "identification": {"VendorName": "Example Metering", "ProductCode": "EM-9", "MajorMinorRevision": "1.2"},
        }
    ]


def test_sim_answers_read_device_identification_per_unit(library, bus):
    client = ModbusTcpClient(bus.host, port=bus.port, timeout=5)
    assert client.connect()
    try:
        assert client.read_device_information(device_id=3).information == {0: b"Acme Meters", 1: b"EM200", 2: b"1.0"}
        assert client.read_device_information(device_id=4).information == {0: b"Acme Meters", 1: b"EM", 2: b"3"}
        assert client.read_device_information(device_id=4, read_code=4, object_id=1).information == {1: b"EM"}
        for unit, read_code, object_id, code in [
            (7, 1, 0, 1),  # no identity elements: no such function
            (5, 1, 0, 11),  # no device at unit 5
            (4, 4, 5, 2),
        ]:  # ModelName: not in MDL
            reply = client.read_device_information(device_id=unit, read_code=read_code, object_id=object_id)
            assert reply.isError() and reply.exception_code == code, (unit, reply)
    finally:
        client.close()


def test_an_identity_too_long_for_one_reply_is_cut_and_said(tmp_path, sim_factory):
    path = tmp_path / "long.xml"
    path.write_text(device_xml(identity("&#233;" * 150, "P", "1") + fn_xml("v", 0), "Long"), encoding="ascii")
    sim = sim_factory(path)
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        info = client.read_device_information(device_id=1).information
    finally:
        client.close()
    assert info[0] == ("\u00e9" * 120).encode() and info[1] == b"P"
    sim.stop()
    assert "manufacturer is 300 bytes long; function 43 answers VendorName with its first 240 bytes" in sim.stderr


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_nothing_listening_is_exit_3_naming_the_connection(library):
    port = _free_port()
    assert_clean_error(
        cli("discover", library["family"], "--host", "127.0.0.1", "--port", port),
        3,
        f"cannot connect to 127.0.0.1:{port} for units 1-247: ",
    )
    assert_clean_error(
        cli("discover", library["family"], "--host", "127.0.0.1", "--port", port, "--framer", "rtu"),
        3,
        f"cannot connect to 127.0.0.1:{port} (RTU over TCP) for units 1-247: ",
    )
    assert_clean_error(
        cli("discover", library["family"], "--serial", "/nonexistent/ttyX"),
        3,
        "cannot open serial device /nonexistent/ttyX",
    )


def test_a_description_without_markers_is_a_warning_that_fail_on_warning_refuses(library):
    port = _free_port()  # nothing listens: exit 1 shows it refused before connecting
    proc = cli(
        "discover", library["family"], library["plain"], "--host", "127.0.0.1", "--port", port, "--fail-on-warning"
    )
    assert_clean_error(proc, 1, f"{library['plain']}: warning: no function has a marker", "--fail-on-warning")
    assert "cannot connect" not in proc.stderr


def test_bad_unit_lists_are_usage_errors_naming_every_bad_item(library):
    proc = cli("discover", library["family"], "--host", "127.0.0.1", "--units", "1-x,300,9-2,,5")
    assert_clean_error(
        proc,
        2,
        "'1-x' is not a unit id or a range FIRST-LAST",
        "300 is outside 0-255",
        "'9-2' runs backwards (write 2-9)",
        "an empty item",
    )


def test_parse_units():
    assert parse_units("1-10,17") == [*range(1, 11), 17]
    assert parse_units(" 17 , 3 - 5,4") == [3, 4, 5, 17]
    assert parse_units("0-255") == list(range(256))
    for bad in ["", "256", "1-1000000000", "1-", "-3", "a", "1.5", "\u0663", "1-2-3", "9" * 5000]:
        with pytest.raises(ValueError):
            parse_units(bad)


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.text(alphabet="0123456789-, \u0663x", max_size=20), st.text(max_size=20)))
def test_fuzz_parse_units_gives_units_or_a_value_error(text):
    try:
        units = parse_units(text)
    except ValueError as exc:
        assert str(exc)
        return
    assert units == sorted(set(units)) and all(0 <= u <= 255 for u in units) and units


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 255), st.integers(0, 20)), min_size=1, max_size=6))
def test_fuzz_parse_units_of_ranges_is_their_union(ranges):
    items = [f"{a}-{min(a + n, 255)}" if n else str(a) for a, n in ranges]
    assert parse_units(",".join(items)) == sorted({u for a, n in ranges for u in range(a, min(a + n, 255) + 1)})


def test_rtu_over_tcp_skips_silent_units(library, sim_factory, tmp_path):
    sim = sim_factory(
        [library["sensor"], library["em200"]],
        "--framer",
        "rtu",
        "--unit",
        "2",
        "--unit",
        "4",
        "--registers",
        registers(tmp_path, "s", SENSOR_REGISTERS),
        "--registers",
        meter(tmp_path, "m", 23855, 3),
    )
    proc = discover(
        library["family"], library["sensor"], *sim.connection, "--framer", "rtu", "--units", "1-5", "--format", "json"
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [
        {"unit": 2, "matches": [str(library["sensor"])], "identification": None},
        {"unit": 4, "matches": [str(library["family"])], "identification": EM200},
    ]
    assert "mdl discover: unit 5: no answer" in proc.stderr


def test_serial_line_a_silent_unit_costs_one_timeout(library, serial_line, sim_factory, tmp_path):
    device, client_end = serial_line.ends
    sim_factory(
        [library["family"], library["sensor"]],
        "--unit",
        "2",
        "--unit",
        "6",
        "--registers",
        meter(tmp_path, "m", 23854, 3),
        "--registers",
        registers(tmp_path, "s", SENSOR_REGISTERS),
        serial=device,
    )
    timeout = 1.5
    started = time.monotonic()
    proc = discover(
        library["em200"],
        library["family"],
        library["sensor"],
        "--serial",
        client_end,
        "--units",
        "0-3,6",
        "--timeout",
        timeout,
        "--format",
        "json",
    )
    elapsed = time.monotonic() - started
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [
        {"unit": 2, "matches": [str(library["family"])], "identification": EM},
        {"unit": 6, "matches": [str(library["sensor"])], "identification": None},
    ]
    assert "unit 0 is the broadcast address on a serial line" in proc.stderr
    # units 1 and 3 are silent: one timeout each (two each would be 6 s), plus starting Python
    assert 2 * timeout <= elapsed < 2 * timeout + 3, elapsed


def test_progress_bar_on_a_terminal(library, bus):
    """stderr a terminal: a progress bar, no line per unit; stdout still the plain table."""
    main, child = pty.openpty()
    proc = subprocess.Popen(
        mdl_cmd("discover", library["family"], *bus.connection, "--units", "1-5"),
        stdout=subprocess.PIPE,
        stderr=child,
        text=True,
    )
    os.close(child)
    err = b""
    deadline = time.monotonic() + RUN
    while time.monotonic() < deadline:
        if select.select([main], [], [], 1)[0]:
            try:
                data = os.read(main, 4096)
            except OSError:  # the terminal's other end closed
                break
            if not data:
                break
            err += data
        elif proc.poll() is not None:
            break
    os.close(main)
    out = proc.stdout.read()
    proc.stdout.close()
    assert proc.wait(timeout=RUN) == 0
    text = err.decode()
    assert "asking units on" in text and "unit 5" in text, text
    assert "no answer" not in text, text
    assert out.splitlines()[1].startswith("3     ")


def test_the_help_examples_library(sim_factory):
    """examples/discovery: the sim line docs/discovery.md shows, and the discover examples of --help."""
    sim = sim_factory(
        [EXAMPLES / "em100.xml", EXAMPLES / "rs4.xml"],
        "--unit",
        "3",
        "--unit",
        "7",
        "--registers",
        EXAMPLES / "em100.json",
        "--registers",
        EXAMPLES / "rs4.json",
    )
    proc = discover(
        *(EXAMPLES / f"{n}.xml" for n in ("em100", "em200", "rs4")),
        *sim.connection,
        "--units",
        "1-10",
        "--format",
        "json",
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [
        {
            "unit": 3,
            "matches": [str(EXAMPLES / "em100.xml")],
            "identification": {"VendorName": "Acme Meters", "ProductCode": "EM100", "MajorMinorRevision": "2.1"},
        },
        {"unit": 7, "matches": [str(EXAMPLES / "rs4.xml")], "identification": None},
    ]
