"""`mdl csv2xml`'s conversion: the table (and its INI) -> the device, each function matched to its row.

Every guess is a note naming the INI key that overrides it; every row that cannot be read is a
warning with its CSV line; a summary note ends the conversion. All of them go to the Report given
(mdl.formats.table.report, which prints them). Nothing here asks the user (the interactive choice
is a `Chooser` given in Options: mdl.cli.interactive) or writes a file (the command that
writes is mdl.cli.csv2xml; where it may write, mdl.formats.table.target)."""

from __future__ import annotations

import gc
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.formats.table.address_base import guess_address_base
from mdl.formats.table.cells import CellError, access_words
from mdl.formats.table.columns import Columns, resolve
from mdl.formats.table.count_unit import count_unit
from mdl.formats.table.explain import BUDGET, explain, nearest
from mdl.formats.table.ini import DeviceIni
from mdl.formats.table.match import Candidate, Index, assign, candidates
from mdl.formats.table.overrides import read_with_sections
from mdl.formats.table.readers.delimited import DELIMITER_NAMES, Row, Table, find_header, read_table
from mdl.formats.table.readers.document import ini_choice
from mdl.formats.table.report import Progress, Report
from mdl.formats.table.rows import (
    COMMA,
    NATIVE,
    NO_RANGE,
    SCALED_LIMITS,
    UNIT_ALONE,
    WIDTHLESS,
    FieldError,
    ParsedRow,
    RowSettings,
    parse_row,
    row_texts,
    scale_raw_limits,
)
from mdl.formats.table.scoring import EXACT, FUZZY, TIER_NAMES, FunctionName, Score
from mdl.formats.table.synonyms import DEFAULT_SYNONYMS
from mdl.formats.table.vocabulary import FunctionSection, apply_sections, multiplier_of, number_of
from mdl.model import Device, Function
from mdl.model.names import unique_identifiers

DEFAULT_THRESHOLD = 0.6
# functions (name -> phrases), the index of the rows, the rows -> the row chosen for each function
Chooser = Callable[[dict[str, list[str]], Index, list[ParsedRow]], dict[str, Candidate]]
LONG_TABLE = 2000  # rows from which the row reading shows progress on a terminal


def _split_rows(table: Table, ini: DeviceIni | None) -> tuple[Row | None, list[Row]]:
    texts = [c for c in (ini.columns.values() if ini else []) if isinstance(c, str)]
    if ini and ini.lines_to_skip is not None:
        skipped = [r for r in table.rows if r.line <= ini.lines_to_skip]
        header = find_header(table, ini.lines_to_skip, texts or None) if skipped else None
        if header is None and skipped and not texts:
            header = skipped[-1]
        if texts and header is None:
            raise error(
                f"no row among the {ini.lines_to_skip} skipped lines holds the header texts "
                f"{', '.join(repr(t) for t in texts)}",
                table.path,
            )
        return header, [r for r in table.rows if r.line > ini.lines_to_skip]
    header = find_header(table, None, texts or None)
    if header is None and texts:
        raise error(f"no row holds the header texts {', '.join(repr(t) for t in texts)} named in the INI", table.path)
    if header is None:
        if ini and ini.columns and not texts and "addresses" in ini.columns:
            return None, table.rows
        raise error(
            "no recognizable header row (expected a column such as 'Address', 'Register', "
            "'Reg No' or 'Modbus Address', and a description column)",
            table.path,
            table.rows[0].line,
        )
    return header, [r for r in table.rows if r.line > header.line]


