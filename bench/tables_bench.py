#!/usr/bin/env python3
"""How long csv2xml's readers take on one 5,000-row register table published as CSV, Markdown, HTML,
Excel (.xlsx), OpenDocument (.ods) and a PDF manual (SPEC 4.1: an Excel or HTML table of 5,000 rows
reads in under 5 s; SPEC 4.2: a 300-page manual in under 10 s and 500 MB). For each format it prints
the file's size, the time to read it into rows (mdl.formats.table.readers.delimited.read_table, best of
--repeat), and the wall time, CPU time (user + system) and peak resident memory (ru_maxrss from wait4)
of the whole `mdl csv2xml FILE --ini INI --all` as a child process (reading, matching the INI's
synonyms, writing every row as MDL), with the functions it wrote. Asserts nothing.

The .ods is written with the standard library (a zip of content.xml); the PDF with pypdfium2: A4 pages
of 40 rows under the header repeated on each, every cell ruled, Helvetica text. No .xls: writing one
needs xlwt, which mdl does not depend on (xlrd only reads them).

    python3 bench/tables_bench.py                 # 5,000 rows
    python3 bench/tables_bench.py --rows 20000 --repeat 1
"""

from __future__ import annotations

import argparse
import ctypes
import html
import os
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

HEADER = ["Register", "Description", "Data Type", "Multiplier", "Units", "Access"]
INI = "[Function Name Search Synonyms]\nroom_temperature = room temperature 15\nfan_speed = fan speed 4001\n"
A4 = (595.0, 842.0)  # points
PDF_ROWS = 40  # table rows a page, under the header
PDF_WIDTHS = [60.0, 150.0, 70.0, 70.0, 50.0, 50.0]  # points, one a column
ODS = "urn:oasis:names:tc:opendocument:xmlns:"
ODS_TYPE = "application/vnd.oasis.opendocument.spreadsheet"


def rows(n: int) -> list[list[str]]:
    words = ["room temperature", "fan speed", "phase voltage", "total power", "energy import"]
    return [HEADER] + [
        [str(i), f"{words[i % len(words)]} {i}", "int16" if i % 2 else "uint16", "0.1", "V", "R"] for i in range(n)
    ]


def write_csv(path: Path, table: list[list[str]]) -> None:
    path.write_text("\n".join(",".join(r) for r in table) + "\n")


def write_md(path: Path, table: list[list[str]]) -> None:
    md = ["| " + " | ".join(table[0]) + " |", "|" + "---|" * len(table[0])]
    path.write_text("\n".join(md + ["| " + " | ".join(r) + " |" for r in table[1:]]) + "\n")


def write_html(path: Path, table: list[list[str]]) -> None:
    cells = ("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in table)
    path.write_text("<html><body><table>\n" + "\n".join(cells) + "\n</table></body></html>\n")


def write_xlsx(path: Path, table: list[list[str]]) -> None:
    import openpyxl  # type: ignore[import-untyped]

    book = openpyxl.Workbook()
    for r in table:
        book.active.append([int(c) if c.isdigit() else c for c in r])
    book.save(path)


def write_ods(path: Path, table: list[list[str]]) -> None:
    """A minimal OpenDocument spreadsheet: numbers as floats, other cells as strings, as in the .xlsx."""

    def cell(c: str) -> str:
        kind = f'"float" office:value="{c}"' if c.isdigit() else '"string"'
        return f"<table:table-cell office:value-type={kind}><text:p>{html.escape(c)}</text:p></table:table-cell>"

    body = "\n".join("<table:table-row>" + "".join(cell(c) for c in r) + "</table:table-row>" for r in table)
    content = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<office:document-content xmlns:office="{ODS}office:1.0" xmlns:table="{ODS}table:1.0" '
        f'xmlns:text="{ODS}text:1.0" office:version="1.2"><office:body><office:spreadsheet>\n'
        f'<table:table table:name="Registers">\n{body}\n</table:table>\n'
        "</office:spreadsheet></office:body></office:document-content>\n"
    )
    manifest = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<manifest:manifest xmlns:manifest="{ODS}manifest:1.0" manifest:version="1.2">\n'
        f'<manifest:file-entry manifest:full-path="/" manifest:media-type="{ODS_TYPE}"/>\n'
        '<manifest:file-entry manifest:full-path="content.xml" manifest:media-type="text/xml"/>\n'
        "</manifest:manifest>\n"
    )
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as ods:
        ods.writestr(zipfile.ZipInfo("mimetype"), ODS_TYPE)  # first, stored
        ods.writestr("META-INF/manifest.xml", manifest)
        ods.writestr("content.xml", content)


