#!/usr/bin/env python3
"""`mdl csv2xml` against ORNL's 2014 `csvxml.py` on the same generated register tables, and the same
table read from a PDF manual beside them, in one run. Prints a table; asserts nothing.

    python3 bench/csv2xml_bench.py                                # mdl alone, 1,000 x 50 ... 10,000 x 500
    python3 bench/csv2xml_bench.py --sizes 5000x200 --ornl ~/ornl/csvxml.py
    python3 bench/csv2xml_bench.py --sizes 5000x200 --ornl ~/ornl/csvxml.py --callgrind
    python3 bench/csv2xml_bench.py --grid                         # 1,000/5,000/10,000 rows x 50/200/500

Each table is what a vendor publishes (address, description, format, multiplier, units, access) with
one INI in ORNL's format that both tools read unchanged. Descriptions are built from the words such
tables use (phase, total, demand, import, voltage, power ...), so that rows resemble each other as
they do in real tables; every function's synonyms are one row's description (as typed, and in
lower case with doubled spaces), so each function has exactly one right row, known in advance.

Each tool runs as a child process: `mdl csv2xml device.ini -o mdl.xml`; `mdl csv2xml map.pdf --ini
device.ini` on the same rows written as a PDF manual (tables_bench.write_pdf: A4 pages of 40 ruled rows
under the header, 125 pages at 5,000 rows); ORNL's `python3 csvxml.py device.ini` in the table's
folder. For each the bench prints the wall time, the CPU time (user + system, from wait4: what a shared
machine's load disturbs least; mdl's runs are the least of --repeat), the peak resident memory
(ru_maxrss), how many functions landed on their right row and the CPU time per (row x function); and
how many times mdl's CPU time ORNL's script takes. With --callgrind, each also runs once under
`valgrind --tool=callgrind`: its instructions (every process's, the PDF reader's two halves
included), which the load does not change, and the speed-up by them. ORNL's script computes a ratio
for every (row, synonym) pair, each function's alike: under callgrind it would take hours at 5,000 x
200, so its instructions are counted on --ornl-sample of its functions (every Nth, the same table)
and scaled to all of them by their synonyms' characters (a function's ratios cost about in proportion
to them), its start-up (an INI with no function) counted apart: start-up + (sample - start-up) x
(characters of all) / (characters of the sample). At 600 x 20, 4 functions so scaled gave 11.64 G
where all 20 counted 11.47 G. `--ornl-sample 0` counts them all. The callgrind runs go at once,
ORNL's first (it takes longest).

Every child runs with its bytecode cached under the bench's folder (PYTHONPYCACHEPREFIX), after one
unmeasured run of each tool on a small table: the figures are of warm runs, whatever state the
tree's __pycache__ is in. The machine's load average is printed when the bench starts and ends.
ORNL's script is public (ORNL's MDL tool set); give its path with --ornl, or the bench measures mdl
alone.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import os
import platform
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
    wall: float
    cpu: float  # user + system, the child's and its children's
    peak_mb: float
    ok: bool
    right: int = 0
    note: str = ""
    instructions: int | None = None  # with --callgrind


def child_env(folder: Path) -> dict[str, str]:
    """The environment of every child: bytecode cached (and written) under `folder`."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPYCACHEPREFIX"] = str(folder / "pycache")
    return env