@dataclass
class Skipped:
    """A row with an address that could not be read: still matched, so that a function whose row it is
    is told so rather than given another."""

    row: Row
    texts: list[str]
    reason: str
    key: str | None = None  # the field whose cell could not be read


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
        guess = guess_address_base(
            data, cols.index["addresses"], cols.header_of("addresses"), cols.index.get("register_type")
        )
        base = guess.base
        if guess.note:
            report.note(guess.note, file=where)
    unit, unit_note = count_unit(cols, data, dev.get("count_unit"))
    if unit_note:
        report.note(unit_note, file=where)
    w_alone = "write"
    if "access" in cols.index:
        cells = [r.cell(cols.index["access"]) for r in data if r.cell(cols.index["access"])]
        w_alone = access_words(cells)
        if w_alone == "read_write" and any(c.strip().lower() == "w" for c in cells):
            report.note(
                f"{cols.describe(cols.index['access'])} holds only the letters R and W: W is read as "
                "writable (read and write); a table that also writes R/W would make W write-only",
                file=where,
            )
    if "word_order" in cols.index:
        report.note(
            f"{cols.describe(cols.index['word_order'])} gives each row's word order: TRUE reverses the "
            "registers of a value from its type's order (big; little for a '<' struct type), FALSE "
            "keeps it, big/little or ABCD/CDAB/BADC/DCBA name it; it wins over [Modbus Device] "
            "word_order; set word_order = (blank) in [Column/Field Indices] to ignore it",
            file=where,
        )
    decimal = (ini.decimal if ini else None) or "auto"
    return RowSettings(
        base,
        unit,
        dev.get("register_type"),
        dev.get("byte_order"),
        dev.get("word_order"),
        decimal,
        w_alone,
        guessed_base,
        ini.cells if ini else {},
        {"raw": True, "scaled": False}.get(dev.get("limits", "")),
    )


def _guess_notes(cols: Columns) -> dict[str, str]:
    """What each guess a row can make says, for the first cell read so ({cell}, {line})."""
    scale = cols.index.get("divisor", cols.index.get("multiplier"))
    scale_key = "divisor" if "divisor" in cols.index else "multiplier"
    return {
        COMMA: "decimal comma: '{cell}' on line {line} (and any like it) is read with ',' as the decimal mark; "
        "set decimal_separator = point in [Input/Output] if ',' groups thousands",
        UNIT_ALONE: (
            f"{cols.describe(scale) if scale is not None else 'the scale column'} is both {scale_key} and "
            "units: '{cell}' on line {line} (a unit with no number before it, and any like it) is read as "
            "scale 1 in that unit; write the scale before the unit (1W) if it is another"
        ),
        WIDTHLESS: "format '{cell}' on line {line} (and any like it) gives no width: read as one register (16 bits); "
        "if the table means 32 bits, write INT32/UINT32 there or give the row a count of 2 "
        "(count = N in [Column/Field Indices])",
        NATIVE: "struct type '{cell}' on line {line} (and any like it) has the byte order of the host that reads "
        "it: read as little-endian (x86 and ARM hosts); write '<' or '>' to say which",
        SCALED_LIMITS: "minimum/maximum '{cell}' on line {line} (and any like it, on a scaled row) read in engineering "
        "units, as the value reads after its scale; set limits = raw in [Modbus Device] if the table gives them "
        "as register values (before the scale), limits = scaled to silence this",
        NO_RANGE: "minimum/maximum '{cell}' on line {line} (and any like it) is no range (the minimum is the maximum): "
        "read as no limits",
    }


def _not_a_register(row: Row, cols: Columns, header: list[str] | None) -> str | None:
    """What a row is that holds no register: the header repeated (a new page or section of the table),
    or a section title written in the address column alone ('COIL REGISTERS'); None for any other."""
    first = row.cell(cols.index["addresses"]).lstrip()[:1] if "addresses" in cols.index else ""
    if first.isdigit():  # most rows: an address
        return None
    cells = [" ".join(c.split()).lower() for c in row.cells]
    while cells and not cells[-1]:
        cells.pop()
    i = cols.index.get("addresses")
    if header is not None and i is not None and i < min(len(cells), len(header)) and cells[i] == header[i] != "":
        same = sum(1 for k, c in enumerate(cells) if c and k < len(header) and c == header[k])
        if 2 * same > sum(1 for c in cells if c):  # its address cell and most others are the header's
            return "repeats the header"
    filled = [k for k, c in enumerate(cells) if c]
    if i is not None and filled == [i] and (not any(ch.isdigit() for ch in cells[i]) or len(cells[i].split()) > 4):
        return f"is a title or a remark ('{row.cell(i).strip()[:40]}' alone, in the address column)"
    return None


