#!/usr/bin/env python3
"""The client-side cost of one full poll of a 500-register device over loopback. Prints figures;
asserts nothing.

    python3 bench/poll_bench.py                    # instructions per poll under callgrind, if present
    python3 bench/poll_bench.py --wall             # wall time per poll instead
    python3 bench/poll_bench.py --compare 64420ac  # the Python clients of that revision too

The device: 500 holding registers 0..499, as 300 functions (UINT16 x 0.1, INT16, INT32, FLOAT32,
UINT32 x 0.01 + 5, UINT8 in a full word), read by every client as the same 4 requests of 125
registers. `mdl sim` serves it in its own process; only the client process is measured:

- hand:    a hand-written pymodbus batch: 4 read_holding_registers and a loop decoding every function
           from a precomputed (offset, kind, scale) table (the floor the others are held against);
- naive:   one read_holding_registers per function, no coalescing (what the plan saves);
- py-sync: the generated Python driver's read_all over ModbusTcpClient;
- py-async: the generated Python driver's async read_all over AsyncModbusTcpClient;
- runtime: `mdl read`'s in-process runtime (mdl.device.runtime.Session.read of every function);
- cpp:     the generated C++ driver's read_all over libmodbus (when g++ and libmodbus are there).

With valgrind, each client runs twice under `valgrind --tool=callgrind` (WARM + SHORT and
WARM + LONG polls) and the difference of the instruction counts over LONG - SHORT polls is the
cost of one poll: start-up and imports cancel out. Without valgrind (or with --wall), each client
times its own polls (best of 5 batches of 20) and prints microseconds per poll.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
KINDS = [  # (format, registers, extra elements), cycled until 500 registers are used
    ("UINT16", 1, "<multiplier>0.1</multiplier>"),
    ("INT16", 1, ""),
    ("INT32", 2, ""),
    ("FLOAT32", 2, ""),
    ("UINT32", 2, "<multiplier>0.01</multiplier><offset>5</offset>"),
    ("UINT8", 1, ""),
]
REGISTERS = 500
CLIENTS = ("hand", "naive", "py-sync", "py-async", "runtime", "cpp")


def device_functions() -> list[tuple[str, str, int, int, str]]:
    """(name, format, first address, registers, extra elements) of the bench device."""
    out = []
    address = i = 0
    while address < REGISTERS:
        fmt, size, extra = KINDS[i % len(KINDS)]
        if address + size > REGISTERS:
            fmt, size, extra = KINDS[0]
        out.append((f"v{i}_{fmt.lower()}", fmt, address, size, extra))
        address += size
        i += 1
    return out


def device_xml() -> str:
    out = [
        "<?xml version='1.0' encoding='US-ASCII'?>",
        '<device xmlns="http://www.ornl.gov/ModbusXMLSchema" version="1.0">',
        "  <name>Poll bench device</name>",
        "  <description>500 holding registers</description>",
    ]
    for name, fmt, address, _, extra in device_functions():
        mult = re.search(r"<multiplier>.*?</multiplier>", extra)
        offset = re.search(r"<offset>.*?</offset>", extra)
        out.append(
            f"  <function><name>{name}</name><description>{name}</description><addresses>{address}"
            f"</addresses><format>{fmt}</format>{mult.group(0) if mult else ''}"
            f"{offset.group(0) if offset else ''}<access>read</access></function>"
        )
    out.append("</device>")
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------------------
# the clients (each runs in its own process: `poll_bench.py --client KIND ...`)


def hand_client(host: str, port: int) -> object:
    from pymodbus.client import ModbusTcpClient

    client = ModbusTcpClient(host, port=port)
    client.connect()
    pack16, unpack_f = struct.Struct(">HH").pack, struct.Struct(">f").unpack
    table = []
    for name, fmt, address, _, _ in device_functions():
        scale = {"UINT16": 0.1, "UINT32": 0.01}.get(fmt)
        table.append((name, fmt, address, scale))

    def poll() -> dict[str, object]:
        regs: list[int] = []
        for start in range(0, REGISTERS, 125):
            regs += client.read_holding_registers(start, count=125, device_id=1).registers
        out: dict[str, object] = {}
        for name, fmt, a, scale in table:
            if fmt == "UINT16":
                out[name] = regs[a] * scale
            elif fmt == "INT16":
                r = regs[a]
                out[name] = r - 0x10000 if r & 0x8000 else r
            elif fmt == "INT32":
                v = regs[a] << 16 | regs[a + 1]
                out[name] = v - 0x100000000 if v & 0x80000000 else v
            elif fmt == "FLOAT32":
                out[name] = unpack_f(pack16(regs[a], regs[a + 1]))[0]
            elif fmt == "UINT32":
                out[name] = (regs[a] << 16 | regs[a + 1]) * scale + 5
            else:
                out[name] = regs[a] & 0xFF
        return out

    return poll


def naive_client(host: str, port: int) -> object:
    from pymodbus.client import ModbusTcpClient

    client = ModbusTcpClient(host, port=port)
    client.connect()
    spans = [(name, address, size) for name, _, address, size, _ in device_functions()]

    def poll() -> dict[str, object]:
        return {name: client.read_holding_registers(a, count=n, device_id=1).registers for name, a, n in spans}

    return poll


def _driver(gen_dir: Path) -> object:
    sys.path.insert(0, str(gen_dir))
    import poll_bench_device  # type: ignore[import-not-found]

    return poll_bench_device


def py_sync_client(host: str, port: int, gen_dir: Path) -> object:
    from pymodbus.client import ModbusTcpClient

    module = _driver(gen_dir)
    client = ModbusTcpClient(host, port=port)
    client.connect()
    driver = module.PollBenchDevice(client)
    return driver.read_all


def py_async_client(host: str, port: int, gen_dir: Path) -> object:
    import asyncio

    from pymodbus.client import AsyncModbusTcpClient

    module = _driver(gen_dir)
    loop = asyncio.new_event_loop()

    async def connected() -> object:
        client = AsyncModbusTcpClient(host, port=port)  # made in the loop: pymodbus wants a running one
        await client.connect()
        return module.AsyncPollBenchDevice(client)

    driver = loop.run_until_complete(connected())
    return lambda: loop.run_until_complete(driver.read_all())


def runtime_client(host: str, port: int, xml: Path) -> object:
    from mdl.device.connection import Connection
    from mdl.device.runtime import Session
    from mdl.formats.loading import load_any

    device = load_any(xml)
    session = Session(device, Connection(host=host, port=port), 1)
    session.connect()
    functions = [fn for fn in device.functions if fn.readable]
    return lambda: session.read(functions)


def run_client(args: argparse.Namespace) -> int:
    kind = args.client
    if kind == "hand":
        poll = hand_client(args.host, args.port)
    elif kind == "naive":
        poll = naive_client(args.host, args.port)
    elif kind == "py-sync":
        poll = py_sync_client(args.host, args.port, args.gen_dir)
    elif kind == "py-async":
        poll = py_async_client(args.host, args.port, args.gen_dir)
    else:
        poll = runtime_client(args.host, args.port, args.xml)
    if args.timed:  # wall time: best of 5 batches of `polls`
        for _ in range(args.warm):
            poll()  # type: ignore[operator]
        best = float("inf")
        for _ in range(5):
            start = time.perf_counter()
            for _ in range(args.polls):
                poll()  # type: ignore[operator]
            best = min(best, (time.perf_counter() - start) / args.polls)
        print(f"{best * 1e6:.1f}")
        return 0
    for _ in range(args.warm + args.polls):
        poll()  # type: ignore[operator]
    return 0


CPP_MAIN = r"""
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <chrono>
#include <modbus.h>
#include "poll_bench_device.h"

