"""`mdl read CONNECTION --raw TABLE:RANGE [--as TYPE]` (SPEC 14): raw registers without a description, against
`mdl sim`, with the values the description reads as the control; bad ranges and options are clean usage errors,
an undefined register is exit 3 naming it."""

from __future__ import annotations

import json

import pytest

from support.common import fn_xml
from support.run import assert_clean_error, run_mdl

FUNCTIONS = (
    fn_xml("temp", 0, format="FLOAT32")
    + fn_xml("flow", 2, format="FLOAT32", word_order="little")
    + fn_xml("offset", 4, format="INT16")
    + fn_xml("label", 10, format="STRING", count=4)
    + fn_xml("energy", 20, format="UINT32")
    + fn_xml("big", 30, format="INT64")
    + fn_xml("door", 3, format="BIT", register_type="coil")
    + fn_xml("volts", 100, format="UINT16", register_type="input")
)
SETS = ("temp=21.5", "flow=-3.25", "offset=-7", "label=Pump", "energy=70000", "big=-5", "door=1", "volts=231")


@pytest.fixture
def device(write_device, sim_factory):
    path = write_device(FUNCTIONS, "Raw Device")
    sets = [arg for s in SETS for arg in ("--set", s)]
    return path, sim_factory(path, *sets)


def raw_json(sim, *args):
    proc = run_mdl("read", *sim.connection, *args, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_raw_values_equal_what_the_description_reads(device):
    path, sim = device
    described = json.loads(run_mdl("read", path, *sim.connection, "--format", "json").stdout)
    assert raw_json(sim, "--raw", "hr:0-1", "--as", "float32") == {"hr:0": described["temp"]} == {"hr:0": 21.5}
    flow = raw_json(sim, "--raw", "hr:2+2", "--as", "float32", "--word-order", "little")
    assert flow == {"hr:2": described["flow"]} == {"hr:2": -3.25}
    assert raw_json(sim, "--raw", "hr:2+2", "--as", "float32")["hr:2"] != -3.25  # control: the order matters
    assert raw_json(sim, "--raw", "hr:4", "--as", "int16") == {"hr:4": -7}
    assert raw_json(sim, "--raw", "hr:4") == {"hr:4": 65529}  # uint16 by default
    assert raw_json(sim, "--raw", "holding:10-13", "--as", "string") == {"hr:10": "Pump"}
    assert raw_json(sim, "--raw", "hr:20-21", "--as", "uint32") == {"hr:20": 70000}
    assert raw_json(sim, "--raw", "hr:30+4", "--as", "int64") == {"hr:30": -5}
    assert raw_json(sim, "--raw", "ir:100", "--raw", "co:3") == {"ir:100": 231, "co:3": True}


def test_hex_bits_byte_order_and_the_other_formats(device):
    _, sim = device
    assert raw_json(sim, "--raw", "hr:4", "--raw", "hr:20-21", "--as", "hex") == {
        "hr:4": "0xFFF9",
        "hr:20": "0x0001",
        "hr:21": "0x1170",
    }
    assert raw_json(sim, "--raw", "hr:4", "--as", "bits") == {"hr:4": "1111111111111001"}
    assert raw_json(sim, "--raw", "hr:4", "--as", "hex", "--byte-order", "little") == {"hr:4": "0xF9FF"}
    table = run_mdl("read", *sim.connection, "--raw", "hr:0-1", "--raw", "co:3", "--as", "float32")
    assert table.returncode == 0 and table.stdout.split() == ["hr:0", "21.5", "co:3", "true"]
    csv = run_mdl("read", *sim.connection, "--raw", "ir:100", "--format", "csv")
    assert csv.stdout == "name,value,units\nir:100,231,\n"


def test_polling_raw_registers(device):
    _, sim = device
    proc = run_mdl("read", *sim.connection, "--raw", "ir:100", "--interval", "0.1", "--count", "2", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [r["ir:100"] for r in records] == [231, 231] and all("time" in r for r in records)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--raw", "hr:0-2", "--as", "float32"], "hr:0-2 is 3 registers, not a whole number of float32 values"),
        (["--raw", "xx:1"], "'xx' is not a table"),
        (["--raw", "hr:9-3"], "runs backwards (write hr:3-9)"),
        (["--raw", "hr:65535+2"], "address 65536 is over 65535"),
        (["--raw", "hr:0+0"], "must be 1 or more"),
        (["--raw", "hr:0-9x"], "is not a range"),
        (["--raw", "hr:0", "--as", "float16"], "'float16' is not one of uint16"),
        (["--raw", "hr:0-199", "--as", "string"], "a string of 200 registers is more than one request reads"),
        (["--raw", "hr:0-3", "--raw", "hr:0-1", "--as", "string"], "hr:0 starts two values, hr:0-3 and hr:0-1"),
        ([], "missing FILE: give a description to read, or --raw TABLE:RANGE"),
        (["--as", "float32", "x.xml"], "--as goes with --raw"),
        (["x.xml", "--raw", "hr:0"], "--raw reads without a description: leave out FILE and NAME (x.xml)"),
    ],
)
def test_bad_ranges_and_options_are_usage_errors(args, message):
    proc = run_mdl("read", "--host", "127.0.0.1", "--port", "1", *args)
    assert_clean_error(proc, 2, message)


def test_registers_the_device_refuses_are_null_and_said_the_others_read(device):
    """As mbpoll: a line per register, the refused ones marked (null, and a warning naming each run of
    them), exit 0; the range is read again in smaller requests, not given up (issue 37)."""
    _, sim = device
    proc = run_mdl("read", *sim.connection, "--raw", "hr:4-6", "--raw", "hr:10-13", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    values = json.loads(proc.stdout)
    assert values["hr:4"] == 65529 and values["hr:5"] is None and values["hr:6"] is None
    assert [values[f"hr:{a}"] for a in (10, 11)] == [ord("P") * 256 + ord("u"), ord("m") * 256 + ord("p")]
    assert proc.stderr == "warning: hr:5-6: the device answers Modbus exception 2 (ILLEGAL DATA ADDRESS): no value\n"
    table = run_mdl("read", *sim.connection, "--raw", "hr:4-5")
    assert table.returncode == 0 and table.stdout.splitlines() == ["hr:4  65529", "hr:5  null"]


def test_a_range_the_device_refuses_whole_is_a_device_error_naming_it(device):
    _, sim = device
    assert_clean_error(
        run_mdl("read", *sim.connection, "--raw", "hr:5-6"),
        3,
        "reading 1 holding from 5: Modbus exception 2 (ILLEGAL DATA ADDRESS)",
    )


def test_a_manuals_register_number_gets_the_address_it_means(device):
    """40001 is how manuals number holding register 0 (Modicon): said where the device refuses hr:40001,
    and where --raw has no table at all."""
    _, sim = device
    assert_clean_error(
        run_mdl("read", *sim.connection, "--raw", "hr:40001"),
        3,
        "40001 looks like a manual's number (Modicon) for hr:0: did you mean hr:0?",
    )
    for number, meant in (("40001", "write hr:0"), ("300101", "write ir:100"), ("10004", "write di:3")):
        assert_clean_error(run_mdl("read", *sim.connection, "--raw", number), 2, meant)
    assert raw_json(sim, "--raw", "hr:0-1", "--as", "float32") == {"hr:0": 21.5}  # what hr:40001 meant
