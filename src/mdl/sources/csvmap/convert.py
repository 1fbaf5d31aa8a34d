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
from mdl.sources.csvmap.explain import BUDGET, explain, nearest
from mdl.sources.csvmap.ini import DeviceIni, is_ini, read_ini
from mdl.sources.csvmap.match import Candidate, Index, assign, best, candidates
from mdl.sources.csvmap.report import Progress, Report
from mdl.sources.csvmap.rows import COMMA, NATIVE, UNIT_ALONE, WIDTHLESS, ParsedRow, RowSettings, parse_row, row_texts
from mdl.sources.csvmap.scoring import FUZZY, TIER_NAMES, FunctionName
from mdl.sources.csvmap.synonyms import DEFAULT_SYNONYMS
from mdl.sources.csvmap.table import DELIMITER_NAMES, Row, Table, find_header, read_table
from mdl.sources.mdlxml.parse import schema_errors, secure_parser
from mdl.sources.mdlxml.write import device_to_xml

DEFAULT_THRESHOLD = 0.6
LONG_TABLE = 2000  # rows from which the row reading shows progress on a terminal


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
class Skipped:
    """A row with an address that could not be read: still matched, so that a function whose row it is
    is told so rather than given another."""

    row: Row
    texts: list[str]
    reason: str


@dataclass
class Parsed:
    """The table as rows csv2xml can use, and what reading it took."""

    rows: list[ParsedRow]
    read: int  # rows with an address
    skipped: list[Skipped]  # of them, rows that could not be read


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
    if "word_order" in cols.index:
        report.note(where, f"{cols.describe(cols.index['word_order'])} gives each row's word order: TRUE reverses the "
                           "registers of a value from its type's order (big; little for a '<' struct type), FALSE "
                           "keeps it, big/little or ABCD/CDAB/BADC/DCBA name it; it wins over [Modbus Device] "
                           "word_order; set word_order = (blank) in [Column/Field Indices] to ignore it")
    decimal = (ini.decimal if ini else None) or "auto"
    return RowSettings(base, unit, dev.get("register_type"), dev.get("byte_order"), dev.get("word_order"),
                       decimal, w_alone, guessed_base)


def _guess_notes(cols: Columns) -> dict[str, str]:
    """What each guess a row can make says, for the first cell read so ({cell}, {line})."""
    scale = cols.index.get("divisor", cols.index.get("multiplier"))
    scale_key = "divisor" if "divisor" in cols.index else "multiplier"
    return {
        COMMA: "decimal comma: '{cell}' on line {line} (and any like it) is read with ',' as the decimal mark; "
               "set decimal_separator = point in [Input/Output] if ',' groups thousands",
        UNIT_ALONE: (f"{cols.describe(scale) if scale is not None else 'the scale column'} is both {scale_key} and "
                     "units: '{cell}' on line {line} (a unit with no number before it, and any like it) is read as "
                     "scale 1 in that unit; write the scale before the unit (1W) if it is another"),
        WIDTHLESS: "format '{cell}' on line {line} (and any like it) gives no width: read as one register (16 bits); "
                   "if the table means 32 bits, write INT32/UINT32 there or give the row a count of 2 "
                   "(count = N in [Column/Field Indices])",
        NATIVE: "struct type '{cell}' on line {line} (and any like it) has the byte order of the host that reads "
                "it: read as little-endian (x86 and ARM hosts); write '<' or '>' to say which",
    }


def _read_rows(table: Table, cols: Columns, data: list[Row], st: RowSettings, report: Report) -> Parsed:
    where = str(table.path)
    rows: list[ParsedRow] = []
    skipped: list[Skipped] = []
    read = 0
    said: set[str] = set()
    notes = _guess_notes(cols)
    progress = Progress("mdl csv2xml: reading rows", len(data)) if len(data) >= LONG_TABLE else None
    report.progress = progress
    for row in data:
        if progress:
            progress()
        try:
            parsed = parse_row(row, cols, st)
        except CellError as exc:
            read += 1
            skipped.append(Skipped(row, row_texts(row, cols), str(exc)))
            report.warn(Diagnostic(where, row.line, None, f"row skipped: {exc}", "warning"))
            continue
        if parsed:
            read += 1
            rows.append(parsed)
            for kind, cell in parsed.guesses.items():
                if kind not in said:
                    said.add(kind)
                    report.note(where, notes[kind].format(cell=cell, line=row.line))
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
    return {name: words + [FunctionName(name.replace("_", " "))] for name, words in functions.items()}


