"""`mdl read` / `mdl write` against a device that lies or breaks the connection (tests/support/hostile_server.py):
exit 3, a message naming the connection, the unit and what was wrong, no value, no traceback, in bounded time."""

from __future__ import annotations

import json
import time

import pytest

from support.common import DATA
from support.hostile_server import hostile_server
from support.run import assert_clean_error, run_mdl

ALL = DATA / "all_tables.xml"
UNIT = 7
BOUND = 10  # seconds a run may take against any mode, with --timeout 0.5

READS = {  # function -> its request, one per read function code
    "fan": "reading 1 coil from 1",
    "door_open": "reading 1 discrete from 0",
    "label": "reading 4 holding from 102",
    "voltage": "reading 1 input from 10",
}
WRITES = {  # assignment -> its request: functions 5, 6 and 16
    "pump=1": "writing pump at coil 0",
    "setpoint=20": "writing setpoint at holding 100",
    "label=ab": "writing label at holding 102",
}
REPLY_LIES = {  # mode -> what a read says about it, what a write says
    "wrong_function_code": ("the reply has function code", "the reply has function code"),
    "extra_registers": ("data bytes, expected", "does not echo the request"),
    "short": ("data bytes, expected", "does not echo the request"),
    "bad_byte_count": ("does not match the", "does not echo the request"),
    "long_byte_count": ("does not match the", "does not echo the request"),
    "exception": ("Modbus exception 4 (SERVER DEVICE FAILURE)", "Modbus exception 4 (SERVER DEVICE FAILURE)"),
}
CONNECTION_LIES = {
    "wrong_transaction_id": "the reply's transaction id is",
    "wrong_unit": f"the reply comes from unit {UNIT + 1}",
    "garbage": "the reply is not a Modbus TCP frame",
    "drop": "the connection closed without a reply",
    "reset": "connection error: Connection reset by peer",
    "silent": "no reply within 0.5 s (2 tries)",
}


def run_against(mode: str, *args: str):
    with hostile_server(mode) as (host, port):
        started = time.monotonic()
        proc = run_mdl(*args, "--host", host, "--port", port, "--unit", UNIT, "--timeout", "0.5", timeout=BOUND * 3)
        elapsed = time.monotonic() - started
    assert elapsed < BOUND, (mode, args, elapsed)
    return proc, f"{host}:{port} unit {UNIT}"


def assert_refused(proc, where: str, request: str, problem: str) -> None:
    assert_clean_error(proc, 3, f"{where}: {request}: ", problem)
    assert proc.stdout == "", proc.stdout  # no value from a lying device


def test_an_honest_server_is_trusted():
    """The control: the same server telling the truth is read and written (each register holds its
    address; bits are 1 at odd addresses, padding bits included)."""
    proc, _ = run_against(
        "honest", "read", ALL, "pump", "fan", "door_open", "filter_dirty", "setpoint", "label", "--format", "json"
    )
    assert proc.returncode == 0, proc.stderr
    values = json.loads(proc.stdout)
    assert values == {
        "pump": False,
        "fan": True,
        "door_open": False,
        "filter_dirty": True,
        "setpoint": 10.0,
        "label": "\x00f\x00g\x00h\x00i",
    }
    proc, _ = run_against("honest", "write", ALL, *WRITES)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("name", READS)
@pytest.mark.parametrize("mode", REPLY_LIES)
def test_read_refuses_a_lying_reply(mode, name):
    proc, where = run_against(mode, "read", ALL, name)
    assert_refused(proc, where, READS[name], REPLY_LIES[mode][0])


@pytest.mark.parametrize("assignment", WRITES)
@pytest.mark.parametrize("mode", REPLY_LIES)
def test_write_refuses_a_lying_reply(mode, assignment):
    proc, where = run_against(mode, "write", ALL, assignment)
    assert_refused(proc, where, WRITES[assignment], REPLY_LIES[mode][1])


@pytest.mark.parametrize("mode", CONNECTION_LIES)
def test_read_and_write_survive_a_broken_connection(mode):
    proc, where = run_against(mode, "read", ALL, "label")
    assert_refused(proc, where, READS["label"], CONNECTION_LIES[mode])
    proc, where = run_against(mode, "write", ALL, "label=ab")
    assert_refused(proc, where, WRITES["label=ab"], CONNECTION_LIES[mode])
