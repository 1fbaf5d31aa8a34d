#!/usr/bin/env python3
"""How long `mdl csv2xml` takes on PDF manuals (SPEC 4.2: a 300-page manual reads in under 10 s and
500 MB). Prints figures; asserts nothing.

    python3 bench/pdf_bench.py                  # the corpus manuals, then a 300-page manual
    python3 bench/pdf_bench.py --pages 600

No public manual in the corpus is 300 pages long, so the long one is made from real ones: the
register-table pages of the corpus manuals (tests/data/corpus/pdf/), copied with pypdfium2 again and
again to PAGES pages, every page a real vendor's table. Each run is `mdl csv2xml FILE --all` as a
child process: its wall time, CPU time (user + system) and peak resident memory (ru_maxrss from
wait4), with the targets beside them.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "data" / "corpus" / "pdf"
# (manual, its register-table pages, 1-based)
TABLE_PAGES = [
    ("sungrow_sh_hybrid_protocol_v1.1.15.pdf", range(6, 17)),
    ("pace_bms_modbus_v1.3.pdf", range(7, 10)),
    ("abb_terra_ac_modbus_v1.7.pdf", range(6, 7)),
    ("epever_tracer_protocol_v2.3.pdf", range(4, 14)),
    ("noark_ex9em_register_map.pdf", range(1, 2)),
]


def long_manual(path: Path, pages: int) -> None:
    import pypdfium2 as pdfium  # type: ignore[import-untyped]

    out = pdfium.PdfDocument.new()
    sources = [(pdfium.PdfDocument(str(CORPUS / name)), [p - 1 for p in span]) for name, span in TABLE_PAGES]
    while len(out) < pages:
        for doc, indices in sources:
            take = indices[: pages - len(out)]
            if take:
                out.import_pages(doc, take)
    out.save(str(path))


def run(args: list[str]) -> tuple[float, float, int, int]:
    """(wall s, CPU s, peak RSS MB, exit status) of `mdl ARGS` as a child process."""
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "mdl", *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert proc.stderr is not None
    proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - start
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss // 1024, proc.returncode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pages", type=int, default=300, help="pages of the long manual (default 300)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        manuals = [(name, CORPUS / name) for name, _ in TABLE_PAGES]
        long = folder / f"manual_{args.pages}_pages.pdf"
        long_manual(long, args.pages)
        manuals.append((long.name, long))
        print(f"{'manual':44} {'pages':>5} {'wall':>8} {'CPU':>8} {'peak':>7}  per page (CPU)")
        import pypdfium2 as pdfium

        for name, path in manuals:
            pages = len(pdfium.PdfDocument(str(path)))
            wall, cpu, peak, status = run(["csv2xml", str(path), "--all", "-q", "-o", str(folder / "out.xml")])
            said = "" if status == 0 else f"  (exit {status})"
            print(f"{name:44} {pages:>5} {wall:>7.2f}s {cpu:>7.2f}s {peak:>5}MB  {1000 * cpu / pages:.0f} ms{said}")
        print(f"target (SPEC 4.2): 300 pages in under 10 s and 500 MB: {10_000 / 300:.0f} ms a page")


if __name__ == "__main__":
    main()
