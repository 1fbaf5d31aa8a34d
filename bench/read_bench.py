#!/usr/bin/env python3
"""Reads, poll records and `mdl sim`, each figure beside what it is compared with and the goal it is held
to (issue 40), in one run. Instructions counted by callgrind (valgrind), which a shared machine's load does
not distort; prints figures, asserts nothing.

    python3 bench/read_bench.py                          # reads, records and the sim
    python3 bench/read_bench.py --only reads,records     # or --only sim
    python3 bench/read_bench.py --compare 887531d        # the same figures of a git revision beside
    python3 bench/read_bench.py --rps 3                  # the sim's requests per second (wall) too

Reads: bench/poll_bench.py's device (500 holding registers as 300 functions: UINT16 x 0.1, INT16, INT32,
FLOAT32, UINT32 x 0.01 + 5, UINT8; 4 requests of 125 registers), served by `mdl sim` in its own process with
values a meter shows (`--registers`: scaled readings, float32 of two decimals, an eighth of them 0). Only the
client process is measured: one full poll, as the difference of two callgrind runs of 3 + 2 and 3 + 12 polls
divided by 10 (start-up and imports cancel out). The clients: a hand-written pymodbus batch (the floor the
others are held against), the generated Python driver's read_all (sync, asyncio) and `mdl read`'s runtime
(`Session.read` of every function).

Records: `mdl.device.output.record` of the runtime's values in each --format, as a fraction of the runtime's
read, measured the same way; "steady" the values the sim serves, the same at every poll (what polling a device
whose readings hold gives), "new" other values at every poll (every number printed afresh). Beside them, the
floor: `str` of every value of the poll and nothing else, what any record printing them all pays.

Sim: the server's instructions per request, `mdl sim` against a plain pymodbus server (ModbusTcpServer on a
SimDevice of the same 500 registers, written here), reading 10 or 125 holding registers over 1, 10 and 50
connections at once (each with one request outstanding): the server runs under callgrind twice, answering
SIM_SHORT and SIM_LONG requests; the difference over SIM_LONG - SIM_SHORT is one request. --rps S also runs
each server without valgrind for S seconds per figure: requests per second and the server's CPU per request
(median of 3 runs, the servers in turns; the machine's load moves these).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import selectors
import shutil
import signal
import socket
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from poll_bench import (  # noqa: E402  (bench/ on the path first)
    REGISTERS,
    device_functions,
    device_xml,
    generate,
    hand_client,
    py_async_client,
    py_sync_client,
)

READ_CLIENTS = ("hand", "py-sync", "py-async", "runtime")
READ_GOALS = {"py-sync": 1.1, "py-async": 1.25, "runtime": 1.1}  # at most, x the hand batch
FORMATS = ("json", "csv", "table", "senml")
# not a format: Python's own text of every value (`str`), which any record of them must make at least: the floor
FLOOR = "str"
RECORD_GOAL = 0.3  # at most, x the runtime's read
SIM_GOAL = 1.0  # at most, x the plain server's instructions per request
WARM, SHORT, LONG = 3, 2, 12  # polls
SIM_SHORT, SIM_LONG = 100, 500  # requests
SERVERS = ("plain", "mdl sim")


# ---------------------------------------------------------------------------------------------
# the device's values


def registers(seed: int = 40) -> list[int]:
    """500 holding registers as a meter's readings (see the module docstring)."""
    rng = random.Random(seed)
    regs = [0] * REGISTERS
    for i, (_, fmt, address, size, _) in enumerate(device_functions()):
        if i % 8 == 7:
            words = [0] * size
        elif fmt == "UINT16":
            words = [rng.randrange(5000)]  # 0.0 .. 499.9
        elif fmt == "INT16":
            words = [rng.randrange(-2000, 2000) & 0xFFFF]
        elif fmt in ("INT32", "FLOAT32", "UINT32"):
            if fmt == "INT32":
                v = rng.randrange(-(10**6), 10**6) & 0xFFFFFFFF
            elif fmt == "FLOAT32":
                v = int.from_bytes(struct.pack(">f", round(rng.uniform(-500, 500), 2)), "big")
            else:
                v = rng.randrange(10**7)
            words = [v >> 16, v & 0xFFFF]
        else:
            words = [rng.randrange(256)]
        regs[address : address + size] = words
    return regs


