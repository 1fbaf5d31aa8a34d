#!/usr/bin/env python3
"""Per-poll latency of `mdl read --interval` on a 500-register device, over Modbus TCP, RTU over TCP
and Modbus RTU on a pseudo-terminal pair at 115200 baud, beside the time the same frames need on a
real serial line at that speed. Prints figures; asserts nothing.

    python3 bench/rtu_poll_bench.py                  # 40 polls per link, csv records
    python3 bench/rtu_poll_bench.py --polls 100 --format json --links rtu

The device is bench/poll_bench.py's (500 holding registers as 300 functions of six kinds), read by
the plan resolve makes: 4 requests of 125 registers. `mdl sim` serves it in its own process: on a
free TCP port; with `--framer rtu` on another; and with `--serial` on one end of a
`socat -d -d pty,raw,echo=0 pty,raw,echo=0` pair (as tests/conftest.py's serial_line makes one),
the client on the other end, both at --baud (115200) and --parity/--stopbits (8N1; some kernels'
pseudo terminals refuse parity E or O). Without socat the RTU row is skipped with the reason.

What is measured. The client runs in this process and is exactly `mdl read --interval`: the
device loaded as the CLI loads it, a `mdl.device.runtime.Session`, and `mdl.device.fleet.poll.poll`
writing its records (--format, csv by default) to /dev/null. `poll` runs each poll as one call of
`mdl.device.fleet.poll._poll_once` (connect if need be, `Session.read` of every readable function by the
plan, the record formatted, written and flushed); the wait for the next poll's start
(`Stopper.sleep_until`) lies outside that call. The bench wraps `_poll_once` and times each call
with time.perf_counter (wall) and time.process_time (this process's CPU), so a poll's figure is its
whole cost without the wait. It includes the sim's time to answer and the pty or loopback transfer:
it is the latency a user of `mdl read` sees, not the client's CPU alone (that is the CPU column).
The first poll (connecting, resolving, compiling the decoders, the plan) is shown apart; the
others give the median, the 10th and the 90th percentile. "in requests" is the median time spent
inside `Session.read_request` (send, wait for the reply, pymodbus decoding it, the reply checks);
the rest of a poll is evaluating the values and writing the record.

The wire time is what the same frames need on a real line: per read of the plan an 8-byte request
and a 5 + 2*N byte reply (N registers; 5 + ceil(N/8) for bits), each byte a character of
1 start + data bits + parity bit (if any) + stop bits (10 bits for 8N1, 11 for 8E1 or 8N2, the
character the Modbus serial line spec defines), plus a 3.5-character silent interval per frame. It
is the same for every link: the figure a serial bus cannot beat. A pty does not pace bytes at its
baud rate, so the RTU row's ratio measured/wire says how much of a real line's time the software
adds; on a real line a poll takes about the wire time plus that overhead.

The machine's load changes these figures: run it on an idle machine, and compare rows of one run.
"""

from __future__ import annotations

import argparse
import codecs
import os
import selectors
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from poll_bench import REGISTERS, device_xml  # noqa: E402  (the bench device, shared)

SPEC_GAP_ABOVE_19200 = 1.75e-3  # the Modbus serial line spec's fixed t3.5 above 19200 baud


# ---------------------------------------------------------------------------------------------
# processes: the socat pair and the sim


def _lines(
    proc: subprocess.Popen[bytes], stream: Any, wanted: Callable[[list[str]], bool], timeout: float
) -> list[str]:
    """Whole lines of `stream` until `wanted(lines)`, the process ends, or `timeout` seconds pass."""
    fd = stream.fileno()
    decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
    deadline = time.monotonic() + timeout
    text, lines = "", []
    with selectors.DefaultSelector() as sel:
        sel.register(fd, selectors.EVENT_READ)
        while not wanted(lines) and time.monotonic() < deadline:
            if sel.select(timeout=0.5):
                data = os.read(fd, 4096)
                if not data:
                    break
                text += decoder.decode(data)
                *complete, text = text.split("\n")
                lines += complete
            elif proc.poll() is not None:
                break
    return lines


def stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def socat_pair() -> tuple[subprocess.Popen[bytes], list[str]]:
    """A pseudo-terminal pair wired together by socat: the process and the two device names."""
    proc = subprocess.Popen(
        ["socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    lines = _lines(proc, proc.stderr, lambda got: sum(" PTY is " in line for line in got) == 2, 10)
    ends = [line.split(" PTY is ", 1)[1].strip() for line in lines if " PTY is " in line]
    if len(ends) != 2:
        stop(proc)
        raise SystemExit(f"socat made no pseudo-terminal pair: {lines!r}")
    return proc, ends


def start_sim(xml: Path, where: list[str]) -> tuple[subprocess.Popen[bytes], str]:
    """`mdl sim XML WHERE...` once it is serving, and where it serves (host:port or the serial device)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), PYTHONWARNINGS="ignore")
    proc = subprocess.Popen(
        [sys.executable, "-m", "mdl", "sim", str(xml), *where], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    )
    lines = _lines(proc, proc.stdout, bool, 60)
    if not lines or not lines[0].startswith("mdl sim: serving"):
        stop(proc)
        err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
        raise SystemExit(f"mdl sim did not start: {lines!r} {err[-400:]}")
    return proc, lines[0].rsplit(" unit ", 1)[0].rsplit(" on ", 1)[1]


# ---------------------------------------------------------------------------------------------
# the wire time of the plan


@dataclass(frozen=True)
class Wire:
    reads: int
    request_bytes: int
    reply_bytes: int
    bits_per_char: int
    seconds: float  # characters and a 3.5-character gap per frame
    seconds_spec_gap: float  # the same with the spec's fixed 1.75 ms gap above 19200 baud


def wire_time(xml: Path, baud: int, bytesize: int, parity: str, stopbits: int) -> Wire:
    from mdl.formats.loading import load_resolved

    resolved = load_resolved(xml)
    requests = [group.request for group in resolved.plan]
    request_bytes = 8 * len(requests)  # unit, function, address, count, CRC
    reply_bytes = sum(
        5 + (2 * r.count if r.table in ("holding", "input") else (r.count + 7) // 8) for r in requests
    )  # unit, function, byte count, data, CRC
    bits = 1 + bytesize + (parity != "N") + stopbits
    char = bits / baud
    frames = 2 * len(requests)
    chars = request_bytes + reply_bytes
    gap = SPEC_GAP_ABOVE_19200 if baud > 19200 else 3.5 * char
    return Wire(
        len(requests), request_bytes, reply_bytes, bits, chars * char + frames * 3.5 * char, chars * char + frames * gap
    )


# ---------------------------------------------------------------------------------------------
# the client: mdl read --interval, in this process, each poll timed


@dataclass
class Result:
    first: float
    wall: list[float]  # seconds per poll, the first left out
    cpu: list[float]
    requests: list[float]  # seconds inside Session.read_request, per poll
    failures: list[str]


def measure(xml: Path, connection: Any, polls: int, interval: float, fmt: str) -> Result:
    from mdl.device.fleet import poll as polling
    from mdl.device.runtime import Session
    from mdl.formats.loading import load_resolved

    device = load_resolved(xml).device  # as `mdl read` loads it
    functions = [fn for fn in device.functions if fn.readable]
    session = Session(device, connection, 1)
    in_requests = [0.0]
    read_request = session.read_request

    def timed_request(req: Any) -> list[int]:
        start = time.perf_counter()
        try:
            return read_request(req)
        finally:
            in_requests[0] += time.perf_counter() - start

    session.read_request = timed_request  # type: ignore[method-assign]
    wall: list[float] = []
    cpu: list[float] = []
    requests: list[float] = []
    poll_once = polling._poll_once

    def timed_poll(*args: Any, **kwargs: Any) -> int:
        in_requests[0] = 0.0
        c0, w0 = time.process_time(), time.perf_counter()
        try:
            return poll_once(*args, **kwargs)
        finally:
            wall.append(time.perf_counter() - w0)
            cpu.append(time.process_time() - c0)
            requests.append(in_requests[0])

    class Errors:
        def __init__(self) -> None:
            self.lines: list[str] = []

        def write(self, text: str) -> int:
            self.lines.append(text.rstrip("\n"))
            return len(text)

        def flush(self) -> None:
            pass

    errors = Errors()
    polling._poll_once = timed_poll  # type: ignore[assignment]
    try:
        with open(os.devnull, "w") as out:
            polling.poll(session, functions, fmt, interval, polls, out=out, err=errors)  # type: ignore[arg-type]
    finally:
        polling._poll_once = poll_once  # type: ignore[assignment]
    return Result(wall[0], wall[1:], cpu[1:], requests[1:], errors.lines)


# ---------------------------------------------------------------------------------------------


def percentile(values: list[float], p: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(p * (len(ordered) - 1) + 0.5))]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--polls", type=int, default=40, help="polls per link (the first is shown apart)")
    parser.add_argument("--interval", type=float, default=0.05, help="--interval of the polling, seconds")
    parser.add_argument("--format", dest="fmt", choices=["table", "json", "csv", "senml"], default="csv")
    parser.add_argument("--baud", type=int, default=115200)
    parser.add_argument("--parity", choices=["N", "E", "O"], default="N")
    parser.add_argument("--stopbits", type=int, choices=[1, 2], default=1)
    parser.add_argument("--links", default="tcp,rtu-over-tcp,rtu", help="which links (comma separated)")
    args = parser.parse_args()
    if args.polls < 2:
        parser.error("--polls must be at least 2")

    from mdl.device.connection import Connection

    links = args.links.split(",")
    framing = f"{args.baud} 8{args.parity}{args.stopbits}"
    results: dict[str, Result | str] = {}
    with tempfile.TemporaryDirectory(prefix="mdl-rtu-poll-") as tmp:
        xml = Path(tmp) / "poll_bench_device.xml"
        xml.write_text(device_xml())
        wire = wire_time(xml, args.baud, 8, args.parity, args.stopbits)
        for link in links:
            procs: list[subprocess.Popen[bytes]] = []
            try:
                if link == "tcp":
                    sim, where = start_sim(xml, ["--port", "0"])
                    procs.append(sim)
                    host, port = where.rsplit(":", 1)
                    connection = Connection(host=host, port=int(port))
                elif link == "rtu-over-tcp":
                    sim, where = start_sim(xml, ["--port", "0", "--framer", "rtu"])
                    procs.append(sim)
                    host, port = where.rsplit(":", 1)
                    connection = Connection(host=host, port=int(port), rtu=True)
                elif link == "rtu":
                    if shutil.which("socat") is None:
                        results[link] = "skipped: socat is not installed (apt-get install socat)"
                        print(f"  {link}: {results[link]}", file=sys.stderr)
                        continue
                    pair, ends = socat_pair()
                    procs.append(pair)
                    line = ["--baud", str(args.baud), "--parity", args.parity, "--stopbits", str(args.stopbits)]
                    sim, _ = start_sim(xml, ["--serial", ends[0], *line])
                    procs.insert(0, sim)  # the sim stops before the line goes
                    connection = Connection(
                        serial=ends[1], baud=args.baud, parity=args.parity, stopbits=args.stopbits, rtu=True
                    )
                else:
                    parser.error(f"unknown link {link!r}: tcp, rtu-over-tcp, rtu")
                results[link] = measure(xml, connection, args.polls, args.interval, args.fmt)
                print(f"  {link}: done", file=sys.stderr, flush=True)
            finally:
                for proc in procs:
                    stop(proc)

    ms = 1e3
    print()
    print(
        f"mdl read --interval {args.interval:g} --format {args.fmt}: {REGISTERS} holding registers, "
        f"{wire.reads} reads per poll; {args.polls} polls per link, the first apart"
    )
    print(f"per poll, without the wait between polls (ms); wire: the same frames on a real line at {framing}")
    print(
        f"{'link':14} {'first':>7} {'median':>7} {'p10':>7} {'p90':>7} {'in requests':>12} {'client CPU':>11} "
        f"{'wire':>7} {'measured/wire':>14}"
    )
    for link in links:
        result = results.get(link)
        if isinstance(result, str) or result is None:
            print(f"{link:14} {result or '-'}")
            continue
        median = statistics.median(result.wall)
        print(
            f"{link:14} {result.first * ms:7.2f} {median * ms:7.2f} {percentile(result.wall, 0.1) * ms:7.2f} "
            f"{percentile(result.wall, 0.9) * ms:7.2f} {statistics.median(result.requests) * ms:12.2f} "
            f"{statistics.median(result.cpu) * ms:11.2f} {wire.seconds * ms:7.2f} {median / wire.seconds:14.3f}"
        )
        for failure in result.failures[:3]:
            print(f"{'':14} failed poll: {failure}")
        if len(result.failures) > 3:
            print(f"{'':14} ... {len(result.failures) - 3} more failed polls")
    print()
    print(
        f"wire: {wire.reads} x (8-byte request + reply) = {wire.request_bytes} + {wire.reply_bytes} bytes at "
        f"{wire.bits_per_char} bits per character, and a 3.5-character gap per frame: {wire.seconds * ms:.2f} ms"
    )
    if args.baud > 19200:
        print(f"      with the spec's fixed 1.75 ms gap above 19200 baud instead: {wire.seconds_spec_gap * ms:.2f} ms")
    if wire.bits_per_char != 11:
        chars = wire.request_bytes + wire.reply_bytes
        spec = (chars + 2 * wire.reads * 3.5) * 11 / args.baud
        print(f"      at 11 bits per character (8E1, the spec's framing): {spec * ms:.2f} ms")
    print(
        "a pty passes bytes at memory speed whatever its baud rate: on a real line a poll takes about the wire "
        "time plus the measured time"
    )
    print("the machine was shared while this ran (figures vary with its load)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