def write_pdf(path: Path, table: list[list[str]]) -> None:
    """A4 pages of PDF_ROWS rows under the header (bold, repeated on each page), every cell ruled."""
    import pypdfium2 as pdfium  # type: ignore[import-untyped]
    import pypdfium2.raw as c  # type: ignore[import-untyped]

    pdf = pdfium.PdfDocument.new()
    height, margin = 18.0, 50.0
    xs = [margin + sum(PDF_WIDTHS[:i]) for i in range(len(PDF_WIDTHS) + 1)]
    for first in range(1, len(table), PDF_ROWS):
        page = pdf.new_page(*A4)
        lines = [table[0]] + table[first : first + PDF_ROWS]
        ys = [A4[1] - margin - height * i for i in range(len(lines) + 1)]
        for i, row in enumerate(lines):
            for x, text in zip(xs[:-1], row, strict=True):
                obj = c.FPDFPageObj_NewTextObj(pdf.raw, b"Helvetica-Bold" if i == 0 else b"Helvetica", 9.0)
                utf16 = (text + "\0").encode("utf-16-le")  # kept alive: a cast of a temporary may point at freed memory
                c.FPDFText_SetText(obj, ctypes.cast(utf16, c.FPDF_WIDESTRING))
                c.FPDFPageObj_Transform(obj, 1, 0, 0, 1, x + 3, ys[i + 1] + 5.5)
                c.FPDFPage_InsertObject(page.raw, obj)
        rules = [(x, ys[-1], x, ys[0]) for x in xs] + [(xs[0], y, xs[-1], y) for y in ys]
        for x0, y0, x1, y1 in rules:
            rule = c.FPDFPageObj_CreateNewPath(x0, y0)
            c.FPDFPath_LineTo(rule, x1, y1)
            c.FPDFPageObj_SetStrokeWidth(rule, 0.5)
            c.FPDFPath_SetDrawMode(rule, c.FPDF_FILLMODE_NONE, True)
            c.FPDFPage_InsertObject(page.raw, rule)
        page.gen_content()
        page.close()
    pdf.save(path)
    pdf.close()


WRITERS = {"csv": write_csv, "md": write_md, "html": write_html, "xlsx": write_xlsx, "ods": write_ods, "pdf": write_pdf}


def run(args: list[str]) -> tuple[float, float, int, str]:
    """(wall s, CPU s, peak RSS MB, what went wrong or "") of `mdl ARGS` as a child process."""
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "mdl", *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert proc.stderr is not None
    stderr = proc.stderr.read().decode(errors="replace")
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - start
    said = "" if proc.returncode == 0 else f"  exit {proc.returncode}: {stderr.strip()[-200:]}"
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss // 1024, said


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rows", type=int, default=5000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    from mdl.formats.table.readers.delimited import read_table

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        table = rows(args.rows)
        ini = folder / "map.ini"
        ini.write_text(INI)
        print(f"{args.rows:,} rows x {len(HEADER)} columns (.xls not written: that needs xlwt, not a dependency)")
        print(f"{'format':6} {'size':>10} {'write':>7} {'read_table':>10}  rows  ", end="")
        print(f"{'csv2xml':>7} {'CPU':>7} {'peak':>7}  functions")
        for fmt, write in WRITERS.items():
            path = folder / f"map.{fmt}"
            start = time.perf_counter()
            write(path, table)
            written = time.perf_counter() - start
            best = float("inf")
            for _ in range(args.repeat):
                start = time.perf_counter()
                read = read_table(path)
                best = min(best, time.perf_counter() - start)
            out = folder / f"{fmt}.xml"
            wall, cpu, peak, said = run(["csv2xml", str(path), "--ini", str(ini), "--all", "-q", "-o", str(out)])
            functions = out.read_text().count("<function>") if out.exists() else 0
            print(
                f"{fmt:6} {path.stat().st_size:>10,} {written:>6.2f}s {best:>9.2f}s {len(read.rows):>5,}  "
                f"{wall:>6.2f}s {cpu:>6.2f}s {peak:>5}MB  {functions:,}{said}"
            )
        print("targets: SPEC 4.1 a 5,000-row Excel or HTML table under 5 s; SPEC 4.2 300 PDF pages under 10 s, 500 MB")


if __name__ == "__main__":
    main()