def registers_json(regs: list[int]) -> str:
    return json.dumps({"holding": {str(a): v for a, v in enumerate(regs)}})


# ---------------------------------------------------------------------------------------------
# the client side (each runs in its own process: `read_bench.py --client KIND ...`)


def runtime_session(host: str, port: int, xml: Path) -> tuple[Any, list[Any], Any]:
    from mdl.device.connection import Connection
    from mdl.device.runtime import Session
    from mdl.formats.loading import load_resolved

    resolved = load_resolved(xml)
    session = Session(resolved, Connection(host=host, port=port), 1)
    session.connect()
    return session, [fn for fn in resolved.device.functions if fn.readable], resolved


def record_client(host: str, port: int, xml: Path, fmt: str, fresh: bool) -> Callable[[], object]:
    """One record per call, of the values read once (steady) or of other values at each call (fresh: decoded
    by the runtime from other registers, WARM + LONG sets made before the first call either way)."""
    from datetime import datetime, timezone

    from mdl.device import output
    from mdl.device.evaluate import evaluate

    session, functions, resolved = runtime_session(host, port, xml)
    sets = [session.read(functions)]
    if fresh:
        names = [fn.name for fn in functions]
        sets = []
        for seed in range(WARM + LONG):
            regs = registers(1000 + seed)
            sets.append(evaluate(resolved, names, lambda table, address, regs=regs: regs[address]))
    name = resolved.device.name
    turn = iter(range(10**9))

    if fmt == FLOOR:

        def floor() -> object:
            return list(map(str, sets[next(turn) % len(sets)].values()))

        return floor

    def poll() -> str:
        return output.record(functions, sets[next(turn) % len(sets)], fmt, datetime.now(timezone.utc), name)

    return poll


def run_client(args: argparse.Namespace) -> int:
    kind = args.client
    poll: Any
    if kind == "hand":
        poll = hand_client(args.host, args.port)
    elif kind == "py-sync":
        poll = py_sync_client(args.host, args.port, args.gen_dir)
    elif kind == "py-async":
        poll = py_async_client(args.host, args.port, args.gen_dir)
    elif kind == "runtime":
        session, functions, _ = runtime_session(args.host, args.port, args.xml)

        def poll() -> object:
            return session.read(functions)
    else:  # record:FMT:steady|new
        _, fmt, values = kind.split(":")
        poll = record_client(args.host, args.port, args.xml, fmt, values == "new")
    for _ in range(args.warm + args.polls):
        poll()
    return 0


# ---------------------------------------------------------------------------------------------
# the plain pymodbus server (`read_bench.py --serve-plain REGISTERS.json`)


def serve_plain(values_file: Path) -> int:
    import asyncio

    from pymodbus.server import ModbusTcpServer
    from pymodbus.simulator import DataType, SimData, SimDevice

    holding = json.loads(values_file.read_text())["holding"]
    values = [holding[str(a)] for a in range(REGISTERS)]

    async def main() -> None:
        device = SimDevice(id=1, simdata=[SimData(0, values=values, datatype=DataType.REGISTERS)])
        server = ModbusTcpServer(context=device, address=("127.0.0.1", 0))
        await server.serve_forever(background=True)
        port = server.transport.sockets[0].getsockname()[1]  # type: ignore[union-attr]
        print(f"plain: serving on 127.0.0.1:{port}", flush=True)
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        await stop.wait()
        await server.shutdown()

    asyncio.run(main())
    return 0


# ---------------------------------------------------------------------------------------------
# the load on a server: `connections` clients, each with one request outstanding


