#!/usr/bin/env python3
"""How long csv2xml's readers take on a 5,000-row register table published as CSV, Markdown, HTML and
Excel (SPEC 4.1: reading an Excel or HTML table of 5,000 rows takes under 5 s). Prints a table: the
time to read the file into rows (mdl.formats.table.readers.delimited.read_table, best of --repeat) and the time
of the whole `mdl csv2xml` as a child process (reading, matching, writing MDL). Asserts nothing.

    python3 bench/tables_bench.py                 # 5,000 rows
    python3 bench/tables_bench.py --rows 20000 --repeat 1
"""

from __future__ import annotations

import argparse
import html
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HEADER = ["Register", "Description", "Data Type", "Multiplier", "Units", "Access"]
INI = "[Function Name Search Synonyms]\nroom_temperature = room temperature 17\nfan_speed = fan speed 4000\n"


def rows(n: int) -> list[list[str]]:
    words = ["room temperature", "fan speed", "phase voltage", "total power", "energy import"]
    return [HEADER] + [
        [str(i), f"{words[i % len(words)]} {i}", "int16" if i % 2 else "uint16", "0.1", "V", "R"] for i in range(n)
    ]


def write_all(folder: Path, table: list[list[str]]) -> dict[str, Path]:
    import openpyxl  # type: ignore[import-untyped]

    out = {fmt: folder / f"map.{fmt}" for fmt in ("csv", "md", "html", "xlsx")}
    out["csv"].write_text("\n".join(",".join(r) for r in table) + "\n")
    md = ["| " + " | ".join(table[0]) + " |", "|" + "---|" * len(HEADER)]
    out["md"].write_text("\n".join(md + ["| " + " | ".join(r) + " |" for r in table[1:]]) + "\n")
    cells = ("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in table)
    out["html"].write_text("<html><body><table>\n" + "\n".join(cells) + "\n</table></body></html>\n")
    book = openpyxl.Workbook()
    for r in table:
        book.active.append([int(c) if c.isdigit() else c for c in r])
    book.save(out["xlsx"])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rows", type=int, default=5000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    from mdl.formats.table.readers.delimited import read_table

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        files = write_all(folder, rows(args.rows))
        ini = folder / "map.ini"
        ini.write_text(INI)
        print(f"{args.rows:,} rows x {len(HEADER)} columns")
        print(f"{'format':8} {'size':>10} {'read_table':>11} {'mdl csv2xml':>12}  rows")
        for fmt, path in files.items():
            best = float("inf")
            for _ in range(args.repeat):
                start = time.perf_counter()
                table = read_table(path)
                best = min(best, time.perf_counter() - start)
            start = time.perf_counter()
            proc = subprocess.run(
                [sys.executable, "-m", "mdl", "csv2xml", str(path), "--ini", str(ini), "-o", str(folder / "out.xml")],
                capture_output=True,
                text=True,
            )
            whole = time.perf_counter() - start
            status = "" if proc.returncode == 0 else f"  exit {proc.returncode}: {proc.stderr.strip()[-200:]}"
            size = path.stat().st_size
            print(f"{fmt:8} {size:>10,} {best:>10.2f}s {whole:>11.2f}s  {len(table.rows):,}{status}")


if __name__ == "__main__":
    main()