def measure(cmd: list[str], cwd: Path, env: dict[str, str]) -> Run:
    """Wall time, CPU time and peak RSS of one child process (wait4 gives that child's own rusage, with
    that of the children it waited for)."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=cwd, env=env)
    assert proc.stderr is not None
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.stderr.close()
    proc.returncode = code = os.waitstatus_to_exitcode(status)
    note = "" if code == 0 else (err.decode(errors="replace").strip().splitlines() or [f"exit {code}"])[-1][:80]
    return Run(wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024, code == 0, note=note)


def best(cmd: list[str], cwd: Path, env: dict[str, str], repeat: int) -> Run:
    """The run of least CPU time of `repeat` (the one the load disturbed least)."""
    return min((measure(cmd, cwd, env) for _ in range(max(1, repeat))), key=lambda r: (not r.ok, r.cpu))


def callgrind(cmd: list[str], cwd: Path, env: dict[str, str], out: Path) -> subprocess.Popen[bytes]:
    """`cmd` started under callgrind, one output file per process (out.PID); `instructions` sums them."""
    out.parent.mkdir(parents=True, exist_ok=True)
    for old in out.parent.glob(out.name + ".*"):
        old.unlink()
    grind = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}.%p", *cmd]
    return subprocess.Popen(grind, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=cwd, env=env)


def instructions(proc: subprocess.Popen[bytes], out: Path) -> int | None:
    """The instructions of every process of a finished callgrind run (None if it failed)."""
    if proc.wait() != 0:
        return None
    total = 0
    for path in out.parent.glob(out.name + ".*"):
        for line in path.read_text(errors="replace").splitlines():
            if line.startswith(("totals:", "summary:")):
                total += int(line.split()[1])
                break
    return total or None


def right_rows(xml: Path, expected: dict[str, str]) -> int:
    if not xml.exists():
        return 0
    root = etree.parse(str(xml), etree.XMLParser(resolve_entities=False, no_network=True)).getroot()
    got = {
        (fn.findtext(f"{NS}name") or "").strip(): (fn.findtext(f"{NS}addresses") or "").strip()
        for fn in root.iter(f"{NS}function")
    }
    return sum(got.get(name) == address for name, address in expected.items())


def write_pdf(case: Case) -> Path:
    """The case's table as a PDF manual, by bench/tables_bench.py's writer (columns wide enough for the
    longest description on one line, at its 9 points)."""
    spec = importlib.util.spec_from_file_location("tables_bench", Path(__file__).resolve().parent / "tables_bench.py")
    assert spec and spec.loader
    tables = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tables)
    tables.PDF_WIDTHS = [40.0, 290.0, 45.0, 50.0, 35.0, 35.0]  # 495 points: A4 less its margins
    with (case.folder / "map.csv").open(newline="") as f:
        table = list(csv.reader(f))
    path = case.folder / "map.pdf"
    tables.write_pdf(path, table)
    return path


def ornl_inis(case: Case, sample: int) -> tuple[str, str, int, float]:
    """Two INIs beside device.ini for counting ORNL's instructions: none of its functions (start-up,
    the table read, the XML written) and every Nth (`sample` of them); how many that is, and how many
    times their synonyms' characters all the functions' are (a function's ratios cost about in
    proportion to them: the scale)."""
    text = (case.folder / "device.ini").read_text()
    head, _, synonyms = text.partition("[Function Name Search Synonyms]\n")
    lines = [x for x in synonyms.splitlines() if x.strip()]
    step = max(1, len(lines) // sample)
    picked = lines[step // 2 :: step][:sample]
    for name, chosen in (("none", []), ("sample", picked)):
        body = head.replace("output_xml_file      = ornl.xml", f"output_xml_file      = ornl-{name}.xml")
        synonyms_part = "[Function Name Search Synonyms]\n" + "\n".join(chosen) + "\n"
        (case.folder / f"device-{name}.ini").write_text(body + synonyms_part)

    def chars(some: list[str]) -> int:  # as ORNL's script reads them: split at commas, stripped
        return sum(len(w.strip()) for x in some for w in x.partition("=")[2].split(","))

    return "device-none.ini", "device-sample.ini", len(picked), chars(lines) / chars(picked)


@dataclass
class Tool:
    """One way of converting a case: its label and its command (run in the case's folder)."""

    label: str
    cmd: list[str]
    out: str  # the MDL it writes, in the case's folder
    repeat: int


def tools(case: Case, ornl: Path | None, pdf: bool, repeat: int) -> list[Tool]:
    mdl = [sys.executable, "-m", "mdl", "csv2xml"]
    out = [Tool("mdl, CSV", [*mdl, "device.ini", "-o", "mdl.xml"], "mdl.xml", repeat)]
    if pdf:
        out.append(Tool("mdl, PDF", [*mdl, "map.pdf", "--ini", "device.ini", "-o", "pdf.xml"], "pdf.xml", repeat))
    if ornl:
        out.append(Tool("ORNL, CSV", [sys.executable, str(ornl), "device.ini"], "ornl.xml", 1))
    return out


def parse_sizes(text: str) -> list[tuple[int, int]]:
    sizes = []
    for part in text.split(","):
        rows, _, functions = part.strip().lower().partition("x")
        sizes.append((int(rows), int(functions)))
    return sizes


def load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"{one:.2f} {five:.2f} {fifteen:.2f} ({os.cpu_count()} cores)"


def line(case: Case, typos: bool, tool: Tool, run: Run, ornl: Run | None, grind: bool) -> str:
    pairs = case.rows * case.functions
    text = (
        f"{'typos' if typos else 'exact':>8} {case.rows:>8,} x {case.functions:>5} | {tool.label:<9} "
        f"{run.wall:8.2f} {run.cpu:8.2f} {run.peak_mb:5.0f} {run.right:>4}/{case.functions:<4} "
        f"{1e6 * run.cpu / pairs:8.2f}"
    )
    if grind:
        text += f" | {run.instructions / 1e9:9.2f}" if run.instructions else " |         -"
    if ornl is not None and not tool.label.startswith("ORNL"):
        text += f" | {ornl.cpu / run.cpu:8.1f}x"
        if grind:
            text += f" {ornl.instructions / run.instructions:8.1f}x" if ornl.instructions and run.instructions else ""
    if not run.ok:
        text += f"  failed: {run.note}"
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ornl", type=Path, help="path to ORNL's csvxml.py (skipped when absent)")
    parser.add_argument("--sizes", type=parse_sizes, help="ROWSxFUNCTIONS,... (default 1000x50,5000x200,10000x500)")
    parser.add_argument("--grid", action="store_true", help="every combination of 1,000/5,000/10,000 x 50/200/500")
    parser.add_argument("--keep", type=Path, help="write the tables here instead of a temporary folder")
    parser.add_argument(
        "--typos", action="store_true", help="also measure synonyms with a letter left out (fuzzy matches only)"
    )
    parser.add_argument("--no-pdf", action="store_true", help="leave out the same table read from a PDF")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each mdl conversion; the least CPU is kept")
    parser.add_argument("--callgrind", action="store_true", help="also count each run's instructions (valgrind)")
    parser.add_argument(
        "--ornl-sample",
        type=int,
        default=10,
        help="ORNL's functions counted under callgrind, scaled to all (default 10; 0: all of them, hours)",
    )
    args = parser.parse_args()
    sizes = args.sizes or (GRID if args.grid else DIAGONAL)
    ornl = args.ornl if args.ornl and args.ornl.is_file() else None
    if args.ornl and ornl is None:
        print(f"ORNL's script {args.ornl} is absent: measuring mdl alone", file=sys.stderr)
    if args.callgrind and shutil.which("valgrind") is None:
        raise SystemExit("--callgrind counts instructions with valgrind: install valgrind")
    base = args.keep or Path(tempfile.mkdtemp(prefix="csv2xml_bench_"))
    base.mkdir(parents=True, exist_ok=True)
    env = child_env(base)
    pdf = not args.no_pdf
    print(f"python {platform.python_version()}; load average {load()} at the start")

    warm = generate(20, 2, base / "warm")  # one unmeasured run of each tool: its bytecode cached
    if pdf:
        write_pdf(warm)
    for tool in tools(warm, ornl, pdf, 1):
        measure(tool.cmd, warm.folder, env)

    head = (
        f"{'synonyms':>8} {'rows x functions':>16} | {'run':<9} {'wall s':>8} {'CPU s':>8} {'MB':>5} "
        f"{'right':>9} {'us/pair':>8}"
    )
    head += f" | {'G instr':>9}" if args.callgrind else ""
    head += f" | {'ORNL/run':>9}" + (f" {'by instr':>9}" if args.callgrind else "") if ornl else ""
    print(head)
    print("-" * len(head), flush=True)
    cases = [(rows, functions, False) for rows, functions in sizes]
    cases += [(rows, functions, True) for rows, functions in sizes] if args.typos else []
    for rows, functions, typos in cases:
        case = generate(rows, functions, base / f"{rows}x{functions}{'-typos' * typos}", typos=typos)
        if pdf:
            write_pdf(case)
        runs: dict[str, Run] = {}
        how = ""
        todo = tools(case, ornl, pdf, args.repeat)
        for tool in todo:
            runs[tool.label] = run = best(tool.cmd, case.folder, env, tool.repeat)
            run.right = right_rows(case.folder / tool.out, case.expected)
            run.ok = run.ok and (case.folder / tool.out).exists()
        if args.callgrind:  # at once, the longest (ORNL's) first: they take as long as it does
            grinds = base / "callgrind" / case.folder.name
            scaled = None
            if ornl and 0 < args.ornl_sample < functions:
                none, some, k, scale = ornl_inis(case, args.ornl_sample)
                apart = [
                    (f"ornl-{n}", [sys.executable, str(ornl), ini]) for n, ini in (("none", none), ("sample", some))
                ]
                scaled = (k, scale, [(callgrind(cmd, case.folder, env, grinds / n), grinds / n) for n, cmd in apart])
            started = [
                (tool, callgrind(tool.cmd, case.folder, env, grinds / tool.out))
                for tool in reversed(todo)
                if not (scaled and tool.label.startswith("ORNL"))
            ]
            for tool, proc in started:
                runs[tool.label].instructions = instructions(proc, grinds / tool.out)
            if scaled:
                k, scale, ((p0, o0), (p1, o1)) = scaled
                start_up, sampled = instructions(p0, o0), instructions(p1, o1)
                if start_up and sampled:
                    runs["ORNL, CSV"].instructions = round(start_up + (sampled - start_up) * scale)
                    how = (
                        f"ORNL's instructions: {start_up / 1e9:.2f} G with no function, {sampled / 1e9:.2f} G with "
                        f"{k} of its {functions} (every {functions // k}th), scaled by their synonyms' characters "
                        f"(x{scale:.2f})"
                    )
        theirs = runs.get("ORNL, CSV")
        for tool in todo:
            print(line(case, typos, tool, runs[tool.label], theirs, args.callgrind), flush=True)
        mine = runs["mdl, CSV"]
        if pdf:
            paper = runs["mdl, PDF"]
            said = f"the PDF takes {paper.cpu / mine.cpu:.1f}x the CSV's CPU"
            if paper.instructions and mine.instructions:
                said += f", {paper.instructions / mine.instructions:.1f}x its instructions"
            print(f"{'':>25} | {said}", flush=True)
        if how:
            print(f"{'':>25} | {how}", flush=True)
    print(f"load average {load()} at the end")
    if not args.keep:
        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