def load(host: str, port: int, connections: int, count: int, total: int | None, seconds: float | None) -> int:
    """Replies received (each checked: function 3, `count` registers), after `total` replies or `seconds`."""
    pdu = bytes([3, 0, 0, count >> 8, count & 0xFF])
    reply_size = 9 + 2 * count
    sel = selectors.DefaultSelector()
    socks = []
    for _ in range(connections):
        sock = socket.create_connection((host, port), timeout=60)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.setblocking(False)
        socks.append(sock)
        sel.register(sock, selectors.EVENT_READ, [b"", 1])
    sent = done = 0
    deadline = time.monotonic() + seconds if seconds is not None else None

    def more() -> bool:
        return (total is None or sent < total) and (deadline is None or time.monotonic() < deadline)

    def send(sock: socket.socket, tid: int) -> None:
        sock.sendall(struct.pack(">HHHB", tid, 0, len(pdu) + 1, 1) + pdu)

    for sock in socks:
        if more():
            send(sock, 1)
            sent += 1
    while done < sent:
        for key, _ in sel.select(timeout=60):
            sock, state = key.fileobj, key.data
            chunk = sock.recv(65536)  # type: ignore[union-attr]
            if not chunk:
                raise SystemExit("the server closed a connection")
            state[0] += chunk
            while len(state[0]) >= reply_size:
                reply, state[0] = state[0][:reply_size], state[0][reply_size:]
                if reply[7] != 3 or reply[8] != 2 * count:
                    raise SystemExit(f"unexpected reply {reply[:9].hex(' ')}")
                done += 1
                if more():
                    state[1] = state[1] % 65000 + 1
                    send(sock, state[1])  # type: ignore[arg-type]
                    sent += 1
    for sock in socks:
        sel.unregister(sock)
        sock.close()
    return done


def start_server(cmd: list[str], env: dict[str, str], ready: str) -> tuple[subprocess.Popen[str], str, int]:
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None and proc.stderr is not None
    line = proc.stdout.readline()
    if ready not in line:
        proc.kill()
        raise SystemExit(f"{' '.join(cmd[:6])} did not start: {line!r} {proc.stderr.read()[-500:]}")
    host, port = line.split(" on ", 1)[1].split()[0].rsplit(":", 1)
    return proc, host, int(port)


def stop_server(proc: subprocess.Popen[str]) -> str:
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=300)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return err


def collected(err: str) -> int:
    found = re.search(r"Collected : (\d+)", err)
    if found is None:
        raise RuntimeError(f"no instruction count from callgrind: {err[-600:]}")
    return int(found.group(1))


def server_cmd(server: str, xml: Path, values: Path) -> tuple[list[str], str]:
    """The command serving the device, and the start of its ready line."""
    if server == "plain":
        return [sys.executable, str(Path(__file__).resolve()), "--serve-plain", str(values)], "plain: serving"
    return [sys.executable, "-m", "mdl", "sim", str(xml), "--port", "0", "--registers", str(values)], "mdl sim: serving"


def sim_instructions(cmd: list[str], ready: str, env: dict[str, str], connections: int, count: int) -> float:
    """Server instructions per request (callgrind; the difference of SIM_LONG and SIM_SHORT requests)."""
    runs = []
    for total in (SIM_SHORT, SIM_LONG):
        grind = ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null"]
        proc, host, port = start_server([*grind, *cmd], env, ready)
        try:
            load(host, port, connections, count, total, None)
        finally:
            err = stop_server(proc)
        runs.append(collected(err))
    return (runs[1] - runs[0]) / (SIM_LONG - SIM_SHORT)


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def sim_rps(
    cmd: list[str], ready: str, env: dict[str, str], connections: int, count: int, seconds: float
) -> tuple[float, float]:
    """(requests per second, the server's CPU microseconds per request) of one timed run."""
    proc, host, port = start_server(cmd, env, ready)
    try:
        load(host, port, connections, count, 200, None)  # warm
        cpu, start = cpu_seconds(proc.pid), time.perf_counter()
        done = load(host, port, connections, count, None, seconds)
        wall, cpu = time.perf_counter() - start, cpu_seconds(proc.pid) - cpu
    finally:
        stop_server(proc)
    return done / wall, cpu / done * 1e6


# ---------------------------------------------------------------------------------------------
# the driver


def client_instructions(cmd: list[str], env: dict[str, str]) -> float:
    """Millions of instructions per poll (the difference of WARM + LONG and WARM + SHORT polls)."""
    counts = []
    for polls in (SHORT, LONG):
        grind = ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null"]
        proc = subprocess.run(
            [*grind, *cmd, "--warm", str(WARM), "--polls", str(polls)], capture_output=True, text=True, env=env
        )
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd[:4])} failed under callgrind: {proc.stderr[-600:]}")
        counts.append(collected(proc.stderr))
    return (counts[1] - counts[0]) / (LONG - SHORT) / 1e6


def mdl_env(src: Path) -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(src), PYTHONHASHSEED="0")  # the same dict layouts in every run


