"""`mdl read --interval S [--count N]` (SPEC section 9): one record per poll, spaced start to start, flushed
at once; failed polls on stderr, reconnection, SIGINT, and the exit status of the last poll."""

from __future__ import annotations

import csv
import io
import json
import signal
import subprocess
import threading
from datetime import datetime

import pytest

from support.common import DATA, fn_xml
from support.run import assert_clean_error, cli, mdl_cmd, run_mdl

ALL = DATA / "all_tables.xml"
NAMES = ["setpoint", "mode", "label", "voltage", "pump"]
RUN = 30  # seconds any one command or wait may take
FAILING = ["--timeout", "0.5", "--retries", "0"]


def parse_time(text: str) -> datetime:
    assert text.endswith("Z") and len(text) == len("2026-11-23T05:00:00.123Z"), text
    return datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ")


def assert_spaced(times: list[datetime], interval: float) -> None:
    """Increasing, about `interval` apart from start to start (a loose bound: machines are busy)."""
    gaps = [(b - a).total_seconds() for a, b in zip(times, times[1:], strict=False)]
    assert all(interval * 0.75 <= gap < interval + 2 for gap in gaps), gaps


def test_count_gives_json_records_spaced_from_start_to_start(sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5", "--set", "mode=1")
    proc = run_mdl(
        "read", ALL, *sim.connection, *NAMES, "--interval", "0.2", "--count", "3", "--format", "json", timeout=RUN
    )
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(records) == 3
    for record in records:
        assert list(record) == ["time", *NAMES]
        assert record["setpoint"] == 21.5 and record["mode"] == "Heat"
    assert_spaced([parse_time(r["time"]) for r in records], 0.2)


def test_csv_has_one_header_then_a_row_per_poll(sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5", "--set", "label=Hall")
    proc = run_mdl(
        "read", ALL, *sim.connection, *NAMES, "--interval", "0.2", "--count", "3", "--format", "csv", timeout=RUN
    )
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.reader(io.StringIO(proc.stdout)))
    assert rows[0] == ["time", *NAMES]
    assert len(rows) == 4 and all(row[1:] == ["21.5", "Off", "Hall", "0.0", "false"] for row in rows[1:])
    assert_spaced([parse_time(row[0]) for row in rows[1:]], 0.2)


def test_table_blocks_and_senml_documents(sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5")
    proc = run_mdl("read", ALL, *sim.connection, "setpoint", "pump", "--interval", "0.2", "--count", "2", timeout=RUN)
    assert proc.returncode == 0, proc.stderr
    blocks = proc.stdout.split("\n\n")
    assert blocks[-1] == "" and len(blocks) == 3
    for block in blocks[:2]:
        first, *rows = block.splitlines()
        assert first.split()[0] == "time" and parse_time(first.split()[1])
        assert [row.split()[:2] for row in rows] == [["setpoint", "21.5"], ["pump", "false"]]
    proc = run_mdl(
        "read", ALL, *sim.connection, "setpoint", "--interval", "0.2", "--count", "2", "--format", "senml", timeout=RUN
    )
    assert proc.returncode == 0, proc.stderr
    documents = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(documents) == 2
    times = [doc["All Tables"]["bt"] for doc in documents]
    assert all(isinstance(t, float) for t in times) and 0.15 <= times[1] - times[0] < 2.2, times
    assert documents[0]["All Tables"]["e"][0] == {
        "n": "setpoint",
        "v": 21.5,
        "u": "°C",
        "min": 5.0,
        "max": 35.0,
        "asm": "rw",
    }


def test_count_against_no_device_fails_every_poll_and_exits_3():
    proc = run_mdl(
        "read",
        ALL,
        "--host",
        "127.0.0.1",
        "--port",
        "1",
        "setpoint",
        "--interval",
        "0.2",
        "--count",
        "2",
        "--format",
        "csv",
        timeout=RUN,
    )
    assert_clean_error(proc, 3, "cannot connect to 127.0.0.1:1")
    failures = proc.stderr.splitlines()
    assert len(failures) == 2 and all(parse_time(line.split(": ", 1)[0]) for line in failures), failures
    assert proc.stdout == "time,setpoint\n"


@pytest.mark.parametrize(
    "args, code, message",
    [
        (["--count", "2"], 2, "--count needs --interval"),
        (["--interval", "0"], 2, "--interval"),
        (["--interval", "1", "--count", "0"], 2, "--count"),
    ],
    ids=["count-alone", "zero-interval", "zero-count"],
)
def test_poll_options(args, code, message):
    assert_clean_error(cli("read", ALL, "--host", "127.0.0.1", "--port", "1", *args), code, message)


def test_a_function_named_time_would_hide_the_time_column(write_device):
    path = write_device(fn_xml("time", "10", format="UINT16"))
    for fmt in ("json", "csv"):
        assert_clean_error(
            cli("read", path, "--host", "127.0.0.1", "--port", "1", "--interval", "1", "--format", fmt),
            1,
            "function 'time' has the name of the poll record's time",
        )


class Polling:
    """`mdl read --interval ...` running: its stdout and stderr lines as they come, waits bounded in time."""

    def __init__(self, *args):
        self.proc = subprocess.Popen(mdl_cmd("read", *args), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.changed = threading.Condition()
        self.out: list[str] = []
        self.err: list[str] = []
        self.readers = [
            threading.Thread(target=self._collect, args=(stream, lines), daemon=True)
            for stream, lines in ((self.proc.stdout, self.out), (self.proc.stderr, self.err))
        ]
        for reader in self.readers:
            reader.start()

    def _collect(self, stream, lines: list[str]) -> None:
        for line in iter(stream.readline, ""):  # a last line without its newline too: a torn record shows
            with self.changed:
                lines.append(line)
                self.changed.notify_all()

    def wait_for(self, what, timeout: float = RUN) -> None:
        with self.changed:
            if not self.changed.wait_for(what, timeout):
                raise AssertionError(f"waited {timeout} s in vain: out={self.out!r} err={self.err!r}")

    def stop(self, sig=signal.SIGINT) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            code = self.proc.wait(timeout=RUN)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()
            for reader in self.readers:
                reader.join(timeout=RUN)
            self.proc.stdout.close()
            self.proc.stderr.close()
        return code


def test_sigint_ends_polling_with_whole_records(sim_factory):
    sim = sim_factory(ALL, "--set", "setpoint=21.5")
    polling = Polling(ALL, *sim.connection, "--interval", "0.1", "--format", "csv")
    try:
        polling.wait_for(lambda: len(polling.out) >= 4)
    finally:
        code = polling.stop(signal.SIGINT)
    assert code == 0, polling.err
    assert polling.err == []  # no traceback, no "interrupted"
    rows = list(csv.reader(io.StringIO("".join(polling.out))))
    assert all(line.endswith("\n") for line in polling.out)
    assert rows[0][0] == "time" and all(len(row) == len(rows[0]) for row in rows)


def test_a_stopped_device_fails_polls_then_is_read_again_when_it_returns(sim_factory):
    first = sim_factory(ALL, "--set", "setpoint=21.5")
    polling = Polling(ALL, *first.connection, "setpoint", "--interval", "0.2", "--format", "json", *FAILING)
    try:
        polling.wait_for(lambda: len(polling.out) >= 1)
        first.stop()
        polling.wait_for(lambda: len(polling.err) >= 2)  # polls go on, and fail
        where = f"127.0.0.1:{first.port}"
        assert all(
            f"error: {where} unit 1: " in line or f"error: cannot connect to {where} for unit 1: " in line
            for line in polling.err
        ), polling.err
        assert all(parse_time(line.split(": ", 1)[0]) for line in polling.err)
        second = sim_factory(ALL, "--set", "setpoint=19.5", port=first.port)
        polling.wait_for(lambda: any(json.loads(line)["setpoint"] == 19.5 for line in polling.out))
        second.stop()
        failed = len(polling.err)
        polling.wait_for(lambda: len(polling.err) > failed)  # the last poll failed...
    finally:
        code = polling.stop(signal.SIGINT)
    assert code == 3  # ...and gives the exit status
    assert "Traceback" not in "".join(polling.err)
    assert all(json.loads(line)["setpoint"] in (21.5, 19.5) for line in polling.out)


def test_exit_0_when_the_last_poll_read_after_failures(sim_factory):
    first = sim_factory(ALL, "--set", "setpoint=21.5")
    port = first.port
    first.stop()
    polling = Polling(
        ALL, "--host", "127.0.0.1", "--port", str(port), "setpoint", "--interval", "0.2", "--format", "json", *FAILING
    )
    try:
        polling.wait_for(lambda: len(polling.err) >= 1)
        sim_factory(ALL, "--set", "setpoint=19.5", port=port)
        polling.wait_for(lambda: len(polling.out) >= 1)
    finally:
        code = polling.stop(signal.SIGINT)
    assert code == 0, (polling.out, polling.err)  # the device stayed up after the record: no failure since
    assert json.loads(polling.out[0])["setpoint"] == 19.5