def _read_rows(
    table: Table, cols: Columns, data: list[Row], st: RowSettings, report: Report, header: Row | None = None
) -> Parsed:
    where = str(table.path)
    rows: list[ParsedRow] = []
    skipped: list[Skipped] = []
    read = 0
    said: set[str] = set()
    notes = _guess_notes(cols)
    health = Health()
    progress = report.bar("mdl csv2xml: reading rows", len(data)) if len(data) >= LONG_TABLE else None
    report.progress = progress
    header_cells = [" ".join(c.split()).lower() for c in header.cells] if header is not None else None
    at = cols.index.get("addresses")
    for row in data:
        if progress:
            progress()
        # a row whose address cell starts with a digit is a register (_not_a_register's first test)
        kind = None if at is not None and row.cell(at)[:1].isdigit() else _not_a_register(row, cols, header_cells)
        if kind is not None:
            if kind not in said:
                said.add(kind)
                report.note(f"line {row.line} {kind}: not read as a register (nor any like it)", row.line, file=where)
            continue
        try:
            parsed = parse_row(row, cols, st)
        except CellError as exc:
            read += 1
            if isinstance(exc, FieldError):
                health.failed.setdefault(exc.key, (str(exc), row.line))
            skipped.append(
                Skipped(row, row_texts(row, cols), str(exc), exc.key if isinstance(exc, FieldError) else None)
            )
            report.warn(f"row skipped: {exc}", row.line, file=where)
            continue
        if parsed:
            read += 1
            rows.append(parsed)
            health.ok.update(parsed.ok)
            for key, problem in parsed.problems:
                if key:  # a cell that could not be read (not one read but doubtful)
                    health.failed.setdefault(key, (problem, row.line))
                report.warn(problem, row.line, file=where)
            for kind, cell in parsed.guesses.items():
                if kind not in said:
                    said.add(kind)
                    report.note(notes[kind].format(cell=cell, line=row.line), file=where)
            for kind, message in parsed.notes:
                if kind not in said:
                    said.add(kind)
                    report.note(message, row.line, file=where)
    if progress:
        progress.close()
    report.progress = None
    _dead_columns(table, cols, health)
    return Parsed(rows, read, skipped)


@dataclass
class Health:
    """Which fields' cells were read, and the first that could not be (its message and line)."""

    ok: set[str] = field(default_factory=set)
    failed: dict[str, tuple[str, int]] = field(default_factory=dict)


def _dead_columns(table: Table, cols: Columns, health: Health) -> None:
    """One error for each column the INI named whose every cell could not be read (SPEC 4.1)."""
    dead = [
        (key, message, line)
        for key, (message, line) in health.failed.items()
        if key in cols.index and key not in cols.guessed and key not in health.ok
    ]
    if dead:
        raise MdlError(
            [
                Diagnostic(
                    str(table.path),
                    line,
                    None,
                    f"no cell of {cols.describe(cols.index[key])} (named as {key} in the INI) could be read as "
                    f"{key}, the first on line {line}: {message.split(': ', 1)[-1]}; name another column "
                    f"or map its cells in [{key} cells]",
                )
                for key, message, line in dead
            ]
        )


def _functions(ini: DeviceIni | None) -> dict[str, list[str]]:
    if ini and ini.synonyms:
        functions = dict(DEFAULT_SYNONYMS) if ini.default_synonyms else {}
        for name, words in ini.synonyms.items():
            functions[name] = words + [w for w in functions.get(name, []) if w not in words]
    else:
        functions = dict(DEFAULT_SYNONYMS)
    for name in ini.functions if ini else {}:  # a [function NAME] of no synonyms is searched by its name
        functions.setdefault(name, [])
    return {name: words + [FunctionName(name.replace("_", " "))] for name, words in functions.items()}