def reads_and_records(
    trees: list[tuple[str, Path]], d: Path, xml: Path, values: Path, parts: set[str]
) -> dict[tuple[str, str], float | str]:
    results: dict[tuple[str, str], float | str] = {}
    for label, src in trees:
        env = mdl_env(src)
        cmd, ready = server_cmd("mdl sim", xml, values)
        sim, host, port = start_server(cmd, env, ready)
        try:
            gen_dir = d / f"gen-{label}"
            gen_dir.mkdir()
            generate(src, xml, gen_dir, "python")
            kinds = [*READ_CLIENTS] if "reads" in parts else ["runtime"]
            if "records" in parts:
                kinds += [f"record:{fmt}:{v}" for v in ("steady", "new") for fmt in (*FORMATS, FLOOR)]
            for kind in kinds:
                if label != "after" and kind == "hand":
                    continue  # the same code either way
                me = str(Path(__file__).resolve())
                cmd = [sys.executable, me, "--client", kind, "--host", host, "--port", str(port)]
                cmd += ["--gen-dir", str(gen_dir), "--xml", str(xml)]
                try:
                    results[(label, kind)] = client_instructions(cmd, env)
                except RuntimeError as exc:
                    print(exc, file=sys.stderr)
                    results[(label, kind)] = "failed"
                print(f"  [{label}] {kind:20} {results[(label, kind)]}", file=sys.stderr, flush=True)
        finally:
            stop_server(sim)
    return results


def sim_figures(
    trees: list[tuple[str, Path]], xml: Path, values: Path, conns: list[int], counts: list[int], rps: float | None
) -> dict[tuple[Any, ...], Any]:
    runs = [(label, src, server) for label, src in trees for server in SERVERS if label == "after" or server != "plain"]
    results: dict[tuple[Any, ...], Any] = {}
    for label, src, server in runs:
        cmd, ready = server_cmd(server, xml, values)
        for count in counts:
            for n in conns:
                value = results[(label, server, n, count)] = sim_instructions(cmd, ready, mdl_env(src), n, count)
                say = f"  [{label}] {server:8} {n:3} conn {count:4} regs {value / 1e6:.3f} M"
                print(say, file=sys.stderr, flush=True)
    if rps:
        for count in counts:
            for n in conns:
                timed: dict[tuple[str, str], list[tuple[float, float]]] = {}
                for _ in range(3):  # the servers in turns: the machine's load moves
                    for label, src, server in runs:
                        cmd, ready = server_cmd(server, xml, values)
                        got = sim_rps(cmd, ready, mdl_env(src), n, count, rps)
                        timed.setdefault((label, server), []).append(got)
                for (label, server), got_runs in timed.items():
                    median = (statistics.median(r for r, _ in got_runs), statistics.median(c for _, c in got_runs))
                    results[(label, server, n, count, "rps")] = median
                    say = f"  [{label}] {server:8} {n:3} conn {count:4} regs {median[0]:.0f}/s {median[1]:.0f} us"
                    print(say, file=sys.stderr, flush=True)
    return results


