#!/usr/bin/env python3
"""`mdl csv2xml` against ORNL's 2014 `csvxml.py` on the same generated register tables. Prints a
table; asserts nothing.

    python3 bench/csv2xml_bench.py                               # mdl only
    python3 bench/csv2xml_bench.py --ornl ~/ornl/csvxml.py       # and ORNL's script beside it
    python3 bench/csv2xml_bench.py --sizes 5000x200 --ornl ...   # one size
    python3 bench/csv2xml_bench.py --grid                        # 1,000/5,000/10,000 rows x 50/200/500

Each table is what a vendor publishes (address, description, format, multiplier, units, access) with
one INI in ORNL's format that both tools read unchanged. Descriptions are built from the words such
tables use (phase, total, demand, import, voltage, power ...), so that rows resemble each other as
they do in real tables; every function's synonyms are one row's description (as typed, and in
lower case with doubled spaces), so each function has exactly one right row, known in advance.

Each tool runs as a child process (`mdl csv2xml device.ini -o mdl.xml`; ORNL's `python3 csvxml.py
device.ini` in the table's folder); the bench prints its wall time, its peak resident memory
(ru_maxrss from wait4) and how many functions landed on their right row, and for mdl how its time
grows per (row x function) against the smallest size. ORNL's script is public (ORNL's MDL tool
set); give its path with --ornl, or the bench measures mdl alone.
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

ROOT = Path(__file__).resolve().parent.parent
NS = "{http://www.ornl.gov/ModbusXMLSchema}"
DIAGONAL = [(1000, 50), (5000, 200), (10000, 500)]
GRID = [(r, f) for r in (1000, 5000, 10000) for f in (50, 200, 500)]

PLACES = [
    "phase A",
    "phase B",
    "phase C",
    "L1",
    "L2",
    "L3",
    "total",
    "average",
    "neutral",
    "inlet",
    "outlet",
    "zone",
    "channel",
    "pump",
    "fan",
    "string",
    "battery",
    "grid",
    "load",
    "generator",
    "PV",
]
QUANTITIES = [
    "voltage",
    "current",
    "real power",
    "reactive power",
    "apparent power",
    "power factor",
    "frequency",
    "import energy",
    "export energy",
    "temperature",
    "pressure",
    "flow rate",
    "setpoint",
    "speed",
    "state of charge",
    "alarm status",
    "run hours",
    "counter",
    "THD",
]
QUALIFIERS = ["", "", "instantaneous", "max demand", "min", "average", "peak", "last hour", "daily", "total"]
FORMATS = [("uint16", ""), ("int16", "0.1"), ("uint32", "0.01"), ("float", ""), ("int32", "0.001")]
UNITS = {
    "voltage": "V",
    "current": "A",
    "real power": "W",
    "reactive power": "var",
    "apparent power": "VA",
    "frequency": "Hz",
    "import energy": "kWh",
    "export energy": "kWh",
    "temperature": "degC",
    "pressure": "bar",
    "flow rate": "m3/h",
    "speed": "rpm",
    "state of charge": "%",
    "run hours": "h",
}


@dataclass
class Case:
    rows: int
    functions: int
    folder: Path
    expected: dict[str, str]  # function -> its right row's address


def descriptions(n: int, rng: random.Random) -> list[str]:
    out, seen = [], set()
    while len(out) < n:
        place, quantity, qualifier = rng.choice(PLACES), rng.choice(QUANTITIES), rng.choice(QUALIFIERS)
        number = f" {rng.randint(1, 64)}" if place in ("zone", "channel", "pump", "fan", "string") else ""
        text = " ".join(w for w in (place.capitalize() + number, qualifier, quantity) if w)
        if rng.random() < 0.3:
            text += f" ({rng.choice(['sum of phases', 'see note', 'signed', 'read only', 'resets daily'])})"
        if text.lower() in seen:
            text += f" #{len(out)}"
        seen.add(text.lower())
        out.append(text)
    return out


def identifier(text: str) -> str:
    return "_".join("".join(ch if ch.isalnum() else " " for ch in text.lower()).split())


def typo(text: str, rng: random.Random) -> str:
    """The text with one letter of a longer word left out: no exact or whole-phrase match, only a fuzzy one."""
    words = text.lower().split(" ")
    long = [i for i, w in enumerate(words) if len(w) >= 5 and w.isalpha()] or [
        max(range(len(words)), key=lambda i: len(words[i]))
    ]
    i = rng.choice(long)
    j = rng.randrange(1, max(2, len(words[i]) - 1))
    words[i] = words[i][:j] + words[i][j + 1 :]
    return " ".join(words)


def generate(rows: int, functions: int, folder: Path, seed: int = 12, typos: bool = False) -> Case:
    rng = random.Random(seed * 100003 + rows * 7 + functions)
    texts = descriptions(rows, rng)
    lines = ["Address,Description,Format,Multiplier,Units,Access"]
    address = 0
    addresses = []
    for text in texts:
        fmt, scale = rng.choice(FORMATS)
        unit = next((u for q, u in UNITS.items() if q in text.lower()), "")
        access = rng.choice(["R", "R", "R/W"])
        lines.append(f'{address},"{text}",{fmt},{scale},{unit},{access}')
        addresses.append(str(address))
        address += 2
    targets = sorted(rng.sample(range(rows), functions))
    expected, synonyms = {}, []
    for n, t in enumerate(targets):
        name = f"f{n}_" + identifier(texts[t]) if typos else identifier(texts[t])
        expected[name] = addresses[t]
        if typos:
            synonyms.append(f"{name} = {typo(texts[t], rng)}")
        else:
            synonyms.append(f"{name} = {texts[t]}, {'  '.join(texts[t].lower().split(' '))}")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "map.csv").write_text("\n".join(lines) + "\n")
    (folder / "device.ini").write_text(
        f"""[Modbus Device]
