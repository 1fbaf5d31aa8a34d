"""`mdl csv2xml`: read the INI and the table, match functions to rows, write MDL.

Every guess is said as a note on stderr naming the INI key that overrides it; every row that cannot
be read is a warning with its CSV line; a summary line ends the run. Notes print once the table has
been read and matched (an error ends the run with errors only)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import click

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.fileio import write_atomic
from mdl.model import Device, Function
from mdl.model.names import unique_identifiers
from mdl.sources.csvmap.address_base import guess_address_base
from mdl.sources.csvmap.cells import CellError, access_words
from mdl.sources.csvmap.columns import Columns, resolve
from mdl.sources.csvmap.count_unit import count_unit
from mdl.sources.csvmap.explain import explain, nearest
from mdl.sources.csvmap.ini import DeviceIni, read_ini
from mdl.sources.csvmap.match import Candidate, Index, assign, best
from mdl.sources.csvmap.report import Progress, Report
from mdl.sources.csvmap.rows import ParsedRow, RowSettings, parse_row
from mdl.sources.csvmap.synonyms import DEFAULT_SYNONYMS
from mdl.sources.csvmap.table import Row, Table, find_header, read_table
from mdl.sources.mdlxml.parse import schema_errors, secure_parser
from mdl.sources.mdlxml.write import device_to_xml

DEFAULT_THRESHOLD = 0.6
DELIMITER_NAMES = {",": "comma", ";": "semicolon", "\t": "tab", "|": "pipe"}
LONG_TABLE = 2000  # rows from which the row reading shows progress on a terminal


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


@dataclass
class Parsed:
    """The table as rows csv2xml can use, and what reading it took."""

    rows: list[ParsedRow]
    read: int  # rows with an address
    skipped: int  # of them, rows that could not be read


def _settings(table: Table, cols: Columns, data: list[Row], ini: DeviceIni | None, report: Report) -> RowSettings:
    """How the rows are read: the INI's word, else a guess that is said."""
    where = str(table.path)
    dev = ini.device if ini else {}
    base = dev.get("address_base")
    guessed_base = base is None
    if base is None:
        guess = guess_address_base(data, cols.index["addresses"], cols.header_of("addresses"),
                                   cols.index.get("register_type"))
        base = guess.base
        if guess.note:
            report.note(where, guess.note)
    unit, unit_note = count_unit(cols, data, dev.get("count_unit"))
    if unit_note:
        report.note(where, unit_note)
    w_alone = "write"
    if "access" in cols.index:
        cells = [r.cell(cols.index["access"]) for r in data if r.cell(cols.index["access"])]
        w_alone = access_words(cells)
        if w_alone == "read_write" and any(c.strip().lower() == "w" for c in cells):
            report.note(where, f"{cols.describe(cols.index['access'])} holds only the letters R and W: W is read as "
                               "writable (read and write); a table that also writes R/W would make W write-only")
    decimal = (ini.decimal if ini else None) or "auto"
    return RowSettings(base, unit, dev.get("register_type"), dev.get("byte_order"), dev.get("word_order"),
                       decimal, w_alone, guessed_base)


def _read_rows(table: Table, cols: Columns, data: list[Row], st: RowSettings, report: Report) -> Parsed:
    where = str(table.path)
    rows: list[ParsedRow] = []
    read = skipped = 0
    comma_said = False
    progress = Progress("mdl csv2xml: reading rows", len(data)) if len(data) >= LONG_TABLE else None
    report.progress = progress
    for row in data:
        if progress:
            progress()
        try:
            parsed = parse_row(row, cols, st)
        except CellError as exc:
            read += 1
            skipped += 1
            report.warn(Diagnostic(where, row.line, None, f"row skipped: {exc}", "warning"))
            continue
        if parsed:
            read += 1
            rows.append(parsed)
            if parsed.comma and not comma_said:
                comma_said = True
                report.note(where, f"decimal comma: '{parsed.comma}' on line {row.line} (and any like it) is read "
                                   "with ',' as the decimal mark; set decimal_separator = point in [Input/Output] "
                                   "if ',' groups thousands")
    if progress:
        progress.close()
    report.progress = None
    return Parsed(rows, read, skipped)