def _choose_interactive(functions: dict[str, list[str]], index: Index, rows: list[ParsedRow]) -> dict[str, Candidate]:
    chosen: dict[str, Candidate] = {}
    used: set[int] = set(range(len(rows), index.rows))  # the skipped rows: not to be chosen
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


def _table_notes(table: Table, ini: DeviceIni | None, report: Report) -> None:
    where = str(table.path)
    if table.encoding_guess:
        report.note(where, table.encoding_guess.note(ini is not None))
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
    strict: bool = False  # a function matched by similarity only is a warning, not a note


@dataclass
class Matched:
    """Each function its row, and the functions whose best row could not be read (its Candidate)."""

    chosen: dict[str, Candidate]
    lost: dict[str, Candidate]


def _match(functions: dict[str, list[str]], index: Index, readable: int, limit: float,
           progress: Progress | None = None) -> Matched:
    """Rows at and after `readable` are skipped rows: matched like the others, so that a function
    whose best row was skipped is left unmatched (and told) rather than given a lesser row."""
    chosen = assign(functions, index, limit, progress)
    lost = {name: c for name, c in chosen.items() if c.row_index >= readable}
    return Matched({name: c for name, c in chosen.items() if name not in lost}, lost)


def _shown(text: str, width: int = 50) -> str:
    text = " ".join(text.split())
    return text if len(text) <= width else text[:width - 3] + "..."


def _row_text(index: Index, row: int) -> str:
    return _shown(index.texts[row][0].raw) if index.texts[row] else ""


def _instead(name: str, phrases: list[str], index: Index, readable: int, used: set[int], limit: float,
             lines: list[int]) -> str:
    """`; left unmatched rather than given line 2 'PV2 voltage' (fuzzy 0.72)`, or the bare first part."""
    for c in candidates(name, phrases, index, limit, BUDGET):
        if c.row_index < readable and c.row_index not in used:
            return (f"; left unmatched rather than given line {lines[c.row_index]} '{_row_text(index, c.row_index)}' "
                    f"({TIER_NAMES[c.score.tier]} {c.score})")
    return "; left unmatched"


def _say_matches(where: str, functions: dict[str, list[str]], index: Index, parsed: Parsed, matched: Matched,
                 limit: float, lines: list[int], opts: Options, own: bool, report: Report) -> None:
    """A warning for each function whose best row was skipped (a note for the bundled list's functions,
    which the user did not ask for: the row's own warning has been said); a note (a warning with
    --strict) for each function matched by similarity only."""
    readable = len(parsed.rows)
    used = {c.row_index for c in matched.chosen.values()}
    for name, c in matched.lost.items():
        skipped = parsed.skipped[c.row_index - readable]
        instead = _instead(name, functions[name], index, readable, used, limit, lines)
        message = (f"{name}: line {skipped.row.line} names it ({TIER_NAMES[c.score.tier]} {c.score}: "
                   f"'{_row_text(index, c.row_index)}') but was skipped ({skipped.reason}){instead}")
        if own:
            report.warn(Diagnostic(where, skipped.row.line, None, message, "warning"))
        else:
            report.note(where, message, skipped.row.line)
    for name, c in matched.chosen.items():
        if c.score.tier != FUZZY:
            continue
        line = lines[c.row_index]
        message = (f"{name} matched by similarity only: line {line} '{_row_text(index, c.row_index)}' "
                   f"(score {c.score}; none of its synonyms stands there as a phrase); if that is not its row, "
                   f"add the right row's words as a synonym (--explain {name} lists its nearest rows)")
        if opts.strict:
            report.warn(Diagnostic(where, line, None, message + "; --strict refuses it", "warning"))
        else:
            report.note(where, message, line)


