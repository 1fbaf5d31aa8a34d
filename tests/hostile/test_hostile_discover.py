"""`mdl discover` against devices that lie in their Read Device Identification (function 43 / MEI 14) replies,
or answer it late (tests/support/hostile_server.py), over Modbus TCP, RTU over TCP and a serial line (socat):
nothing of a malformed reply is shown, a warning names the unit and what was wrong, the follow-up requests are
bounded, and one unit's late or endless reply never changes another unit's answer. Nobody answering at all is exit 3."""

from __future__ import annotations

import json
import shutil
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device.frames import Wire
from mdl.device.replies import MAX_PDU, came_from, parse_identification
from mdl.device.survey.discover import parse_units, unit_list
from support.common import device_xml, fn_xml, skip_or_fail
from support.hostile_server import IDENTITY, identification, rtu_frame, serial_bridge
from support.hostile_server import hostile_server as serving
from support.run import assert_clean_error, run_mdl

RUN = 90  # seconds one discover may take at most (a serial line drains a dribbling reply: about 12 s)
LIAR = 2
HONEST = {"VendorName": "Hostile", "ProductCode": "H1", "MajorMinorRevision": "1.0"}
MALFORMED = {  # mode -> what the warning says was wrong (Modbus TCP, RTU over TCP, serial line)
    "id_long_length": "object 0x00's length byte says 200 bytes, 3 follow",
    "id_extra_count": "it says 5 objects and carries 3",
    "id_huge": "the reply is 64771 bytes long, more than a Modbus PDU's 253",
    "id_more_forever": "'more follows' names object 0x03 next, which is not a basic object (0x00-0x02)",
    "id_more_stuck": "'more follows' names object 0x00 next, which does not advance",
}
ON_RTU = {"id_huge": "more than 256 bytes came, more than a Modbus RTU frame holds"}  # no whole frame


@pytest.fixture
def probe(tmp_path):
    """A description whose marker every unit of the hostile server reads (its registers hold their address)."""
    path = tmp_path / "probe.xml"
    path.write_text(device_xml(fn_xml("model", 5, format="UINT16", access="read", marker=5), "Probe"))
    return path


def discover(probe, connection, units="1-4"):
    started = time.monotonic()
    proc = run_mdl("discover", probe, *connection, "--units", units, "--format", "json", timeout=RUN)
    return proc, time.monotonic() - started


def tcp(host, port, framing):
    return ["--host", host, "--port", port, *(["--framer", "rtu"] if framing == "rtu" else [])]


def where(host, port, framing) -> str:
    return f"{host}:{port}{' (RTU over TCP)' if framing == 'rtu' else ''}"


def assert_units(proc, probe, liar_identification=None) -> None:
    """Units 1-3 answer and match; the liar's identification is `liar_identification`, the others' honest."""
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert json.loads(proc.stdout) == [
        {"unit": unit, "matches": [str(probe)], "identification": liar_identification if unit == LIAR else HONEST}
        for unit in (1, 2, 3)
    ]
    assert "unit 4: no answer" in proc.stderr


def warning(connection: str, problem: str, whole: bool = True) -> str:
    """The warning about the liar's reply; `whole`: the problem is all of it, else its start."""
    return (
        f"mdl discover: warning: {connection} unit {LIAR}: reading the device identification (function 43): "
        f"{problem}" + ("; none of it is shown" if whole else "")
    )


@pytest.mark.parametrize("framing", ["tcp", "rtu"])
@pytest.mark.parametrize("mode", MALFORMED)
def test_a_malformed_identification_shows_nothing_and_says_why(probe, mode, framing):
    with serving(mode, framing=framing, units={1, 2, 3}, liar=LIAR) as (host, port):
        proc, _ = discover(probe, tcp(host, port, framing))
    assert_units(proc, probe)
    problem = ON_RTU.get(mode, MALFORMED[mode]) if framing == "rtu" else MALFORMED[mode]
    assert warning(where(host, port, framing), problem) in proc.stderr, proc.stderr
    assert proc.stderr.count("warning") == 1, proc.stderr