def _functions(ini: DeviceIni | None) -> dict[str, list[str]]:
    if ini and ini.synonyms:
        functions = dict(DEFAULT_SYNONYMS) if ini.default_synonyms else {}
        for name, words in ini.synonyms.items():
            functions[name] = words + [w for w in functions.get(name, []) if w not in words]
    else:
        functions = dict(DEFAULT_SYNONYMS)
    return {name: words + [name.replace("_", " ")] for name, words in functions.items()}


def _choose_interactive(functions: dict[str, list[str]], index: Index, rows: list[ParsedRow]) -> dict[str, Candidate]:
    chosen: dict[str, Candidate] = {}
    used: set[int] = set()
    for name, phrases in functions.items():
        options = best(name, phrases, index, used, 9)
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


def _table_notes(table: Table, report: Report) -> None:
    where = str(table.path)
    if table.markdown:
        report.note(where, "a Markdown table: the | at both ends of each row and the |---| rule are not cells; "
                           "set delimiter = pipe in [Input/Output] to read every | as a cell boundary")
    elif table.delimiter_guessed and table.delimiter != ",":
        name = DELIMITER_NAMES[table.delimiter]
        report.note(where, f"cells separated by {name}s (the character that splits the first lines most evenly); "
                           f"set delimiter = comma, semicolon, tab or pipe in [Input/Output] to override")


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'s' * (n != 1)}"


@dataclass
class Options:
    interactive: bool = False
    threshold: float | None = None
    emit_all: bool = False
    explain: tuple[str, ...] = ()


def convert(csv_path: Path, ini: DeviceIni | None, opts: Options, report: Report) -> Device | None:
    """The device the table describes (None with --explain, which prints instead)."""
    table = read_table(csv_path, ini.delimiter if ini else None)
    header, data = _split_rows(table, ini)
    cols = resolve(table, header, data, ini)
    if "addresses" not in cols.index:
        raise error("no address column: name it in the INI ([Column/Field Indices] addresses = N) "
                    "or give it a header such as 'Address' or 'Register'", csv_path, header.line if header else None)
    _table_notes(table, report)
    for message in cols.notes:
        report.note(str(csv_path), message)
    parsed = _read_rows(table, cols, data, _settings(table, cols, data, ini, report), report)
    if not parsed.rows:
        col = cols.describe(cols.index["addresses"])
        raise error(f"no row of the table has a usable address (addresses read from {col})", csv_path)

    functions = _functions(ini)
    index = Index([r.texts for r in parsed.rows])
    if opts.threshold is not None:
        limit = opts.threshold
    else:
        limit = ini.threshold if ini and ini.threshold is not None else DEFAULT_THRESHOLD
    lines = [r.row.line for r in parsed.rows]
    if opts.explain:
        report.flush_notes()
        explain(opts.explain, functions, index, lines, assign(functions, index, limit), limit)
        return None
    if opts.interactive:
        report.flush_notes()
        chosen = _choose_interactive(functions, index, parsed.rows)
    else:
        progress = Progress("mdl csv2xml: matching", len(functions)) if len(lines) >= LONG_TABLE else None
        chosen = assign(functions, index, limit, progress)
        if progress:
            progress.close()
    own = bool(ini and ini.synonyms)
    missing = [n for n in functions if n not in chosen]
    if missing and own and not opts.interactive:
        details = ", ".join(nearest(n, functions[n], index, lines, chosen) for n in missing)
        report.warn(Diagnostic(str(ini.path if ini else csv_path), None, None,
                               f"no row reached the threshold {limit:g} for: {details}; "
                               "--explain NAME lists a function's nearest rows", "warning"))
    out, extra = _functions_out(parsed.rows, chosen, opts.emit_all)
    listed = ("function" if len(chosen) == 1 else "functions") + ("" if own else " of the bundled list")
    summary = (f"summary: {_count(parsed.read, 'row')} read, {parsed.skipped} skipped; {len(chosen)} {listed} "
               f"matched, {len(missing)} {'unmatched' if own else 'not found'}")
    report.note(str(csv_path), summary + (f"; {_count(extra, 'more row')} emitted (--all)" if extra else ""))
    if not out:
        raise error("no function matched a row; add synonyms to the INI, lower --threshold, or use --all "
                    "(--explain NAME lists a function's nearest rows)", csv_path)
    dev = ini.device if ini else {}
    device = Device(dev.get("device_name") or csv_path.stem,
                    dev.get("device_description") or f"Converted from {csv_path.name} by mdl csv2xml", out)
    if device.extensions():
        device.version = "1.0"
    return device


