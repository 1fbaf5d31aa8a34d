#!/usr/bin/env python3
"""How long the generated drivers take to compile, and what a poll's record costs beside the read.
Prints figures; asserts nothing.

    python3 bench/compile_bench.py                          # 1,000 / 3,000 / 10,000 mixed functions
    python3 bench/compile_bench.py --sizes 10000 --compare badbc54
    python3 bench/compile_bench.py --no-compile --gen-sizes 10000,30000

The *mixed* device is what a large building controller or gateway description holds: blocks of
functions (each with a block_label) cycling through scaled integers (UINT16 x 0.1, INT16 x 0.5 - 40,
INT32 x 0.01), floats (FLOAT32 in both byte orders, FLOAT64), enumerations (`values`), bounds
(`minimum`/`maximum` on writable ones), a 32-bit counter with `not_implemented`, coils and a text,
over the holding, input and coil tables, with a hole every 37 functions.

For each size it times, each in a child process (wall time, CPU time and peak memory as
bench/scale_bench.py does): `mdl gen FILE --lang all`, then `gcc -std=c99 -O2 -c` of the C driver
and `g++ -std=c++17 -O2 -c` of the C++ one, one compile at a time under `nice -n 10`. With
--record (the default) it also serves bench/poll_bench.py's 300-function device with `mdl sim` and
times, per poll, the read of `mdl read --interval` (`Session.read`) and the record it prints in each
--format (`mdl.device.output.record`), side by side (record_cost).

--compare REV runs the same figures with the mdl of git revision REV (exported once with `git
archive` into /tmp/bench_<REV>, as scale_bench does) and prints before and after side by side.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from scale_bench import WIDTH, Run, fmt, mdl_env, measure, modbus_cflags, worktree  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
ENUM = (
    "<values><value key='0'>Off</value><value key='1'>Auto</value><value key='2'>Manual</value>"
    "<value key='3'>Fault</value></values>"
)
# (table, format, registers, elements in schema order after format/block_label) for the mixed device
MIXED_KINDS: list[tuple[str, str, int, str]] = [
    ("holding", "UINT16", 1, "<multiplier>0.1</multiplier><minimum>0</minimum><maximum>500</maximum>"),
    ("input", "INT16", 1, "<multiplier>0.5</multiplier><register_type>input</register_type><offset>-40</offset>"),
    ("holding", "FLOAT32", 2, "<minimum>-1000</minimum><maximum>1000</maximum>"),
    ("holding", "UINT16", 1, ENUM),
    ("input", "INT32", 2, "<multiplier>0.01</multiplier><register_type>input</register_type>"),
    ("holding", "FLOAT32", 2, "<byte_order>little</byte_order><word_order>little</word_order>"),
    ("coil", "BIT", 1, "<register_type>coil</register_type>"),
    (
        "input",
        "UINT32",
        2,
        "<register_type>input</register_type><not_implemented>0xFFFFFFFF</not_implemented>",
    ),
    ("holding", "INT16", 1, "<minimum>-100</minimum><maximum>100</maximum>"),
    ("input", "FLOAT64", 4, "<register_type>input</register_type><word_order>little</word_order>"),
    ("holding", "UINT16", 1, "<multiplier>0.1</multiplier><offset>-50</offset>"),
    ("holding", "STRING", 4, ""),
]
BLOCK = 64  # functions per block label


def mixed_xml(n: int) -> str:
    """An MDL 1.0 document of n mixed functions (see the module docstring)."""
    next_address = {"holding": 0, "input": 0, "coil": 0}
    out = [
        "<?xml version='1.0' encoding='US-ASCII'?>",
        '<device xmlns="http://www.ornl.gov/ModbusXMLSchema" version="1.0">',
        f"  <name>Mixed {n}</name>",
        f"  <description>{n} synthetic functions of a building controller</description>",
    ]
    for i in range(n):
        table, fmt_, size, extra = MIXED_KINDS[i % len(MIXED_KINDS)]
        if i % 37 == 36:
            next_address[table] += 3
        address = next_address[table]
        next_address[table] += size
        count = "<count>4</count>" if fmt_ == "STRING" else ""
        out.append(
            f"  <function><name>f{i}_{fmt_.lower()}</name><description>function {i}</description>"
            f"<addresses>{address}</addresses>{count}<format>{fmt_}</format>"
            f"<block_label>zone{i // BLOCK}</block_label>{extra}</function>"
        )
    assert max(next_address.values()) <= 65536, next_address
    out.append("</device>")
    return "\n".join(out) + "\n"


def compile_one(compiler: str, std: str, source: Path, include: Path) -> Run:
    """`nice -n 10 <compiler> -std=<std> -O2 -c source`: the wall/CPU time and peak memory of the compiler."""
    exe = shutil.which(compiler)
    if exe is None:
        return Run(0, 0, False, f"no {compiler}")
    return measure(
        [
            "nice",
            "-n",
            "10",
            exe,
            f"-std={std}",
            "-O2",
            "-c",
            "-I",
            str(include),
            *modbus_cflags(),
            str(source),
            "-o",
            str(source.with_suffix(".o")),
        ]
    )


def bench_tree(label: str, src: Path, files: dict[int, Path], sizes: list[int], out: Path, compile_: bool) -> dict:
    env = mdl_env(src)
    results: dict[tuple[int, str], Run] = {}
    for size in sizes:
        dest = out / f"{label}-{size}"
        gen = measure([sys.executable, "-m", "mdl", "gen", str(files[size]), "--lang", "all", "-o", str(dest)], env)
        results[(size, "gen all")] = gen
        print(f"  [{label}] {size:>6} gen --lang all  {fmt(gen)}", file=sys.stderr, flush=True)
        if not gen.ok or not compile_:
            continue
        for compiler, std, ext, key in (("gcc", "c99", "c", "gcc -O2 -c"), ("g++", "c++17", "cc", "g++ -O2 -c")):
            sources = sorted(dest.glob(f"*.{ext}"))
            run = compile_one(compiler, std, sources[0], dest) if sources else Run(0, 0, False, "no source")
            results[(size, key)] = run
            print(
                f"  [{label}] {size:>6} {key:14}  {fmt(run)}" + ("" if run.ok else f"  FAILED: {run.note}"),
                file=sys.stderr,
                flush=True,
            )
    return results


RECORD_CHILD = r"""
import sys, time
from datetime import datetime, timezone
from pathlib import Path
sys.path.insert(0, sys.argv[2])
from poll_bench import device_xml, start_sim
from mdl.device import output
from mdl.device.connection import Connection
from mdl.device.runtime import Session
from mdl.formats.loading import load_resolved

