"""`mdl csv2xml` as a command: the INI read, the conversion (mdl.formats.table.convert) run with its
report printed, the device checked as every description is, and the MDL written where
mdl.formats.table.target said (stdout, or a file written whole or not at all)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mdl.diagnostics import error
from mdl.fileio import write_atomic
from mdl.formats.mdl.load import check_written
from mdl.formats.mdl.write import device_to_xml
from mdl.formats.table.convert import Options, convert, counted
from mdl.formats.table.ini import is_ini, read_ini
from mdl.formats.table.report import Report


def run_csv2xml(
    source: Path,
    ini_path: Path | None,
    output: Path | None,
    interactive: bool,
    threshold: float | None,
    emit_all: bool,
    *,
    fail_on_warning: bool = False,
    strict: bool = False,
    explain: tuple[str, ...] = (),
    quiet: bool = False,
) -> None:
    """Convert and write to `output` (None: stdout; chosen and checked by csvmap/target.py); with
    fail_on_warning (--strict, --fail-on-warning), a warning (a skipped row, an unmatched function, an
    unknown INI key) is an error: nothing is written, exit 1. With `explain`, print each named
    function's nearest rows to stdout instead of writing MDL. Quiet: warnings and errors only."""
    from mdl.cli.interactive import choose_rows
    from mdl.resolver import resolve as resolve_device

    report = Report(quiet)
    ini = None
    csv_given: Path | None = source
    if ini_path is None and is_ini(source):
        ini_path, csv_given = source, None
    if ini_path is not None:
        ini = read_ini(ini_path)
        for w in ini.warnings:
            report.add(w)
        for said in ini.notes:
            report.note(said.message, file=said.file)
    csv_path = csv_given or (ini.csv_file if ini else None)
    if csv_path is None:
        raise error(
            "the INI names no address_map_csv_file in [Input/Output]; give the CSV on the command line", ini_path
        )
    if ini is not None and csv_given is None and not csv_path.exists():
        raise error(
            f"address_map_csv_file names {csv_path}: no such file", ini.path, ini.line("io", "address_map_csv_file")
        )
    opts = Options(choose_rows if interactive else None, threshold, emit_all, explain, strict)
    device = convert(csv_path, ini, opts, report)
    if device is None:
        return
    for diag in resolve_device(device, str(csv_path)).warnings:  # the checks every description passes
        report.add(diag)
    report.flush_notes()
    n = report.counts["warning"]
    if (fail_on_warning or strict) and n:
        flag = "--strict" if strict else "--fail-on-warning"
        raise error(f"{n} warning{'s' * (n != 1)} and {flag}: nothing written", ini_path or csv_path)
    xml = check_written(device_to_xml(device), "csv2xml")
    if output is None:
        sys.stdout.write(xml)
        sys.stdout.flush()
    else:
        write_atomic(output, xml)
        if not quiet:
            click.echo(
                f"wrote {output}: {counted(len(device.functions), 'function')}, MDL {device.schema_version}", err=True
            )