def _name_sections(ini: DeviceIni, report: Report) -> None:
    """Section names are case-insensitive (SPEC 4.1): a [function NAME] whose NAME is a function of the
    synonyms written another way (`[function amp_L1]` for `amp_l1`) is that function's, with a note."""
    known = set(ini.synonyms) | (set(DEFAULT_SYNONYMS) if ini.default_synonyms or not ini.synonyms else set())
    spelled: dict[str, list[str]] = {}
    for name in known:
        spelled.setdefault(name.lower(), []).append(name)
    named: dict[str, FunctionSection] = {}
    for name, fs in ini.functions.items():
        same = spelled.get(name.lower(), [])
        if name not in known and len(same) == 1:  # the INI has one section per name, in any case (ini.py)
            report.note(f"[function {name}] is the section of {same[0]}", fs.line, file=str(ini.path))
            fs.name = name = same[0]
        named[name] = fs
    ini.functions = named


def _forced(ini: DeviceIni | None, parsed: Parsed, places: dict[int, str]) -> dict[str, int]:
    """[function NAME] row = N (or a PDF's `p14:r7`): NAME -> the index of the row on line N (an error if
    it has none)."""
    out: dict[str, int] = {}
    if ini is None:
        return out
    at = {r.row.line: i for i, r in enumerate(parsed.rows)}
    skipped = {s.row.line: s.reason for s in parsed.skipped}
    lines = {place: line for line, place in places.items()}
    for name, fs in ini.functions.items():
        if "row" not in fs.values:
            continue
        given = fs.values["row"]
        if given.startswith("p") and given not in lines:
            why = "no row of the table read stands there" if places else "only a PDF table's rows are named so"
            raise error(f"[function {name}] row = {given}: {why}", ini.path, fs.lines.get("row"))
        line = lines[given] if given.startswith("p") else int(given)
        row = places.get(line, f"line {line}")
        if line in skipped:
            why = f"{row} of the table was skipped ({skipped[line]})"
        elif line not in at:
            why = f"{row} of the table holds no row with an address"
        elif at[line] in out.values():
            why = f"{row} is already the row of another [function] section"
        else:
            out[name] = at[line]
            continue
        raise error(f"[function {name}] row = {given}: {why}", ini.path, fs.lines.get("row"))
    return out


def _table_notes(table: Table, ini: DeviceIni | None, report: Report) -> None:
    where = str(table.path)
    if table.encoding_guess:
        report.note(table.encoding_guess.note(ini is not None), file=where)
    for message in table.notes:  # which table of a Markdown, HTML or Excel file was read
        report.note(message, file=where)
    if table.markdown:
        report.note(
            "a Markdown table: the | at both ends of each row and the |---| rule are not cells; "
            "set delimiter = pipe in [Input/Output] to read every | as a cell boundary",
            file=where,
        )
    elif table.delimiter_guessed and table.delimiter != ",":
        name = DELIMITER_NAMES[table.delimiter]
        report.note(
            f"cells separated by {name}s (the character that splits the first lines most evenly); "
            f"set delimiter = comma, semicolon, tab or pipe in [Input/Output] to override",
            file=where,
        )


def counted(n: int, what: str) -> str:
    return f"{n} {what}{'s' * (n != 1)}"


@dataclass
class Options:
    choose: Chooser | None = None  # the user picks each function's row (--interactive)
    threshold: float | None = None
    emit_all: bool = False
    explain: tuple[str, ...] = ()
    strict: bool = False  # a function matched by similarity only is a warning, not a note


@dataclass
class Matched:
    """Each function its row, and the functions whose best row could not be read (its Candidate)."""

    chosen: dict[str, Candidate]
    lost: dict[str, Candidate]


def _match(
    functions: dict[str, list[str]], index: Index, readable: int, limit: float, progress: Progress | None = None
) -> Matched:
    """Rows at and after `readable` are skipped rows: matched like the others, so that a function
    whose best row was skipped is left unmatched (and told) rather than given a lesser row."""
    chosen = assign(functions, index, limit, progress)
    lost = {name: c for name, c in chosen.items() if c.row_index >= readable}
    return Matched({name: c for name, c in chosen.items() if name not in lost}, lost)


def _shown(text: str, width: int = 50) -> str:
    text = " ".join(text.split())
    return text if len(text) <= width else text[: width - 3] + "..."


def _row_text(index: Index, row: int) -> str:
    return _shown(index.texts[row][0].raw) if index.texts[row] else ""