device_name        = Bench {rows}x{functions}
device_description = Generated register table

[Input/Output]
address_map_csv_file = map.csv
lines_to_skip        = 1
output_xml_file      = ornl.xml

[Column/Field Indices]
description         = 1
addresses           = 0
length              =
count               =
format              = 2
block_label         =
multiplier          = 3
units               = 4
read_function_code  =
write_function_code =

[Additional Column/Field Indices]
operation_info      = 5

[Function Name Search Synonyms]
"""
        + "\n".join(synonyms)
        + "\n"
    )
    return Case(rows, functions, folder, expected)


@dataclass
class Run:
    seconds: float
    peak_mb: float
    ok: bool
    right: int = 0
    note: str = ""


def measure(cmd: list[str], cwd: Path) -> Run:
    """Wall time and peak RSS of one child process (wait4 gives that child's own rusage)."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=cwd)
    assert proc.stderr is not None
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    proc.stderr.close()
    code = os.waitstatus_to_exitcode(status)
    note = "" if code == 0 else (err.decode(errors="replace").strip().splitlines() or [f"exit {code}"])[-1][:80]
    return Run(seconds, usage.ru_maxrss / 1024, code == 0, note=note)


def right_rows(xml: Path, expected: dict[str, str]) -> int:
    if not xml.exists():
        return 0
    root = etree.parse(str(xml), etree.XMLParser(resolve_entities=False, no_network=True)).getroot()
    got = {
        (fn.findtext(f"{NS}name") or "").strip(): (fn.findtext(f"{NS}addresses") or "").strip()
        for fn in root.iter(f"{NS}function")
    }
    return sum(got.get(name) == address for name, address in expected.items())


def run_mdl(case: Case) -> Run:
    out = case.folder / "mdl.xml"
    run = measure([sys.executable, "-m", "mdl", "csv2xml", "device.ini", "-o", str(out)], case.folder)
    run.right = right_rows(out, case.expected)
    return run


def run_ornl(case: Case, script: Path) -> Run:
    out = case.folder / "ornl.xml"
    run = measure([sys.executable, str(script), "device.ini"], case.folder)
    run.right = right_rows(out, case.expected)
    run.ok = run.ok and out.exists()
    return run


def parse_sizes(text: str) -> list[tuple[int, int]]:
    sizes = []
    for part in text.split(","):
        rows, _, functions = part.strip().lower().partition("x")
        sizes.append((int(rows), int(functions)))
    return sizes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ornl", type=Path, help="path to ORNL's csvxml.py (skipped when absent)")
    parser.add_argument("--sizes", type=parse_sizes, help="ROWSxFUNCTIONS,... (default 1000x50,5000x200,10000x500)")
    parser.add_argument("--grid", action="store_true", help="every combination of 1,000/5,000/10,000 x 50/200/500")
    parser.add_argument("--keep", type=Path, help="write the tables here instead of a temporary folder")
    parser.add_argument(
        "--typos", action="store_true", help="also measure synonyms with a letter left out (fuzzy matches only)"
    )
    args = parser.parse_args()
    sizes = args.sizes or (GRID if args.grid else DIAGONAL)
    ornl = args.ornl if args.ornl and args.ornl.is_file() else None
    if args.ornl and ornl is None:
        print(f"ORNL's script {args.ornl} is absent: measuring mdl alone", file=sys.stderr)
    base = args.keep or Path(tempfile.mkdtemp(prefix="csv2xml_bench_"))
    head = f"{'synonyms':>8} {'rows x functions':>17} | {'mdl s':>7} {'MB':>6} {'right':>9} {'us/pair':>8}"
    if ornl:
        head += f" | {'ORNL s':>7} {'MB':>6} {'right':>9} | {'speed-up':>8}"
    print(head)
    print("-" * len(head))
    runs = [(rows, functions, False) for rows, functions in sizes]
    runs += [(rows, functions, True) for rows, functions in sizes] if args.typos else []
    for rows, functions, typos in runs:
        case = generate(rows, functions, base / f"{rows}x{functions}{'-typos' * typos}", typos=typos)
        mine = run_mdl(case)
        line = (
            f"{'typos' if typos else 'exact':>8} {rows:>8,} x {functions:>6} | {mine.seconds:7.2f} "
            f"{mine.peak_mb:6.0f} {mine.right:>4}/{functions:<4} {1e6 * mine.seconds / (rows * functions):8.2f}"
        )
        if not mine.ok:
            line += f"  mdl failed: {mine.note}"
        if ornl:
            theirs = run_ornl(case, ornl)
            line += (
                f" | {theirs.seconds:7.2f} {theirs.peak_mb:6.0f} {theirs.right:>4}/{functions:<4} | "
                f"{theirs.seconds / mine.seconds:7.1f}x"
            )
            if not theirs.ok:
                line += f"  ORNL failed: {theirs.note}"
        print(line, flush=True)
    if not args.keep:
        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
