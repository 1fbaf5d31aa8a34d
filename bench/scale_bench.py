#!/usr/bin/env python3
"""How `mdl gen` and `mdl validate` scale with the number of functions. Prints figures; asserts nothing.

    python3 bench/scale_bench.py                       # 1,000 / 10,000 / 30,000 functions
    python3 bench/scale_bench.py --sizes 1000,10000 --repeat 3 --compare 64420ac
    python3 bench/scale_bench.py --no-cpp-compile --langs python,cpp

For each size it builds two synthetic devices:
- plain: an MDL 1.0 document whose functions mix formats (8 to 64 bits, floats, strings, bits),
  byte and word orders, multipliers and offsets over the holding, input and coil tables;
- expr: a Modbus Schema Toolkit YAML file of blocks of 50 fields, every field an expression and
  many naming other fields of their block (a scale factor, sums, differences), imported once with
  `mdl import` to MDL 1.0 (so that the figures are mdl's, not the pure-Python YAML parser's);

and runs, each as a child process, `mdl gen FILE --lang L` for each L (all registered ones and
`all`) and `mdl validate FILE`, printing the wall time, the CPU time (user + system: what other jobs
on a shared machine disturb least; --repeat N keeps the best of N runs) and the child's peak
resident memory (ru_maxrss from wait4). With --cpp-compile (the default for sizes up to
3,000) it also times `g++ -std=c++17 -O2 -c` on the generated .cc at 1,000 and 3,000 plain functions.

--compare REV runs the same figures with the mdl of git revision REV (exported once with `git archive`
into /tmp/bench_<REV> unless --worktree says otherwise) and prints before and after side by side.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# (table, format, registers taken, extra elements) for the plain device, cycled
PLAIN_KINDS: list[tuple[str, str, int, str]] = [
    ("holding", "UINT16", 1, "<multiplier>0.1</multiplier>"),
    ("holding", "INT32", 2, "<word_order>little</word_order>"),
    ("holding", "FLOAT32", 2, "<byte_order>little</byte_order>"),
    ("input", "INT16", 1, "<multiplier>0.5</multiplier><offset>-40</offset>"),
    ("input", "UINT32", 2, "<multiplier>0.01</multiplier><not_implemented>0xFFFFFFFF</not_implemented>"),
    ("coil", "BIT", 1, ""),
    ("holding", "UINT8", 1, "<length>Lower byte</length>"),
    ("input", "FLOAT64", 4, "<word_order>little</word_order>"),
    ("holding", "STRING", 4, "<count>4</count>"),
    ("coil", "BIT", 1, ""),
]
# the order the schema wants these elements in
ORDER = (
    "length",
    "count",
    "format",
    "multiplier",
    "register_type",
    "byte_order",
    "word_order",
    "offset",
    "access",
    "not_implemented",
)


def _element(extra: str, tag: str) -> str:
    start = extra.find(f"<{tag}>")
    if start < 0:
        return ""
    end = extra.find(f"</{tag}>", start) + len(f"</{tag}>")
    return extra[start:end]


def plain_xml(n: int) -> str:
    """An MDL 1.0 document of n functions (see the module docstring)."""
    next_address = {"holding": 0, "input": 0, "coil": 0}
    out = [
        "<?xml version='1.0' encoding='US-ASCII'?>",
        '<device xmlns="http://www.ornl.gov/ModbusXMLSchema" version="1.0">',
        f"  <name>Scale {n}</name>",
        f"  <description>{n} synthetic functions</description>",
    ]
    for i in range(n):
        table, fmt, size, extra = PLAIN_KINDS[i % len(PLAIN_KINDS)]
        if i % 37 == 36:  # a hole now and then: the read plan has more than one group per table
            next_address[table] += 3
        address = next_address[table]
        next_address[table] += size
        elements = {"format": f"<format>{fmt}</format>"}
        if table != "holding":
            elements["register_type"] = f"<register_type>{table}</register_type>"
        for tag in ORDER:
            found = _element(extra, tag)
            if found:
                elements[tag] = found
        body = "".join(elements[tag] for tag in ORDER if tag in elements)
        out.append(
            f"  <function><name>f{i}_{fmt.lower()}</name><description>function {i}</description>"
            f"<addresses>{address}</addresses>{body}</function>"
        )
    assert max(next_address.values()) <= 65536, next_address
    out.append("</device>")
    return "\n".join(out) + "\n"


def expr_yaml(n: int) -> str:
    """A Toolkit schema of n fields in blocks of 50, most naming other fields of their block."""
    per_block = 50
    lines = ["description: 'Synthetic expression device'", "maxRegistersPerModbusRequest: 100", "blocks:"]
    address = {"hr": 0, "ir": 0}
    made = 0
    block = 0
    while made < n:
        lines += [
            f"  - id: 'B{block}'",
            f"    description: 'Block {block}'",
            "    fields:",
            "      - id: 'SF'",
            f"        expression: 'int16(hr:{address['hr']}; 0x8000)'",
            "        system: true",
        ]
        address["hr"] += 1
        made += 1
        i = 0
        while i < per_block - 1 and made < n:
            k = i % 7
            t = "ir" if block % 2 else "hr"
            a = address[t]
            if k == 0:
                expr, size = f"uint16({t}:{a}) * 10^SF", 1
            elif k == 1:
                expr, size = f"int16({t}:{a}; 0x8000) * 10^SF", 1
            elif k == 2:
                expr, size = f"int32({t}:{a}#2) / 100", 2
            elif k == 3 and i >= 3:
                expr, size = f"F{i - 3} + F{i - 2}", 0
            elif k == 4:
                expr, size = f"ieee754_32({t}:{a}#2)", 2
            elif k == 5 and i >= 5:
                expr, size = f"F{i - 1} - F{i - 5} * 2", 0
            else:
                expr, size = f"uint32({t}:{a}#2)", 2
            address[t] += size
            lines += [f"      - id: 'F{i}'", f'        expression: "{expr}"']
            i += 1
            made += 1
        block += 1
    assert max(address.values()) <= 65536, address
    return "\n".join(lines) + "\n"


@dataclass
class Run:
    seconds: float  # wall time
    peak_mb: float
    ok: bool
    note: str = ""
    cpu: float = 0.0  # user + system time of the child: what a shared machine disturbs least


def measure(cmd: list[str], env: dict[str, str] | None = None, cwd: Path | None = None) -> Run:
    """Wall time, CPU time and peak RSS of one child process (wait4 gives that child's own rusage)."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, cwd=cwd)
    assert proc.stderr is not None
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    proc.stderr.close()
    note = (
        ""
        if proc.returncode == 0
        else err.decode(errors="replace").strip().splitlines()[-1:][0][:80]
        if err.strip()
        else f"exit {proc.returncode}"
    )
    return Run(seconds, usage.ru_maxrss / 1024, proc.returncode == 0, note, usage.ru_utime + usage.ru_stime)


def best(cmd: list[str], env: dict[str, str] | None, repeat: int) -> Run:
    """The run of least CPU time of `repeat` runs (the first failure, if one fails)."""
    runs = []
    for _ in range(repeat):
        run = measure(cmd, env)
        if not run.ok:
            return run
        runs.append(run)
    return min(runs, key=lambda r: r.cpu)


def mdl_env(src: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(src) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def langs_of(src: Path) -> list[str]:
    """The --lang choices of that mdl (its registry), `all` last."""
    out = subprocess.run(
        [sys.executable, "-m", "mdl", "gen", "--help"], env=mdl_env(src), capture_output=True, text=True, check=True
    ).stdout
    start = out.index("--lang [") + len("--lang [")
    choices = out[start : out.index("]", start)].split("|")
    return [c for c in choices if c != "all"] + ["all"]


def worktree(rev: str, where: Path) -> Path:
    """The tree of `rev` at `where`, exported once with `git archive` (read-only for the repository:
    no worktree, no checkout); `where/.rev` records the commit it holds."""
    want = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", rev], capture_output=True, text=True, check=True
    ).stdout.strip()
    marker = where / ".rev"
    if where.exists():
        if marker.is_file() and marker.read_text().strip() == want:
            return where
        raise SystemExit(f"{where} exists and is not an export of {rev}; remove it or pass --worktree")
    where.mkdir(parents=True)
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", "--format=tar", want], capture_output=True, check=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(where)], input=archive, check=True)
    marker.write_text(want + "\n")
    return where


def to_mdl(yaml_path: Path, xml_path: Path, sources: list[Path]) -> None:
    """`mdl import` the Toolkit YAML to MDL 1.0 (with the first mdl that can), so that gen and validate
    time mdl itself, not the YAML parser."""
    for src in reversed(sources):
        done = subprocess.run(
            [sys.executable, "-m", "mdl", "import", str(yaml_path), "-o", str(xml_path)],
            env=mdl_env(src),
            capture_output=True,
        )
        if done.returncode == 0:
            return
    raise SystemExit(f"cannot import {yaml_path}: {done.stderr.decode(errors='replace')[-300:]}")


def bench_one(
    label: str,
    src: Path,
    files: dict[tuple[str, int], Path],
    sizes: list[int],
    langs: list[str],
    out_dir: Path,
    repeat: int = 1,
) -> dict[tuple[str, int, str], Run]:
    """(kind, size, command) -> Run for one mdl source tree."""
    env = mdl_env(src)
    results: dict[tuple[str, int, str], Run] = {}
    for size in sizes:
        for kind in ("plain", "expr"):
            path = files[(kind, size)]
            for lang in langs:
                dest = out_dir / f"{label}-{kind}-{size}-{lang}"
                run = best(
                    [sys.executable, "-m", "mdl", "gen", str(path), "--lang", lang, "-o", str(dest)], env, repeat
                )
                results[(kind, size, f"gen {lang}")] = run
                print(
                    f"  [{label}] {kind:5} {size:>6} gen --lang {lang:6} {fmt(run)}"
                    + ("" if run.ok else f"  FAILED: {run.note}"),
                    file=sys.stderr,
                    flush=True,
                )
            run = best([sys.executable, "-m", "mdl", "validate", str(path)], env, repeat)
            results[(kind, size, "validate")] = run
            print(
                f"  [{label}] {kind:5} {size:>6} validate        {fmt(run)}"
                + ("" if run.ok else f"  FAILED: {run.note}"),
                file=sys.stderr,
                flush=True,
            )
    return results


def modbus_cflags() -> list[str]:
    pkg = shutil.which("pkg-config")
    if pkg is None:
        return []
    return subprocess.run([pkg, "--cflags", "libmodbus"], capture_output=True, text=True).stdout.split()


def cpp_compile(
    label: str, src: Path, files: dict[tuple[str, int], Path], sizes: list[int], out_dir: Path
) -> dict[int, Run]:
    gxx = shutil.which("g++")
    out: dict[int, Run] = {}
    if gxx is None:
        return out
    for size in sizes:
        dest = out_dir / f"{label}-cc-{size}"
        gen = measure(
            [sys.executable, "-m", "mdl", "gen", str(files[("plain", size)]), "--lang", "cpp", "-o", str(dest)],
            mdl_env(src),
        )
        ccs = sorted(dest.glob("*.cc"))
        if not gen.ok or not ccs:
            out[size] = Run(0, 0, False, gen.note or "no .cc")
            continue
        run = measure(
            [gxx, "-std=c++17", "-O2", "-c", "-I", str(dest), *modbus_cflags(), str(ccs[0]), "-o", str(dest / "out.o")]
        )
        out[size] = run
        print(
            f"  [{label}] g++ -O2 -c {size:>6}       {fmt(run)}" + ("" if run.ok else f"  FAILED: {run.note}"),
            file=sys.stderr,
            flush=True,
        )
    return out


WIDTH = 26


def fmt(run: Run | None) -> str:
    """`wall s (cpu s) peak MB`."""
    if run is None:
        return f"{'-':>{WIDTH}}"
    if not run.ok:
        return f"{'failed':>{WIDTH}}"
    return f"{run.seconds:7.2f}s ({run.cpu:6.2f}s) {run.peak_mb:5.0f}MB"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="1000,10000,30000", help="function counts (comma separated)")
    parser.add_argument("--langs", help="--lang values to time (default: every registered one, and all)")
    parser.add_argument("--compare", metavar="REV", help="also run the mdl of git revision REV, side by side")
    parser.add_argument("--worktree", type=Path, help="where REV is exported (default /tmp/bench_REV)")
    parser.add_argument(
        "--src",
        type=Path,
        default=ROOT / "src",
        help="the mdl source tree measured as 'after' (default: this checkout's src/)",
    )
    parser.add_argument(
        "--cpp-compile",
        dest="cpp",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="time g++ -O2 -c on the generated .cc (default: on, at 1,000 and 3,000 functions)",
    )
    parser.add_argument("--cpp-sizes", default="1000,3000", help="sizes for --cpp-compile")
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="run each mdl command N times and keep the run of least CPU time (default 1)",
    )
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    cpp_sizes = [int(s) for s in args.cpp_sizes.split(",")] if args.cpp is not False else []
    if args.cpp is None:
        cpp_sizes = [s for s in cpp_sizes if s <= 3000]

    trees = [("after", args.src.resolve())]
    if args.compare:
        trees.insert(0, ("before", worktree(args.compare, args.worktree or Path(f"/tmp/bench_{args.compare}")) / "src"))
    langs = args.langs.split(",") if args.langs else langs_of(args.src.resolve())

    with tempfile.TemporaryDirectory(prefix="mdl-scale-") as tmp:
        d = Path(tmp)
        files: dict[tuple[str, int], Path] = {}
        for size in sorted(set(sizes) | set(cpp_sizes)):
            files[("plain", size)] = d / f"plain_{size}.xml"
            files[("plain", size)].write_text(plain_xml(size))
            yaml_path = d / f"expr_{size}.yaml"
            yaml_path.write_text(expr_yaml(size))
            files[("expr", size)] = d / f"expr_{size}.xml"
            to_mdl(yaml_path, files[("expr", size)], [src for _, src in trees])
        results = {}
        compiles = {}
        for label, src in trees:
            tree_langs = [lang for lang in langs if label == "after" or lang in langs_of(src)]
            results[label] = bench_one(label, src, files, sizes, tree_langs, d, args.repeat)
            compiles[label] = cpp_compile(label, src, files, cpp_sizes, d)

    labels = [label for label, _ in trees]
    print()
    print("wall time (CPU time: user + system) and peak memory; speed-up in CPU time")
    print(
        f"{'device':6} {'functions':>9} {'command':14} "
        + " ".join(f"{label:>{WIDTH}}" for label in labels)
        + ("   speed-up" if len(labels) == 2 else "")
    )
    keys = sorted({k for r in results.values() for k in r}, key=lambda k: (k[0] != "plain", k[1], k[2]))
    for kind, size, command in keys:
        runs = [results[label].get((kind, size, command)) for label in labels]
        line = f"{kind:6} {size:>9} {command:14} " + " ".join(fmt(r) for r in runs)
        if len(runs) == 2 and all(r is not None and r.ok for r in runs):
            line += f"   {runs[0].cpu / runs[1].cpu:7.1f}x"  # type: ignore[union-attr]
        print(line)
    for size in cpp_sizes:
        runs = [compiles[label].get(size) for label in labels]
        print(f"{'plain':6} {size:>9} {'g++ -O2 -c':14} " + " ".join(fmt(r) for r in runs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