xml = Path(sys.argv[1])
xml.write_text(device_xml())
proc, host, port = start_sim(xml)
try:
    resolved = load_resolved(xml)
    functions = [fn for fn in resolved.device.functions if fn.readable]
    session = Session(resolved, Connection(host=host, port=port), 1)
    session.connect()
    for _ in range(5):
        values = session.read(functions)
    n = int(sys.argv[3])
    best = {}
    for _ in range(3):
        start = time.process_time()
        for _ in range(n):
            values = session.read(functions)
        best["none"] = min(best.get("none", 1e9), (time.process_time() - start) / n)
        for fmt in ("json", "csv", "table", "senml"):
            when = datetime.now(timezone.utc)
            start = time.process_time()
            for _ in range(n):
                output.record(functions, values, fmt, when, resolved.device.name)
            best[fmt] = min(best.get(fmt, 1e9), (time.process_time() - start) / n)
    for key, value in best.items():
        print(f"record:{key} {value:.6f}")
finally:
    proc.kill()
"""


def record_cost(src: Path, polls: int = 100) -> dict[str, float]:
    """CPU seconds per poll of bench/poll_bench.py's device (300 functions, 4 requests, served by `mdl
    sim`): `Session.read` of every function (what `mdl read --interval` does each poll: "none") and
    `mdl.device.output.record` of its values in each --format (the record a poll prints), in one
    child process with that mdl; best of 3 rounds of `polls`."""
    with tempfile.TemporaryDirectory(prefix="mdl-record-") as tmp:
        done = subprocess.run(
            [sys.executable, "-c", RECORD_CHILD, str(Path(tmp) / "poll.xml"), str(ROOT / "bench"), str(polls)],
            capture_output=True,
            text=True,
            env=mdl_env(src),
        )
    figures: dict[str, float] = {}
    for line in done.stdout.splitlines():
        key, _, value = line.partition(" ")
        if key.startswith("record:"):
            figures[key[len("record:") :]] = float(value)
    if not figures:
        print(f"  record cost failed: {done.stderr.strip()[-300:]}", file=sys.stderr)
    return figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="1000,3000,10000", help="function counts (comma separated)")
    parser.add_argument("--compare", metavar="REV", help="also run the mdl of git revision REV, side by side")
    parser.add_argument("--worktree", type=Path, help="where REV is exported (default /tmp/bench_REV)")
    parser.add_argument("--src", type=Path, default=ROOT / "src", help="the mdl measured as 'after'")
    parser.add_argument("--compile", dest="compile_", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--record", action=argparse.BooleanOptionalAction, default=True, help="time poll records")
    parser.add_argument("--keep", type=Path, help="write the devices and drivers here instead of a temporary dir")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    trees = [("after", args.src.resolve())]
    if args.compare:
        where = args.worktree or Path(f"/tmp/bench_{args.compare}")
        trees.insert(0, ("before", worktree(args.compare, where) / "src"))
    print(f"load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}", file=sys.stderr)

    with tempfile.TemporaryDirectory(prefix="mdl-compile-") as tmp:
        d = args.keep or Path(tmp)
        d.mkdir(parents=True, exist_ok=True)
        files = {}
        for size in sizes:
            files[size] = d / f"mixed_{size}.xml"
            files[size].write_text(mixed_xml(size))
        results = {label: bench_tree(label, src, files, sizes, d, args.compile_) for label, src in trees}
        records = {label: record_cost(src) for label, src in trees} if args.record else {}

    labels = [label for label, _ in trees]
    print()
    print(f"mixed device; wall time (CPU time) and peak memory; load {os.getloadavg()[0]:.2f} at the end")
    print(f"{'functions':>9} {'command':14} " + " ".join(f"{label:>{WIDTH}}" for label in labels))
    keys = sorted({k for r in results.values() for k in r})
    for size, command in keys:
        print(f"{size:>9} {command:14} " + " ".join(fmt(results[label].get((size, command))) for label in labels))
    if records:
        print()
        print("mdl read --interval: CPU ms per poll of 300 functions, the read ('none') and each record (x the read)")
        names = sorted({k for r in records.values() for k in r}, key=lambda k: (k != "none", k))
        for name in names:
            cells = []
            for label in labels:
                value = records[label].get(name)
                base = records[label].get("none")
                if value is None:
                    cells.append(f"{'-':>{WIDTH}}")
                elif name == "none" or not base:
                    cells.append(f"{value * 1000:>{WIDTH - 9}.3f} ms       ")
                else:
                    cells.append(f"{value * 1000:>{WIDTH - 9}.3f} ms {value / base:5.2f}x")
            print(f"{'':>9} {name:14} " + " ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