def _functions_out(rows: list[ParsedRow], chosen: dict[str, Candidate], emit_all: bool) -> tuple[list[Function], int]:
    """The chosen rows' functions under their names, then with --all every other row under its label;
    and how many of those others there were."""
    out = []
    for name, cand in chosen.items():
        fn = rows[cand.row_index].function
        fn.name = name
        out.append(fn)
    if not emit_all:
        return out, 0
    used = {c.row_index for c in chosen.values()}
    rest = [pr for i, pr in enumerate(rows) if i not in used]
    names = unique_identifiers([f.name for f in out] + [pr.label for pr in rest])[len(out):]
    for pr, name in zip(rest, names, strict=True):
        pr.function.name = name
        out.append(pr.function)
    return out, len(rest)


def _self_check(xml: str, device: Device) -> None:
    from lxml import etree

    tree = etree.fromstring(xml.encode("ascii"), secure_parser()).getroottree()
    problems = schema_errors(tree, "<csv2xml output>", device.schema_version)
    if problems:
        raise MdlError([Diagnostic(None, None, None, f"internal error, output does not validate: {p}")
                        for p in problems])


def run_csv2xml(source: Path, ini_path: Path | None, output: Path | None, interactive: bool,
                threshold: float | None, emit_all: bool, *, fail_on_warning: bool = False, strict: bool = False,
                explain: tuple[str, ...] = ()) -> None:
    """Convert and write; with fail_on_warning (--strict, --fail-on-warning), a warning (a skipped row,
    an unmatched function, an unknown INI key) is an error: nothing is written, exit 1. With `explain`,
    print each named function's nearest rows to stdout instead of writing MDL."""
    from mdl.resolve import resolve as resolve_device

    report = Report()
    ini = None
    csv_given: Path | None = source
    if ini_path is None and _is_ini(source):
        ini_path, csv_given = source, None
    if ini_path is not None:
        ini = read_ini(ini_path)
        for w in ini.warnings:
            report.warn(w)
    csv_path = csv_given or (ini.csv_file if ini else None)
    if csv_path is None:
        raise error("the INI names no address_map_csv_file in [Input/Output]; give the CSV on the command line",
                    ini_path)
    device = convert(csv_path, ini, Options(interactive, threshold, emit_all, explain), report)
    if device is None:
        return
    for diag in resolve_device(device, str(csv_path)).warnings:  # the checks every description passes
        report.warn(diag)
    report.flush_notes()
    if (fail_on_warning or strict) and report.warnings:
        n = len(report.warnings)
        flag = "--strict" if strict else "--fail-on-warning"
        raise error(f"{n} warning{'s' * (n != 1)} and {flag}: nothing written", ini_path or csv_path)
    xml = device_to_xml(device)
    _self_check(xml, device)
    target = output if output is not None else (ini.output_file if ini else None)
    if target is None or str(target) == "-":
        sys.stdout.write(xml)
        sys.stdout.flush()
    else:
        write_atomic(target, xml)
        click.echo(f"wrote {target}: {len(device.functions)} functions, MDL {device.schema_version}", err=True)