def test_the_control_an_honest_server_is_shown(probe):
    with serving("id_dribble", units={1, 2, 3}, liar=None, gap=0) as (host, port):  # no gap: an honest reply
        proc, _ = discover(probe, tcp(host, port, "tcp"))
    assert_units(proc, probe, HONEST)
    assert "warning" not in proc.stderr


@pytest.mark.parametrize("framing", ["tcp", "rtu"])
def test_a_dribbling_reply_does_not_spoil_the_next_units(probe, framing):
    """Unit 2 sends its identification a byte every 0.4 s (discover waits 0.5 s): it gets none; the late
    bytes never reach units 3 and 4 (a new connection), which answer as they are."""
    with serving("id_dribble", framing=framing, units={1, 2, 3}, liar=LIAR) as (host, port):
        proc, _ = discover(probe, tcp(host, port, framing))
    assert_units(proc, probe)
    assert warning(where(host, port, framing), "no whole reply within 0.5 s (", whole=False) in proc.stderr


@pytest.mark.parametrize("framing", ["tcp", "rtu"])
def test_a_reply_without_end_does_not_spoil_the_next_units(probe, framing):
    """Unit 2's identification is sent again and again without end: its first copy is well-formed (shown);
    the copies that reach unit 3's request are said, dropped with the connection, and the request sent again."""
    with serving("id_stream", framing=framing, units={1, 2, 3}, liar=LIAR) as (host, port):
        proc, _ = discover(probe, tcp(host, port, framing))
    assert_units(proc, probe, HONEST)
    assert (
        f"mdl discover: warning: {where(host, port, framing)} unit 3: " in proc.stderr
        and "bytes came that are no reply of this unit" in proc.stderr
    ), proc.stderr


@pytest.fixture
def line(request):
    """A serial line (a socat pseudo terminal) with the hostile server's RTU frames behind it, in mode request.param."""
    if shutil.which("socat") is None:
        skip_or_fail("socat is not installed: the serial tests wire a pseudo terminal with it")
    with serving(request.param, framing="rtu", units={1, 2, 3}, liar=LIAR) as (_, port), serial_bridge(port) as pty:
        yield pty


@pytest.mark.parametrize("line", ["id_more_stuck"], indirect=True)
def test_serial_line_a_malformed_identification(probe, line):
    proc, _ = discover(probe, ["--serial", line])
    assert_units(proc, probe)
    assert warning(f"{line} (19200 8N1)", MALFORMED["id_more_stuck"]) in proc.stderr, proc.stderr


@pytest.mark.parametrize("line", ["id_dribble"], indirect=True)
def test_serial_line_a_dribbling_reply_is_drained(probe, line):
    """On a serial line the late bytes are read and dropped until the line is quiet for one timeout."""
    proc, _ = discover(probe, ["--serial", line])
    assert_units(proc, probe)
    assert warning(f"{line} (19200 8N1)", "no whole reply within 0.5 s (", whole=False) in proc.stderr


@pytest.mark.exhaustive
@pytest.mark.parametrize("line", ["id_stream"], indirect=True)
def test_serial_line_that_never_goes_quiet_ends_the_scan(probe, line):
    proc, _ = discover(probe, ["--serial", line])
    assert_clean_error(
        proc,
        3,
        f"error: {line} (19200 8N1): the line did not go quiet: bytes kept coming for 15 s "
        "after unit 3 was asked (02 2b 0e",
    )
    assert proc.stdout == ""


@pytest.mark.parametrize("framing", ["tcp", "rtu"])
def test_nobody_answering_is_exit_3(probe, framing):
    with serving("silent", framing=framing) as (host, port):
        proc, _ = discover(probe, tcp(host, port, framing), units="1-3,7")
    hint = "; check the unit id, and the converter's baud rate and parity" if framing == "rtu" else ""
    assert_clean_error(proc, 3, f"error: {where(host, port, framing)}: no unit answered (asked 1-3,7){hint}")
    assert proc.stdout == ""