def cell(value: object, base: object, goal: float | None, width: int = 24) -> str:
    if value is None:
        return f"{'-':>{width}}"
    if isinstance(value, str):
        return f"{value:>{width}}"
    assert isinstance(value, float)
    if value <= 0:  # the longer run counted fewer instructions: something else changed between the two runs
        text = f"not measured ({value:.3f})"
        return f"{text:>{width}}"
    ratio = value / base if isinstance(base, float) and base else None
    mark = "" if ratio is None or goal is None else (" ok" if ratio <= goal else " NO")
    text = f"{value:.3f}" + (f" ({ratio:.2f}x{mark})" if ratio is not None else "")
    return f"{text:>{width}}"


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", default="reads,records,sim", help="parts: reads, records, sim (comma separated)")
    parser.add_argument("--compare", metavar="REV", help="also the figures of git revision REV (exported once)")
    parser.add_argument("--worktree", type=Path, help="where REV is exported (default /tmp/bench_REV)")
    parser.add_argument("--connections", default="1,10,50", help="the sim's concurrent connections")
    parser.add_argument("--registers", default="10,125", help="registers per request to the sim")
    parser.add_argument("--rps", type=float, metavar="S", help="also time each server for S seconds per figure")
    # internal
    parser.add_argument("--client", help=argparse.SUPPRESS)
    parser.add_argument("--serve-plain", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--host", default="127.0.0.1", help=argparse.SUPPRESS)
    parser.add_argument("--port", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--gen-dir", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--xml", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--warm", type=int, default=WARM, help=argparse.SUPPRESS)
    parser.add_argument("--polls", type=int, default=10, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.client:
        return run_client(args)
    if args.serve_plain:
        return serve_plain(args.serve_plain)
    if shutil.which("valgrind") is None:
        raise SystemExit("read_bench.py counts instructions with valgrind (callgrind): install valgrind")

    parts = set(args.only.split(","))
    conns = [int(c) for c in args.connections.split(",")]
    counts = [int(c) for c in args.registers.split(",")]
    trees = [("after", ROOT / "src")]
    if args.compare:
        from scale_bench import worktree

        where = args.worktree or Path(f"/tmp/bench_{args.compare}")
        trees.insert(0, ("before", worktree(args.compare, where) / "src"))
    labels = [label for label, _ in trees]
    print(f"read_bench.py: {time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} CPUs; uptime: {uptime()}")
    with tempfile.TemporaryDirectory(prefix="mdl-read-") as tmp:
        d = Path(tmp)
        xml = d / "poll_bench_device.xml"
        xml.write_text(device_xml())
        values = d / "registers.json"
        values.write_text(registers_json(registers()))
        reads = reads_and_records(trees, d, xml, values, parts) if parts & {"reads", "records"} else {}
        sims = sim_figures(trees, xml, values, conns, counts, args.rps) if "sim" in parts else {}

    head = f"{'':28}" + "".join(f"{label:>24}" for label in labels) + "   goal"
    if "reads" in parts:
        hand = reads.get(("after", "hand"))
        print()
        print(f"One full poll of {REGISTERS} registers, client side (M instructions; x the hand batch)")
        print(head)
        for kind in READ_CLIENTS:
            goal = READ_GOALS.get(kind)
            cells = "".join(cell(reads.get((label, kind), reads.get(("after", kind))), hand, goal) for label in labels)
            print(f"{kind:28}{cells}   {f'<= {goal:.2f}x' if goal else '(the floor)'}")
    if "records" in parts:
        print()
        print("A poll's record, mdl.device.output.record (M instructions; x the runtime's read of the same tree)")
        print(head)
        for values_kind in ("steady", "new"):
            for fmt in (*FORMATS, FLOOR):
                kind = f"record:{fmt}:{values_kind}"
                read = {label: reads.get((label, "runtime")) for label in labels}
                goal = None if fmt == FLOOR else RECORD_GOAL
                cells = "".join(cell(reads.get((label, kind)), read[label], goal) for label in labels)
                title = f"{fmt} ({values_kind} values)" if goal else f"floor: str of each ({values_kind})"
                print(f"{title:28}{cells}   {f'<= {goal}x' if goal else ''}")
    if "sim" in parts:
        print()
        print("mdl sim, the server's instructions per request (M; x the plain pymodbus server)")
        print(
            f"{'connections, registers':28}{'plain':>24}" + "".join(f"{'mdl sim ' + x:>24}" for x in labels) + "   goal"
        )
        for count in counts:
            for n in conns:
                plain = sims[("after", "plain", n, count)] / 1e6
                row = cell(plain, None, None)
                row += "".join(cell(sims[(label, "mdl sim", n, count)] / 1e6, plain, SIM_GOAL) for label in labels)
                print(f"{f'{n:>3} conn, {count:>3} registers':28}{row}   <= {SIM_GOAL}x")
        if args.rps:
            print()
            print(
                "mdl sim, wall: requests per second (x the plain server; goal >= 1.0x) and the server's CPU us per"
                f" request (x plain; goal <= 1.0x); median of 3 runs of {args.rps:g} s"
            )
            for count in counts:
                for n in conns:
                    plain_rps, plain_cpu = sims[("after", "plain", n, count, "rps")]
                    row = f"plain {plain_rps:6.0f}/s {plain_cpu:5.0f} us"
                    for label in labels:
                        r, c = sims[(label, "mdl sim", n, count, "rps")]
                        row += f"   {label}: {r:6.0f}/s ({r / plain_rps:.2f}x) {c:5.0f} us ({c / plain_cpu:.2f}x)"
                    print(f"{f'{n:>3} conn, {count:>3} registers':28}{row}")
    print()
    print(f"uptime at the end: {uptime()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