int main(int argc, char **argv) {
    int port = std::atoi(argv[1]), polls = std::atoi(argv[2]), timed = std::atoi(argv[3]);
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", port);
    if (ctx == nullptr || modbus_set_slave(ctx, 1) != 0 || modbus_connect(ctx) != 0) {
        std::printf("connect failed: %s\n", modbus_strerror(errno));
        return 1;
    }
    PollBenchDevice dev(ctx);
    static PollBenchDeviceValues values;
    double best = 1e30;
    for (int batch = 0; batch < (timed ? 5 : 1); ++batch) {
        auto start = std::chrono::steady_clock::now();
        for (int i = 0; i < polls; ++i) {
            if (dev.read_all(&values) != 0) { std::printf("read failed: %s\n", modbus_strerror(errno)); return 1; }
        }
        double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / polls;
        if (s < best) best = s;
    }
    if (timed) std::printf("%.1f\n", best * 1e6);
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}
"""


def build_cpp(gen_dir: Path) -> Path | None:
    gxx, pkg = shutil.which("g++"), shutil.which("pkg-config")
    if gxx is None or pkg is None or subprocess.run([pkg, "--exists", "libmodbus"]).returncode != 0:
        return None
    flags = subprocess.run([pkg, "--cflags", "--libs", "libmodbus"], capture_output=True, text=True).stdout.split()
    main = gen_dir / "main.cc"
    main.write_text(CPP_MAIN)
    exe = gen_dir / "cpp_client"
    subprocess.run(
        [
            gxx,
            "-std=c++17",
            "-O2",
            "-I",
            str(gen_dir),
            str(main),
            str(gen_dir / "poll_bench_device.cc"),
            "-o",
            str(exe),
            *flags,
        ],
        check=True,
    )
    return exe


# ---------------------------------------------------------------------------------------------
# the driver: start the sim, generate, run each client, print the table


def start_sim(xml: Path) -> tuple[subprocess.Popen[str], str, int]:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "mdl", "sim", str(xml), "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if not line.startswith("mdl sim: serving"):
        proc.kill()
        raise SystemExit(f"mdl sim did not start: {line!r}")
    host, port = line.rsplit(" unit ", 1)[0].rsplit(" on ", 1)[1].rsplit(":", 1)
    return proc, host, int(port)


def callgrind_instructions(cmd: list[str], env: dict[str, str], out: Path) -> int:
    proc = subprocess.run(
        ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *cmd], capture_output=True, text=True, env=env
    )
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed under callgrind: {proc.stderr[-400:]}")
    found = re.search(r"Collected : (\d+)", proc.stderr)
    if found is None:
        raise RuntimeError(f"no instruction count from callgrind: {proc.stderr[-400:]}")
    return int(found.group(1))


def measure(kind: str, cmd: list[str], env: dict[str, str], wall: bool, tmp: Path) -> float:
    """Instructions (millions) or microseconds per poll."""
    warm, short, long = 3, 2, 12
    if wall:
        out = subprocess.run(
            cmd + ["--warm", str(warm), "--polls", "20", "--timed"], capture_output=True, text=True, env=env, check=True
        ).stdout
        return float(out.split()[-1])
    a = callgrind_instructions(cmd + ["--warm", str(warm), "--polls", str(short)], env, tmp / f"{kind}.a")
    b = callgrind_instructions(cmd + ["--warm", str(warm), "--polls", str(long)], env, tmp / f"{kind}.b")
    return (b - a) / (long - short) / 1e6


def generate(src: Path, xml: Path, dest: Path, lang: str) -> None:
    env = dict(os.environ, PYTHONPATH=str(src))
    subprocess.run(
        [sys.executable, "-m", "mdl", "gen", str(xml), "--lang", lang, "-o", str(dest)],
        env=env,
        check=True,
        capture_output=True,
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--wall", action="store_true", help="wall time per poll even where valgrind is present")
    parser.add_argument("--clients", default=",".join(CLIENTS), help="which clients (comma separated)")
    parser.add_argument("--compare", metavar="REV", help="also the Python clients of git revision REV")
    parser.add_argument("--worktree", type=Path, help="where REV is exported (default /tmp/bench_REV)")
    # the client side (internal)
    parser.add_argument("--client", choices=CLIENTS, help=argparse.SUPPRESS)
    parser.add_argument("--host", default="127.0.0.1", help=argparse.SUPPRESS)
    parser.add_argument("--port", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--gen-dir", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--xml", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--warm", type=int, default=3, help=argparse.SUPPRESS)
    parser.add_argument("--polls", type=int, default=10, help=argparse.SUPPRESS)
    parser.add_argument("--timed", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.client:
        return run_client(args)

    wall = args.wall or shutil.which("valgrind") is None
    unit = "us/poll" if wall else "M instr/poll"
    clients = args.clients.split(",")
    trees = [("after", ROOT / "src")]
    if args.compare:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from scale_bench import worktree

        trees.insert(0, ("before", worktree(args.compare, args.worktree or Path(f"/tmp/bench_{args.compare}")) / "src"))
    with tempfile.TemporaryDirectory(prefix="mdl-poll-") as tmp:
        d = Path(tmp)
        xml = d / "poll_bench_device.xml"
        xml.write_text(device_xml())
        sim, host, port = start_sim(xml)
        results: dict[tuple[str, str], float | str] = {}
        try:
            for label, src in trees:
                gen_dir = d / label
                gen_dir.mkdir()
                generate(src, xml, gen_dir, "python")
                env = dict(os.environ, PYTHONPATH=str(src))
                for kind in clients:
                    if kind == "cpp":
                        if label != "after":
                            continue
                        try:
                            generate(src, xml, gen_dir, "cpp")
                            exe = build_cpp(gen_dir)
                        except subprocess.CalledProcessError as exc:
                            results[(label, kind)] = f"build failed ({exc.returncode})"
                            continue
                        if exe is None:
                            results[(label, kind)] = "no g++/libmodbus"
                            continue
                        if wall:
                            out = subprocess.run(
                                [str(exe), str(port), "200", "1"], capture_output=True, text=True, check=True
                            ).stdout
                            results[(label, kind)] = float(out.split()[-1])
                        else:
                            a = callgrind_instructions([str(exe), str(port), "5", "0"], env, d / "cpp.a")
                            b = callgrind_instructions([str(exe), str(port), "25", "0"], env, d / "cpp.b")
                            results[(label, kind)] = (b - a) / 20 / 1e6
                    else:
                        if label != "after" and kind in ("hand", "naive"):
                            continue  # the same code either way
                        cmd = [
                            sys.executable,
                            str(Path(__file__).resolve()),
                            "--client",
                            kind,
                            "--host",
                            host,
                            "--port",
                            str(port),
                            "--gen-dir",
                            str(gen_dir),
                            "--xml",
                            str(xml),
                        ]
                        try:
                            results[(label, kind)] = measure(kind, cmd, env, wall, d)
                        except (RuntimeError, subprocess.CalledProcessError) as exc:
                            print(exc, file=sys.stderr)
                            results[(label, kind)] = "failed"
                    print(f"  [{label}] {kind:9} {results[(label, kind)]}", file=sys.stderr, flush=True)
        finally:
            sim.terminate()
            sim.wait(timeout=20)

    labels = [label for label, _ in trees]
    hand = results.get(("after", "hand"))
    print()
    print(f"client-side cost of one full poll of {REGISTERS} registers ({unit}; x: relative to the hand batch)")
    print(f"{'client':10} " + " ".join(f"{label:>22}" for label in labels))
    for kind in clients:
        cells = []
        for label in labels:
            value = results.get((label, kind), results.get(("after", kind)) if kind in ("hand", "naive") else None)
            if value is None:
                cells.append(f"{'-':>22}")
            elif isinstance(value, str):
                cells.append(f"{value:>22}")
            else:
                ratio = f"({value / hand:5.1f}x)" if isinstance(hand, float) and hand else ""
                cells.append(f"{value:12.3f} {ratio:>9}")
        print(f"{kind:10} " + " ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