def _instead(
    name: str, phrases: list[str], index: Index, readable: int, used: set[int], limit: float, lines: list[int]
) -> str:
    """`; left unmatched rather than given line 2 'PV2 voltage' (fuzzy 0.72)`, or the bare first part."""
    for c in candidates(name, phrases, index, limit, BUDGET):
        if c.row_index < readable and c.row_index not in used:
            return (
                f"; left unmatched rather than given line {lines[c.row_index]} '{_row_text(index, c.row_index)}' "
                f"({TIER_NAMES[c.score.tier]} {c.score})"
            )
    return "; left unmatched"


def _say_matches(
    where: str,
    functions: dict[str, list[str]],
    index: Index,
    parsed: Parsed,
    matched: Matched,
    limit: float,
    lines: list[int],
    opts: Options,
    own: bool,
    report: Report,
) -> None:
    """A warning for each function whose best row was skipped (a note for the bundled list's functions,
    which the user did not ask for: the row's own warning has been said); a note (a warning with
    --strict) for each function matched by similarity only."""
    readable = len(parsed.rows)
    used = {c.row_index for c in matched.chosen.values()}
    for name, c in matched.lost.items():
        skipped = parsed.skipped[c.row_index - readable]
        instead = _instead(name, functions[name], index, readable, used, limit, lines)
        message = (
            f"{name}: line {skipped.row.line} names it ({TIER_NAMES[c.score.tier]} {c.score}: "
            f"'{_row_text(index, c.row_index)}') but was skipped ({skipped.reason}){instead}"
        )
        if own:
            report.warn(message, skipped.row.line, file=where)
        else:
            report.note(message, skipped.row.line, file=where)
    for name, c in matched.chosen.items():
        if c.score.tier != FUZZY:
            _say_tie(where, name, c, index, readable, used, lines, own, report)
            continue
        line = lines[c.row_index]
        message = (
            f"{name} matched by similarity only: line {line} '{_row_text(index, c.row_index)}' "
            f"(score {c.score}; none of its synonyms stands there as a phrase); if that is not its row, "
            f"add the right row's words as a synonym (--explain {name} lists its nearest rows)"
        )
        if opts.strict:
            report.warn(message + "; --strict refuses it", line, file=where)
        else:
            report.note(message, line, file=where)


def _say_tie(
    where: str,
    name: str,
    chosen: Candidate,
    index: Index,
    readable: int,
    used: set[int],
    lines: list[int],
    own: bool,
    report: Report,
) -> None:
    """A function whose row's text stands as well in another row no function took (a vendor's table
    that lists one text twice): the first row was taken, which is a guess; say it and how to choose."""
    # rows whose texts are the chosen row's, word for word (found through the index's exact entries)
    texts = [t.norm for t in index.texts[chosen.row_index]]
    rivals = sorted(
        {
            r
            for t in texts[:1]
            for r in index.exact.get(t, ())
            if r != chosen.row_index and r < readable and r not in used and [u.norm for u in index.texts[r]] == texts
        }
    )
    if not rivals:
        return
    line, other = lines[chosen.row_index], lines[rivals[0]]
    message = (
        f"{name}: lines {line} and {other} match it alike ({TIER_NAMES[chosen.score.tier]} {chosen.score}: "
        f"'{_row_text(index, chosen.row_index)}' and '{_row_text(index, rivals[0])}'): line {line}, "
        f"the first, is taken; `row = {other}` in [function {name}] takes the other"
    )
    if own:
        report.warn(message, line, file=where)
    else:
        report.note(message, line, file=where)


def _say_idle_cells(ini: DeviceIni | None, cols: Columns, report: Report) -> None:
    """A `[<field> cells]` map for a field no column is read as maps nothing: its cells are read as
    something else, or not at all (a column named for another key takes the one a header would give)."""
    if ini is None:
        return
    for name in ini.cells:
        if name not in cols.index:
            report.warn(
                f"[{name} cells] maps nothing: no column is read as {name} (name it in [Column/Field Indices]: "
                f"{name} = N or its header; a column another key names is not guessed for {name})",
                ini.line("cells", name),
                file=str(ini.path),
            )