# the parser of replies, alone


def test_parse_identification_of_each_lie():
    asked = bytes([0x2B, 0x0E, 1, 0])
    reply = parse_identification(identification(asked), 0)
    assert not isinstance(reply, int) and reply.objects == tuple(enumerate(IDENTITY)) and not reply.more
    assert parse_identification(bytes([0xAB, 1]), 0) == 1
    for pdu, problem in [
        (bytes([0xAB, 1, 0]), "the exception reply has 3 bytes, expected 2"),
        (identification(asked)[:6], "fewer than the 7 of its header"),
        (bytes([0x2B, 0x0E, 2]) + identification(asked)[3:], "the reply starts 2b 0e 02"),
        (identification(asked, more=1), "'more follows' byte is 0x01"),
        (identification(asked) + b"\x00", "1 bytes follow its 3 objects"),
        (identification(asked, count=4, objects=bytes([0, 1, 65, 1])), "is cut off after its id"),
        (bytes([0x2B]) * (MAX_PDU + 1), "254 bytes long"),
    ]:
        with pytest.raises(ValueError, match=problem.replace("(", r"\(")):
            parse_identification(pdu, 0)


PDUS = st.one_of(
    st.binary(max_size=300),
    st.builds(
        lambda head, objects, tail: head + b"".join(bytes([o, len(d)]) + d for o, d in objects) + tail,
        st.binary(min_size=7, max_size=7).map(lambda h: b"\x2b\x0e\x01" + h[3:]),
        st.lists(st.tuples(st.integers(0, 255), st.binary(max_size=40)), max_size=8),
        st.binary(max_size=3),
    ),
)


@settings(max_examples=300, deadline=None)
@given(PDUS, st.integers(0, 2))
def test_fuzz_parse_identification_gives_a_checked_reply_or_a_value_error(pdu, object_id):
    try:
        reply = parse_identification(pdu, object_id)
    except ValueError as exc:
        assert str(exc)
        return
    assert len(pdu) <= MAX_PDU
    if isinstance(reply, int):
        assert pdu == bytes([0xAB, reply])
        return
    assert len(reply.objects) == pdu[6]
    assert 7 + sum(2 + len(data) for _, data in reply.objects) == len(pdu)  # every byte accounted for
    assert not reply.more or object_id < reply.next_object <= 2


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2), st.binary(max_size=60)), max_size=3), st.integers(0, 2))
def test_fuzz_well_formed_replies_parse_to_their_objects(objects, object_id):
    body = b"".join(bytes([o, len(d)]) + d for o, d in objects)
    pdu = identification(bytes([0x2B, 0x0E, 1, object_id]), count=len(objects), objects=body)
    reply = parse_identification(pdu, object_id)
    assert not isinstance(reply, int) and list(reply.objects) == objects


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=80), st.integers(1, 3), st.booleans())
def test_fuzz_came_from_never_fails_and_knows_the_units_own_frames(noise, unit, rtu):
    wire = Wire(rtu)
    if rtu:
        wire.trace(True, rtu_frame(unit, bytes([0x2B, 0x0E, 1, 0])))
        own = rtu_frame(unit, identification(bytes([0x2B, 0x0E, 1, 0])))
    else:
        wire.trace(True, bytes([0, 9, 0, 0, 0, 5, unit, 0x2B, 0x0E, 1, 0]))
        pdu = identification(bytes([0x2B, 0x0E, 1, 0]))
        own = bytes([0, 9, 0, 0, 0, len(pdu) + 1, unit]) + pdu
    wire.trace(False, noise)
    assert came_from(wire, unit) in (True, False)
    wire.trace(True, wire.request)
    wire.trace(False, own)
    assert came_from(wire, unit)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 255), min_size=1, max_size=40))
def test_fuzz_unit_list_is_read_back_by_parse_units(units):
    assert parse_units(unit_list(units)) == sorted(set(units))
