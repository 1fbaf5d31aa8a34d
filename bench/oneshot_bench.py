#!/usr/bin/env python3
"""One-shot commands, what a user feels (issue 40): `mdl --help`, `mdl read --raw`, `mdl read FILE` and
`mdl write FILE NAME=V`, each run once as its own process, beside `import pymodbus`, `import pymodbus.client`,
a plain pymodbus script reading 4 holding registers, the libraries a read imports (pymodbus's client, click,
pathlib; lxml for a description), and mbpoll / modbus-cli when installed. In one run:

    python3 bench/oneshot_bench.py                    # callgrind instructions and wall, 11 runs each
    python3 bench/oneshot_bench.py --runs 31          # a steadier median
    python3 bench/oneshot_bench.py --pycache tree     # the tree's __pycache__ (default: a temporary prefix)

Instructions: each command's whole process under callgrind (`valgrind --tool=callgrind
--callgrind-out-file=/dev/null`, the "Collected" figure of its stderr), once; the machine's load does not move
them. Wall: the median of --runs runs of each command, the commands in turns (so the load falls on each alike),
the load average printed before and after; only a quiet machine's figures say anything of the 0.15 s goal.

Bytecode is warmed first: one unmeasured run of each command. Python writes and reads it under
PYTHONPYCACHEPREFIX in the bench's temporary folder (--pycache temp, the default: every module, the standard
library's too, compiled once for the run, nothing left in the tree) or in the tree's and the installed packages'
__pycache__ folders (--pycache tree, what an installed `mdl` uses). PYTHONHASHSEED=0 in every process.

The device is `mdl sim` (FILE, default examples/temco_tstat/temco_tstat.xml) on 127.0.0.1, --port 0, started
once for the whole run. The goals: `mdl read` / `mdl write` at most 1.3x `import pymodbus.client` in
instructions and under 0.15 s wall; `mdl --help` at most 1.1x `import pymodbus` in instructions. Prints figures,
asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from read_bench import collected, start_server, stop_server  # noqa: E402  (bench/ on the path first)

DEFAULT_XML = ROOT / "examples" / "temco_tstat" / "temco_tstat.xml"
GRIND = ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null"]
READ_GOAL = 1.3  # at most, x `import pymodbus.client` (instructions)
HELP_GOAL = 1.1  # at most, x `import pymodbus` (instructions)
WALL_GOAL = 0.15  # seconds, under

CLI_LIBRARIES = "import pymodbus.client, click, pathlib"
LIBRARIES = CLI_LIBRARIES + ", lxml.etree"  # and a description's XML reader
PLAIN = """
import sys
from pymodbus.client import ModbusTcpClient
client = ModbusTcpClient(sys.argv[1], port=int(sys.argv[2]))
client.connect()
reply = client.read_holding_registers(0, count=4, device_id=1)
print(reply.registers)
client.close()
"""


@dataclass
class Case:
    label: str
    argv: list[str]
    base: str | None = None  # the label of the case compared with
    goal: float | None = None  # at most, x base (instructions)
    wall_goal: float | None = None  # seconds, under
    absent: str | None = None  # why it is not run


def cases(host: str, port: int, xml: Path, write: str) -> list[Case]:
    py = sys.executable
    mdl = [py, "-m", "mdl"]
    at = ["--host", host, "--port", str(port)]
    found = [
        Case("python -c pass", [py, "-c", "pass"]),
        Case("import pymodbus", [py, "-c", "import pymodbus"]),
        Case("import pymodbus.client", [py, "-c", "import pymodbus.client"]),
        Case("plain pymodbus, 4 hr", [py, "-c", PLAIN, host, str(port)], base="import pymodbus.client"),
        # the libraries a read imports before any of mdl's work: the floor under mdl's own share
        Case("import pymodbus.client, click", [py, "-c", CLI_LIBRARIES], "import pymodbus.client"),  # and pathlib
        Case("... and lxml.etree", [py, "-c", LIBRARIES], "import pymodbus.client"),
        Case("mdl --help", [*mdl, "--help"], base="import pymodbus", goal=HELP_GOAL),
        Case("mdl read --raw hr:0-3", [*mdl, "read", *at, "--raw", "hr:0-3"], "import pymodbus.client", READ_GOAL),
        Case("mdl read FILE", [*mdl, "read", str(xml), *at], "import pymodbus.client", READ_GOAL),
        Case("mdl write FILE " + write, [*mdl, "write", str(xml), write, *at], "import pymodbus.client", READ_GOAL),
    ]
    for case in found:
        if case.label.startswith("mdl ") and case.label != "mdl --help":
            case.wall_goal = WALL_GOAL
    mbpoll = shutil.which("mbpoll")
    argv = [mbpoll or "mbpoll", "-m", "tcp", "-a", "1", "-0", "-r", "0", "-c", "4", "-t", "4", "-1"]
    argv += ["-p", str(port), host]
    found.append(Case("mbpoll, 4 hr", argv, absent=None if mbpoll else "not installed"))
    modbus = shutil.which("modbus")  # favalex/modbus-cli (pip install modbus_cli)
    argv = [modbus or "modbus", f"{host}:{port}", "h@0/4H"]
    found.append(Case("modbus-cli, 4 hr", argv, absent=None if modbus else "not installed"))
    return found


def run(argv: list[str], env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=600)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[-6:])} exited {proc.returncode}: {proc.stderr[-600:]}")
    return proc


def instructions(case: Case, env: dict[str, str]) -> float | str:
    """Millions of instructions of the whole process (one callgrind run)."""
    try:
        return collected(run([*GRIND, *case.argv], env).stderr) / 1e6
    except RuntimeError as exc:
        print(exc, file=sys.stderr)
        return "failed"


def walls(found: list[Case], env: dict[str, str], runs: int) -> dict[str, float | str]:
    """The median wall seconds of each case, the cases in turns."""
    times: dict[str, list[float]] = {case.label: [] for case in found}
    failed: set[str] = set()
    for _ in range(runs):
        for case in found:
            if case.label in failed:
                continue
            start = time.perf_counter()
            try:
                run(case.argv, env)
            except RuntimeError as exc:
                print(exc, file=sys.stderr)
                failed.add(case.label)
                continue
            times[case.label].append(time.perf_counter() - start)
    return {label: "failed" if label in failed else statistics.median(t) for label, t in times.items()}


def load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"{one:.2f}, {five:.2f}, {fifteen:.2f}"


def ratio_cell(value: float | str | None, base: float | str | None, goal: float | None) -> str:
    if not isinstance(value, float) or not isinstance(base, float):
        return ""
    ratio = value / base
    if goal is None:
        return f"{ratio:.2f}x"
    return f"{ratio:.2f}x (<= {goal}x {'ok' if ratio <= goal else 'not met'})"


def wall_cell(value: float | str | None, goal: float | None) -> str:
    if not isinstance(value, float):
        return ""
    return "" if goal is None else f"< {goal} s {'ok' if value < goal else 'not met'}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=11, metavar="N", help="wall: the median of N runs (default 11)")
    parser.add_argument("--xml", type=Path, default=DEFAULT_XML, help="the description served, read and written")
    parser.add_argument("--write", default="fan_speed=1", metavar="NAME=V", help="what `mdl write` writes")
    parser.add_argument(
        "--pycache",
        choices=("temp", "tree"),
        default="temp",
        help="bytecode under the run's temporary folder or in the tree's __pycache__ (default temp)",
    )
    parser.add_argument("--no-callgrind", action="store_true", help="wall times only")
    args = parser.parse_args()
    grind = not args.no_callgrind
    if grind and shutil.which("valgrind") is None:
        raise SystemExit("oneshot_bench.py counts instructions with valgrind (callgrind): install valgrind")

    when = time.strftime("%Y-%m-%d %H:%M")
    print(f"oneshot_bench.py: {when}, {os.cpu_count()} CPUs, Python {sys.version.split()[0]}")
    print(f"load average before: {load()}")
    with tempfile.TemporaryDirectory(prefix="mdl-oneshot-") as tmp:
        env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), PYTHONHASHSEED="0")
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        if args.pycache == "temp":
            env["PYTHONPYCACHEPREFIX"] = str(Path(tmp) / "pycache")
            where = f"bytecode under PYTHONPYCACHEPREFIX={env['PYTHONPYCACHEPREFIX']} (the run's temporary folder)"
        else:
            env.pop("PYTHONPYCACHEPREFIX", None)
            where = "bytecode in the tree's and the packages' __pycache__ folders"
        print(where)
        serve = [sys.executable, "-m", "mdl", "sim", str(args.xml), "--port", "0"]
        sim, host, port = start_server(serve, env, "mdl sim: serving")
        try:
            found = cases(host, port, args.xml, args.write)
            present = [case for case in found if case.absent is None]
            for case in present:  # warm the bytecode: one unmeasured run each
                try:
                    run(case.argv, env)
                except RuntimeError as exc:
                    print(exc, file=sys.stderr)
            counts: dict[str, float | str] = {}
            if grind:
                for case in present:
                    counts[case.label] = instructions(case, env)
                    print(f"  {case.label:32} {counts[case.label]} M", file=sys.stderr, flush=True)
            wall = walls(present, env, args.runs)
        finally:
            stop_server(sim)

    print(f"device: mdl sim {args.xml.relative_to(ROOT) if args.xml.is_relative_to(ROOT) else args.xml} on {host}")
    print()
    head = f"{'command':34}{'M instructions':>16}  {'x the comparison (goal)':50}{'wall s':>8}  goal"
    print(f"Each command once as its own process; wall the median of {args.runs} runs")
    print(head)
    for case in found:
        if case.absent:
            print(f"{case.label:34}{case.absent:>16}")
            continue
        count = counts.get(case.label)
        text = f"{count:.1f}" if isinstance(count, float) else (count or "-")
        base = f"x {case.base}: " if case.base and isinstance(count, float) else ""
        ratio = base + ratio_cell(count, counts.get(case.base or ""), case.goal)
        w = wall.get(case.label)
        wtext = f"{w:.3f}" if isinstance(w, float) else str(w)
        print(f"{case.label:34}{text:>16}  {ratio:50}{wtext:>8}  {wall_cell(w, case.wall_goal)}")
    print()
    print(f"load average after: {load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