def _raw_limits(ini: DeviceIni, functions: list[Function]) -> None:
    """`limits = raw`: each table limit scaled as its value is, with the multiplier and offset the
    function ends with (a [function NAME] multiplier or offset included); limits the section gives are
    its own, in engineering units."""
    if ini.device.get("limits") != "raw":
        return
    for fn in functions:
        fs = ini.functions.get(fn.name)
        values = fs.values if fs is not None else {}
        given = {k: getattr(fn, k) for k in ("minimum", "maximum") if k in values}
        scale = multiplier_of(fs) if fs is not None and ({"multiplier", "divisor"} & set(values)) else fn.multiplier
        offset = number_of(values["offset"], "offset") if "offset" in values else fn.offset
        scale_raw_limits(fn, scale, offset)
        for key, value in given.items():  # the section's own (it sets them again, with its note)
            setattr(fn, key, value)


def _roles_by_name(functions: list[Function], ini: DeviceIni, report: Report) -> None:
    """A function the INI names after a profile's role (`power_w = Total active power`) plays that role
    (SPEC 13), unless its [function NAME] says another; a note lists them."""
    unset = [fn for fn in functions if fn.role is None and fn.name in ini.synonyms]
    if not unset:
        return
    from mdl.profiles.shipped import keyed

    if not keyed(fn.name for fn in unset):  # no profile has a key of these names: no YAML read
        return
    from mdl.profiles.load import shipped_roles

    roles = shipped_roles()
    named = [fn for fn in unset if fn.name in roles]
    for fn in named:
        fn.role = fn.name
    if named:
        listed = ", ".join(f"{fn.name} ({'/'.join(roles[fn.name])})" for fn in named)
        report.note(
            f"functions named after a profile's role play it: {listed}; `role =` in [function NAME] says another",
            file=str(ini.path),
        )


def _read_chosen(csv_path: Path, ini: DeviceIni | None, report: Report) -> Table:
    """The table, with the INI's `table`/`sheet` and `pages` choosing among a document's tables and
    pages unless the command line chose, and the header texts its columns are named by choosing the
    table where no number or sheet does."""
    if ini is None:
        return read_table(csv_path)
    key = "table" if ini.table is not None else "sheet"
    where = (ini.path or csv_path, ini.line("io", key))
    pages = (ini.pages, (ini.path or csv_path, ini.line("io", "pages"))) if ini.pages is not None else None
    texts = tuple(c for c in ini.columns.values() if isinstance(c, str))
    with ini_choice(ini.table, ini.sheet, where, pages, texts) as overridden:
        for note in overridden:
            report.note(note, where[1], file=str(where[0]))
        return read_table(csv_path, ini.delimiter, ini.encoding)


def convert(csv_path: Path, ini: DeviceIni | None, opts: Options, report: Report) -> Device | None:
    """The device the table describes (None with --explain, which prints instead); an error at a row of
    a PDF's table names the row's place (`manual.pdf:p14:r7`), as warnings do."""
    table = _read_chosen(csv_path, ini, report)
    report.located(str(csv_path), table.places)
    try:
        with _collector_paused():
            return _convert(csv_path, table, ini, opts, report)
    except MdlError as exc:
        if not table.places:
            raise
        raise MdlError([report.placed(d) for d in exc.diagnostics], exc.exit_code) from None


@contextmanager
def _collector_paused() -> Iterator[None]:
    """Python's cycle collector paused while the rows are read and matched: they build objects that are
    all kept (a function, an index entry per row), which each collection would walk again, a tenth of
    the work on a long table; what they drop is freed as it goes (no cycles), anything else once it
    is on again. (Not while a document is read: a PDF's layout objects do hold cycles.)"""
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


