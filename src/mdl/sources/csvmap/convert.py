"""`mdl csv2xml`: read the INI and the table, match functions to rows, write MDL."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.fileio import write_atomic
from mdl.model import Device
from mdl.model.names import unique_identifiers
from mdl.sources.csvmap.cells import CellError
from mdl.sources.csvmap.columns import resolve
from mdl.sources.csvmap.ini import DeviceIni, read_ini
from mdl.sources.csvmap.match import Candidate, assign, rank
from mdl.sources.csvmap.rows import ParsedRow, RowSettings, guess_address_base, parse_row
from mdl.sources.csvmap.synonyms import DEFAULT_SYNONYMS
from mdl.sources.csvmap.table import Row, Table, find_header, read_table
from mdl.sources.mdlxml.parse import schema_errors, secure_parser
from mdl.sources.mdlxml.write import device_to_xml

DEFAULT_THRESHOLD = 0.6


_warned: list[Diagnostic] = []  # this run's warnings (--fail-on-warning)


def _warn(diag: Diagnostic) -> None:
    _warned.append(diag)
    click.echo(str(diag), err=True)


def _is_ini(path: Path) -> bool:
    return path.suffix.lower() in (".ini", ".cfg", ".conf")


def _split_rows(table: Table, ini: DeviceIni | None) -> tuple[Row | None, list[Row]]:
    texts = [c for c in (ini.columns.values() if ini else []) if isinstance(c, str)]
    if ini and ini.lines_to_skip is not None:
        skipped = [r for r in table.rows if r.line <= ini.lines_to_skip]
        header = find_header(table, ini.lines_to_skip, texts or None) if skipped else None
        if header is None and skipped and not texts:
            header = skipped[-1]
        if texts and header is None:
            raise error(f"no row among the {ini.lines_to_skip} skipped lines holds the header texts "
                        f"{', '.join(repr(t) for t in texts)}", table.path)
        return header, [r for r in table.rows if r.line > ini.lines_to_skip]
    header = find_header(table, None, texts or None)
    if header is None and texts:
        raise error(f"no row holds the header texts {', '.join(repr(t) for t in texts)} named in the INI",
                    table.path)
    if header is None:
        if ini and ini.columns and not texts and "addresses" in ini.columns:
            return None, table.rows
        raise error("no recognizable header row (expected a column such as 'Address', 'Register', "
                    "'Reg No' or 'Modbus Address', and a description column)", table.path,
                    table.rows[0].line)
    return header, [r for r in table.rows if r.line > header.line]


def _choose_interactive(ranked: dict[str, list[Candidate]], rows: list[ParsedRow]) -> dict[str, Candidate]:
    chosen: dict[str, Candidate] = {}
    used: set[int] = set()
    for name, cands in ranked.items():
        options = [c for c in cands if c.row_index not in used][:9]
        click.echo(f"\nfunction '{name}': which row?", err=True)
        for n, c in enumerate(options, 1):
            pr = rows[c.row_index]
            text = " ".join(pr.function.description.split())[:70]
            click.echo(f"  {n}. [{c.score}] line {pr.row.line}: {text}", err=True)
        click.echo("  0. skip this function", err=True)
        pick = click.prompt("choice", type=click.IntRange(0, len(options)), default=1 if options else 0, err=True)
        if pick:
            chosen[name] = options[pick - 1]
            used.add(options[pick - 1].row_index)
    return chosen


def convert(
    csv_path: Path, ini: DeviceIni | None, interactive: bool, threshold: float | None, emit_all: bool
) -> Device:
    table = read_table(csv_path)
    header, data = _split_rows(table, ini)
    cols = resolve(table, header, data, ini)
    if "addresses" not in cols.index:
        raise error("no address column: name it in the INI ([Column/Field Indices] addresses = N) "
                    "or give it a header such as 'Address' or 'Register'", csv_path, header.line if header else None)
    dev = ini.device if ini else {}
    count_unit = dev.get("count_unit") or ("bytes" if "byte" in cols.header_of("count").lower() else "words")
    hex_header = "hex" in cols.header_of("addresses").lower()
    base = dev.get("address_base") or guess_address_base(data, cols.index["addresses"], hex_header)
    settings = RowSettings(base, count_unit, dev.get("register_type"), dev.get("byte_order"), dev.get("word_order"),
                           table.decimal_comma)
    rows: list[ParsedRow] = []
    for row in data:
        try:
            parsed = parse_row(row, cols, settings)
        except CellError as exc:
            _warn(Diagnostic(str(csv_path), row.line, None, f"row skipped: {exc}", "warning"))
            continue
        if parsed:
            rows.append(parsed)
    if not rows:
        raise error("no row of the table has a usable address", csv_path)

    if ini and ini.synonyms:
        functions = dict(DEFAULT_SYNONYMS) if ini.default_synonyms else {}
        for name, words in ini.synonyms.items():
            functions[name] = words + [w for w in functions.get(name, []) if w not in words]
    else:
        functions = dict(DEFAULT_SYNONYMS)
    functions = {name: words + [name.replace("_", " ")] for name, words in functions.items()}
    ranked = rank(functions, [r.texts for r in rows])
    if threshold is not None:
        limit = threshold
    else:
        limit = ini.threshold if ini and ini.threshold is not None else DEFAULT_THRESHOLD
    chosen = _choose_interactive(ranked, rows) if interactive else assign(ranked, limit)

    out = []
    for name, cand in chosen.items():
        pr = rows[cand.row_index]
        pr.function.name = name
        out.append(pr.function)
    missing = [n for n in functions if n not in chosen]
    if missing and (ini and ini.synonyms and not interactive):
        details = ", ".join(f"{n} (best {ranked[n][0].score})" if ranked[n] else n for n in missing)
        _warn(Diagnostic(str(ini.path if ini else csv_path), None, None,
                         f"no row reached the threshold {limit:g} for: {details}", "warning"))
    if emit_all:
        used = {c.row_index for c in chosen.values()}
        extra = [pr for i, pr in enumerate(rows) if i not in used]
        names = unique_identifiers([f.name for f in out] + [pr.label for pr in extra])[len(out):]
        for pr, name in zip(extra, names, strict=True):
            pr.function.name = name
            out.append(pr.function)
    if not out:
        raise error("no function matched a row; add synonyms to the INI, lower --threshold, or use --all", csv_path)
    name = dev.get("device_name") or csv_path.stem
    description = dev.get("device_description") or f"Converted from {csv_path.name} by mdl csv2xml"
    device = Device(name, description, out)
    if device.extensions():
        device.version = "1.0"
    return device


def _self_check(xml: str, device: Device) -> None:
    from lxml import etree

    tree = etree.fromstring(xml.encode("ascii"), secure_parser()).getroottree()
    problems = schema_errors(tree, "<csv2xml output>", device.schema_version)
    if problems:
        raise MdlError([Diagnostic(None, None, None, f"internal error, output does not validate: {p}")
                        for p in problems])


def run_csv2xml(source: Path, ini_path: Path | None, output: Path | None, interactive: bool,
                threshold: float | None, emit_all: bool, *, fail_on_warning: bool = False) -> None:
    """Convert and write; with fail_on_warning, a warning (a skipped row, an unknown INI key) is an
    error: nothing is written, exit 1."""
    from mdl.resolve import resolve

    _warned.clear()
    ini = None
    csv_given: Path | None = source
    if ini_path is None and _is_ini(source):
        ini_path, csv_given = source, None
    if ini_path is not None:
        ini = read_ini(ini_path)
        for w in ini.warnings:
            _warn(w)
    csv_path = csv_given or (ini.csv_file if ini else None)
    if csv_path is None:
        raise error("the INI names no address_map_csv_file in [Input/Output]; give the CSV on the command line",
                    ini_path)
    device = convert(csv_path, ini, interactive, threshold, emit_all)
    for diag in resolve(device, str(csv_path)).warnings:  # the checks every description passes
        _warn(diag)
    if fail_on_warning and _warned:
        n = len(_warned)
        raise error(f"{n} warning{'s' * (n != 1)} and --fail-on-warning: nothing written", ini_path or csv_path)
    xml = device_to_xml(device)
    _self_check(xml, device)
    target = output if output is not None else (ini.output_file if ini else None)
    if target is None or str(target) == "-":
        sys.stdout.write(xml)
        sys.stdout.flush()
    else:
        write_atomic(target, xml)
        click.echo(f"wrote {target}: {len(device.functions)} functions, MDL {device.schema_version}", err=True)