def convert(csv_path: Path, ini: DeviceIni | None, opts: Options, report: Report) -> Device | None:
    """The device the table describes (None with --explain, which prints instead)."""
    table = read_table(csv_path, ini.delimiter if ini else None, ini.encoding if ini else None)
    header, data = _split_rows(table, ini)
    cols = resolve(table, header, data, ini)
    if "addresses" not in cols.index:
        raise error("no address column: name it in the INI ([Column/Field Indices] addresses = N) "
                    "or give it a header such as 'Address' or 'Register'", csv_path, header.line if header else None)
    _table_notes(table, ini, report)
    for message in cols.notes:
        report.note(str(csv_path), message)
    parsed = _read_rows(table, cols, data, _settings(table, cols, data, ini, report), report)
    if not parsed.rows:
        col = cols.describe(cols.index["addresses"])
        raise error(f"no row of the table has a usable address (addresses read from {col})", csv_path)

    functions = _functions(ini)
    index = Index([r.texts for r in parsed.rows] + [s.texts for s in parsed.skipped])
    if opts.threshold is not None:
        limit = opts.threshold
    else:
        limit = ini.threshold if ini and ini.threshold is not None else DEFAULT_THRESHOLD
    lines = [r.row.line for r in parsed.rows] + [s.row.line for s in parsed.skipped]
    readable = len(parsed.rows)
    own = bool(ini and ini.synonyms)
    if opts.explain:
        report.flush_notes()
        matched = _match(functions, index, readable, limit)
        skipped = {readable + i: s.reason for i, s in enumerate(parsed.skipped)}
        explain(opts.explain, functions, index, lines, matched.chosen, limit, skipped, matched.lost)
        return None
    if opts.interactive:
        report.flush_notes()
        matched = Matched(_choose_interactive(functions, index, parsed.rows), {})
    else:
        progress = (Progress(f"mdl csv2xml: matching {_count(len(functions), 'function')}", 2 * len(functions),
                             percent=True) if len(lines) >= LONG_TABLE else None)
        matched = _match(functions, index, readable, limit, progress)
        if progress:
            progress.close()
        _say_matches(str(csv_path), functions, index, parsed, matched, limit, lines, opts, own, report)
    chosen = matched.chosen
    missing = [n for n in functions if n not in chosen]
    unreached = [n for n in missing if n not in matched.lost]
    if unreached and own and not opts.interactive:
        details = ", ".join(nearest(n, functions[n], index, lines, chosen) for n in unreached)
        report.warn(Diagnostic(str(ini.path if ini else csv_path), None, None,
                               f"no row reached the threshold {limit:g} for: {details}; "
                               "--explain NAME lists a function's nearest rows", "warning"))
    out, extra = _functions_out(parsed.rows, chosen, opts.emit_all)
    listed = ("function" if len(chosen) == 1 else "functions") + ("" if own else " of the bundled list")
    summary = (f"summary: {_count(parsed.read, 'row')} read, {len(parsed.skipped)} skipped; {len(chosen)} {listed} "
               f"matched, {len(missing)} {'unmatched' if own else 'not found'}")
    report.note(str(csv_path), summary + (f"; {_count(extra, 'more row')} emitted (--all)" if extra else ""))
    if not out and matched.lost:
        raise error(f"no function matched a row that could be read: the best row of {', '.join(matched.lost)} was "
                    "skipped (see the warnings above); fix that row, or add synonyms to the INI", csv_path)
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
    if ini_path is None and is_ini(source):
        ini_path, csv_given = source, None
    if ini_path is not None:
        ini = read_ini(ini_path)
        for w in ini.warnings:
            report.warn(w)
        for said in ini.notes:
            report.note(said.file, said.message)
    csv_path = csv_given or (ini.csv_file if ini else None)
    if csv_path is None:
        raise error("the INI names no address_map_csv_file in [Input/Output]; give the CSV on the command line",
                    ini_path)
    if ini is not None and csv_given is None and not csv_path.exists():
        raise error(f"address_map_csv_file names {csv_path}: no such file", ini.path,
                    ini.line("io", "address_map_csv_file"))
    device = convert(csv_path, ini, Options(interactive, threshold, emit_all, explain, strict), report)
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
    target = output  # chosen and checked by the caller (csvmap/target.py)
    if target is None or str(target) == "-":
        sys.stdout.write(xml)
        sys.stdout.flush()
    else:
        write_atomic(target, xml)
        click.echo(f"wrote {target}: {_count(len(device.functions), 'function')}, MDL {device.schema_version}",
                   err=True)