def _convert(csv_path: Path, table: Table, ini: DeviceIni | None, opts: Options, report: Report) -> Device | None:
    header, data = _split_rows(table, ini)
    cols = resolve(table, header, data, ini)
    _say_idle_cells(ini, cols, report)
    if "addresses" not in cols.index:
        raise error(
            "no address column: name it in the INI ([Column/Field Indices] addresses = N) "
            "or give it a header such as 'Address' or 'Register'",
            csv_path,
            header.line if header else None,
        )
    _table_notes(table, ini, report)
    for message in cols.notes:
        report.note(message, file=str(csv_path))
    settings = _settings(table, cols, data, ini, report)
    parsed = _read_rows(table, cols, data, settings, report, header)
    if not parsed.rows:
        col = cols.describe(cols.index["addresses"])
        raise error(f"no row of the table has a usable address (addresses read from {col})", csv_path)

    if ini is not None:
        _name_sections(ini, report)
    functions = _functions(ini)
    forced = _forced(ini, parsed, table.places)
    taken = set(forced.values())  # rows the INI gave a function: no other function is matched to them
    index = Index(
        [[] if i in taken else r.texts for i, r in enumerate(parsed.rows)] + [s.texts for s in parsed.skipped]
    )
    for name, row_index in forced.items():
        report.note(
            f"{name}: {table.name_of(parsed.rows[row_index].row.line)} of the table, as [function {name}] row says",
            ini.functions[name].lines.get("row") if ini else None,
            file=str(ini.path if ini else csv_path),
        )
    matching = {name: words for name, words in functions.items() if name not in forced}
    if opts.threshold is not None:
        limit = opts.threshold
    else:
        limit = ini.threshold if ini and ini.threshold is not None else DEFAULT_THRESHOLD
    lines = [r.row.line for r in parsed.rows] + [s.row.line for s in parsed.skipped]
    readable = len(parsed.rows)
    own = bool(ini and ini.synonyms)
    found: dict[int, ParsedRow] = {}  # skipped rows read after all with a [function] section (by index)
    if opts.explain:
        report.flush_notes()
        matched = _match(matching, index, readable, limit)
        matched.chosen.update({name: Candidate(name, i, Score(EXACT, 1.0)) for name, i in forced.items()})
        skipped = {readable + i: s.reason for i, s in enumerate(parsed.skipped)}
        explain(opts.explain, functions, index, lines, matched.chosen, limit, skipped, matched.lost, table.name_of)
        return None
    if opts.choose is not None:
        report.flush_notes()
        matched = Matched(opts.choose(matching, index, parsed.rows), {})
    else:
        progress = (
            report.bar(f"mdl csv2xml: matching {counted(len(functions), 'function')}", 2 * len(functions), percent=True)
            if len(lines) >= LONG_TABLE
            else None
        )
        matched = _match(matching, index, readable, limit, progress)
        if progress:
            progress.close()
        if ini is not None and matched.lost:
            rescued = read_with_sections(
                {name: c.row_index - readable for name, c in matched.lost.items()},
                [(s.row, s.key) for s in parsed.skipped],
                ini,
                cols,
                settings,
                report,
            )
            for name, row in rescued.items():
                matched.chosen[name] = matched.lost.pop(name)
                found[matched.chosen[name].row_index] = row
        if opts.emit_all and not own:
            _keep_own_names(matched, str(csv_path), report)
        _say_matches(str(csv_path), matching, index, parsed, matched, limit, lines, opts, own, report)
    chosen = matched.chosen
    if ini is None:
        chosen = _own_names(chosen, parsed, str(csv_path), report)
    for name, row_index in forced.items():
        chosen[name] = Candidate(name, row_index, Score(EXACT, 1.0))
    missing = [n for n in functions if n not in chosen]
    unreached = [n for n in missing if n not in matched.lost]
    if unreached and own and opts.choose is None:
        details = ", ".join(nearest(n, functions[n], index, lines, chosen, table.name_of) for n in unreached)
        report.warn(
            f"no row reached the threshold {limit:g} for: {details}; --explain NAME lists a function's nearest rows",
            file=str(ini.path if ini else csv_path),
        )
    rows = [*parsed.rows, *(found.get(readable + i) for i in range(len(parsed.skipped)))]
    out, extra = _functions_out(rows, chosen, opts.emit_all)
    if ini is not None:
        _raw_limits(ini, out)
        apply_sections(ini.functions, str(ini.path), out, report, matched.lost)
        _roles_by_name(out, ini, report)
    listed = ("function" if len(chosen) == 1 else "functions") + ("" if own else " of the bundled list")
    summary = (
        f"summary: {counted(parsed.read, 'row')} read, {len(parsed.skipped)} skipped; {len(chosen)} {listed} "
        f"matched, {len(missing)} {'unmatched' if own else 'not found'}"
    )
    report.note(summary + (f"; {counted(extra, 'more row')} emitted (--all)" if extra else ""), file=str(csv_path))
    if not out and matched.lost:
        raise error(
            f"no function matched a row that could be read: the best row of {', '.join(matched.lost)} was "
            "skipped (see the warnings above); fix that row, or add synonyms to the INI",
            csv_path,
        )
    if not out:
        raise error(
            "no function matched a row; add synonyms to the INI, lower --threshold, or use --all "
            "(--explain NAME lists a function's nearest rows)",
            csv_path,
        )
    dev = ini.device if ini else {}
    device = Device(
        dev.get("device_name") or csv_path.stem,
        dev.get("device_description") or f"Converted from {csv_path.name} by mdl csv2xml",
        out,
    )
    if device.extensions():
        device.version = "1.0"
    return device


def _own_names(chosen: dict[str, Candidate], parsed: Parsed, where: str, report: Report) -> dict[str, Candidate]:
    """Without an INI, a row with a name of its own (a name column's cell) keeps it: the bundled list
    names only rows that have none (SPEC 4.1)."""
    out: dict[str, Candidate] = {}
    kept = []
    for name, c in chosen.items():
        pr = parsed.rows[c.row_index] if c.row_index < len(parsed.rows) else None
        if pr is not None and len(pr.texts) > 1 and pr.label:
            kept.append((name, pr.label))
            continue
        out[name] = c
    if not kept:
        return chosen
    taken = list(out)
    own = unique_identifiers(taken + [label for _, label in kept])[len(taken) :]
    renamed = {name: new for (name, _), new in zip(kept, own, strict=True)}
    result = {renamed.get(name, name): c for name, c in chosen.items()}
    shown_pairs = ", ".join(f"{new} (not {name})" for name, new in list(renamed.items())[:4])
    report.note(
        f"{counted(len(renamed), 'row')} keep the names of their own name column over the bundled list's: "
        f"{shown_pairs}{' ...' if len(renamed) > 4 else ''}; an INI's [Function Name Search Synonyms] names rows",
        file=where,
    )
    return result


def _keep_own_names(matched: Matched, where: str, report: Report) -> None:
    """With --all and the bundled list, a row matched to one of its functions by similarity alone keeps
    its own name: similarity says a row may be that function, not that it is (`energy_voltage_68` is no
    `total_energy`)."""
    fuzzy = sorted(name for name, c in matched.chosen.items() if c.score.tier == FUZZY)
    for name in fuzzy:
        del matched.chosen[name]
    if fuzzy:
        report.note(
            f"{counted(len(fuzzy), 'row')} only similar to the bundled list's {', '.join(fuzzy[:5])}"
            f"{' ...' if len(fuzzy) > 5 else ''} {'keeps its own name' if len(fuzzy) == 1 else 'keep their own names'} "
            "(--all); [Functions] in an INI names rows",
            file=where,
        )


def _functions_out(
    rows: list[ParsedRow | None], chosen: dict[str, Candidate], emit_all: bool
) -> tuple[list[Function], int]:
    """The chosen rows' functions under their names, then with --all every other row under its label;
    and how many of those others there were. `rows` holds the skipped rows after the others (None, or
    the row read after all with a [function] section)."""
    out = []
    for name, cand in chosen.items():
        row = rows[cand.row_index]
        assert row is not None  # a function is given a skipped row only once it is read
        fn = row.function
        fn.name = name
        out.append(fn)
    if not emit_all:
        return out, 0
    used = {c.row_index for c in chosen.values()}
    rest = [pr for i, pr in enumerate(rows) if i not in used and pr is not None]
    names = unique_identifiers([f.name for f in out] + [pr.label for pr in rest])[len(out) :]
    for pr, name in zip(rest, names, strict=True):
        pr.function.name = name
        out.append(pr.function)
    return out, len(rest)
