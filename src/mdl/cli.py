"""The `mdl` command: options -> one library call -> diagnostics -> exit status (SPEC section 1)."""

from __future__ import annotations

import gc
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

import click

from mdl import __version__, engines, formats, targets
from mdl.device.connection import Connection, connection_options
from mdl.diagnostics import EXIT_INVALID, Diagnostic, MdlError
from mdl.fileio import STDIO_ARG, input_path, is_stdin

if TYPE_CHECKING:
    from mdl.model import Device, Function
    from mdl.resolve import ResolvedDevice

SCHEMAS = click.Choice(["0.9b", "1.0"], case_sensitive=False)
STDOUT = Path(STDIO_ARG)
T = TypeVar("T")


class InputFile(click.Path):
    """An input file; `-` is standard input, named `<stdin>` in messages. click checks nothing (no
    `exists`, no `readable`): the reader says what is wrong as `FILE: error: ...`, exit 1 (SPEC 1),
    a missing file and an unreadable one alike."""

    def __init__(self) -> None:
        super().__init__(path_type=Path, allow_dash=True, readable=False)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Path:
        return input_path(os.fsdecode(super().convert(value, param, ctx)))


INPUT = InputFile()


def _stdin_once(paths: Iterable[Path]) -> None:
    if sum(1 for path in paths if is_stdin(path)) > 1:
        raise click.UsageError("standard input (-) can be read only once")


def _fail(exc: MdlError) -> NoReturn:
    for diag in exc.diagnostics:
        click.echo(str(diag), err=True)
    sys.exit(exc.exit_code)


_FAIL_ON_WARNING = "mdl.fail_on_warning"


def _remember_fail_on_warning(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[_FAIL_ON_WARNING] = value


fail_on_warning_option = click.option(
    "--fail-on-warning",
    is_flag=True,
    expose_value=False,
    callback=_remember_fail_on_warning,
    help="Exit 1, before doing anything, if reading the input gives any warning (they print either way).",
)


def _warning_refusal(warnings: Iterable[Diagnostic], file: Path) -> Diagnostic | None:
    """With --fail-on-warning, the error that warnings about `file` make; else None."""
    n = sum(1 for d in warnings if d.severity == "warning")
    if n and click.get_current_context().meta.get(_FAIL_ON_WARNING):
        return Diagnostic(str(file), None, None, f"{n} warning{'s' * (n != 1)} and --fail-on-warning")
    return None


def _report_warnings(warnings: Iterable[Diagnostic], file: Path) -> None:
    """Print each warning once; with --fail-on-warning, any of them ends the command (exit 1)."""
    warnings = list(warnings)
    for diag in warnings:
        click.echo(str(diag), err=True)
    refusal = _warning_refusal(warnings, file)
    if refusal is not None:
        raise MdlError(refusal)


def _resolved(path: Path, fmt: str | None = None) -> ResolvedDevice:
    """The description in `path` through the resolve step, its warnings printed (every command that
    reads one calls this once per file): MdlError with every error otherwise."""
    from mdl.sources.loading import load_resolved

    resolved = load_resolved(path, fmt)
    _report_warnings(resolved.warnings, path)
    return resolved


# A model of 10,000 functions is some 10^6 small objects that live until the command ends: with
# Python's default thresholds (700, 10, 10) the collector walks all of them again and again while
# they are built (a third of `mdl gen`'s time in resolve). Collections stay on, just rarer.
GC_THRESHOLDS = (100_000, 50, 100)


class Group(click.Group):
    def invoke(self, ctx: click.Context) -> Any:
        gc.set_threshold(*GC_THRESHOLDS)
        try:
            return super().invoke(ctx)
        except MdlError as exc:
            _fail(exc)
        except KeyboardInterrupt:
            click.echo("mdl: interrupted", err=True)
            sys.exit(130)


def run() -> None:
    """The `mdl` program (the console script and `python -m mdl`): `main`, and then, whatever its
    outcome, the objects it leaves are frozen out of the collector. The interpreter's last
    collections would otherwise walk a large model's 10^6 objects once more only to free memory
    the process gives back as it exits (a fifth of `mdl gen --lang all` at 10,000 functions).
    Every file a command writes is closed before it returns; tests call `main` itself."""
    try:
        main()
    finally:
        gc.freeze()


@click.group(cls=Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="mdl")
def main() -> None:
    """mdl: vendor register tables -> MDL (Modbus Definition Language) -> drivers.

    \b
    Example, end to end:
      mdl csv2xml examples/temco_tstat/temco_tstat.ini
      mdl validate examples/temco_tstat/temco_tstat.xml
      mdl gen examples/temco_tstat/temco_tstat.xml --lang python -o out/
      mdl sim examples/temco_tstat/temco_tstat.xml --port 5020 &
      mdl read examples/temco_tstat/temco_tstat.xml --host 127.0.0.1 --port 5020

    \b
    Shell completion of commands, options and file names: add your shell's line to its startup file.
      bash (~/.bashrc):                    eval "$(_MDL_COMPLETE=bash_source mdl)"
      zsh (~/.zshrc):                      eval "$(_MDL_COMPLETE=zsh_source mdl)"
      fish (~/.config/fish/config.fish):   _MDL_COMPLETE=fish_source mdl | source
    """


@main.command()
@click.argument("source", type=INPUT)
@click.option("--ini", "ini", type=INPUT, help="Device INI file (ORNL format).")
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, allow_dash=True),
    help="Output MDL file, - for stdout (default: stdout; with SOURCE an INI file, its output_xml_file).",
)
@click.option("--allow-outside", is_flag=True, help="Let the INI's output_xml_file lie outside the INI's folder.")
@click.option("--force", is_flag=True, help="Replace an existing output file that is not an MDL document.")
@click.option("-i", "--interactive", is_flag=True, help="Pick each function's row from a numbered list.")
@click.option("--threshold", type=click.FloatRange(0, 1), help="Lowest match score accepted (default 0.6).")
@click.option("--all", "emit_all", is_flag=True, help="Also emit every unmatched row that has an address.")
@click.option(
    "--strict",
    is_flag=True,
    help="Exit 1 and write nothing if any row is skipped, any function "
    "is left unmatched or matched by similarity only, or anything else gives a warning.",
)
@click.option(
    "--explain",
    "explain",
    multiple=True,
    metavar="FUNCTION",
    help="Print FUNCTION's nearest rows with their scores and why, instead of writing MDL (repeatable).",
)
@click.option(
    "--table",
    "table_no",
    type=click.IntRange(min=1),
    help="Read the Nth table of a .md or .html file (or sheet of an .xlsx; default: the first with an address column).",
)
@click.option("--sheet", help="Read this sheet of an .xlsx workbook (default: the first with an address column).")
@click.option("-q", "--quiet", is_flag=True, help="Print no notes, summary or progress: only warnings and errors.")
@fail_on_warning_option
def csv2xml(
    source: Path,
    ini: Path | None,
    output: Path | None,
    allow_outside: bool,
    force: bool,
    interactive: bool,
    threshold: float | None,
    emit_all: bool,
    strict: bool,
    explain: tuple[str, ...],
    table_no: int | None,
    sheet: str | None,
    quiet: bool,
) -> None:
    """Convert a vendor register table (CSV, Markdown, HTML or Excel) to MDL XML.

    SOURCE is the CSV (- for stdin) with --ini, or the INI file itself, which names the CSV and may
    name the output (output_xml_file, relative to the INI's folder and inside it).

    Every guess (a column found by its header, the address base, the count unit, the delimiter, a
    decimal comma) is a note on stderr naming the INI key that overrides it; every row that cannot
    be read is a warning with its line; a summary line ends the run.

    \b
    Examples:
      mdl csv2xml examples/temco_tstat/temco_tstat.ini
      mdl csv2xml examples/temco_tstat/temco_tstat.csv --ini examples/temco_tstat/temco_tstat.ini -o tstat.xml
      mdl csv2xml examples/temco_tstat/temco_tstat.csv --ini examples/temco_tstat/temco_tstat.ini -i
      mdl csv2xml examples/temco_tstat/temco_tstat.ini --explain occupied_setpoint --strict
    """
    from mdl.sources.csvmap.command import run_csv2xml
    from mdl.sources.csvmap.documents import chosen
    from mdl.sources.csvmap.target import output_target

    _stdin_once([source] + ([ini] if ini else []))
    target = output_target(source, ini, output, allow_outside, force)
    fail_on_warning = bool(click.get_current_context().meta.get(_FAIL_ON_WARNING))
    with chosen(table_no, sheet):
        run_csv2xml(
            source,
            ini,
            target,
            interactive,
            threshold,
            emit_all,
            fail_on_warning=fail_on_warning,
            strict=strict,
            explain=explain,
            quiet=quiet,
        )


@main.command()
@click.argument("files", nargs=-1, required=True, type=INPUT)
@click.option(
    "--schema",
    "version",
    type=SCHEMAS,
    default="1.0",
    show_default=True,
    help="Schema to validate against; 1.0 accepts every 0.9b document.",
)
@fail_on_warning_option
def validate(files: tuple[Path, ...], version: str) -> None:
    """Validate MDL files (- for stdin) against the XSD and the semantic rules.

    \b
    Example:
      mdl validate examples/temco_tstat/temco_tstat.xml examples/discovery/em100.xml
      mdl validate examples/temco_tstat/temco_tstat.xml --schema 1.0
    """
    from mdl.sources.mdlxml import validate_file

    _stdin_once(files)
    bad = False
    for path in files:
        device, diagnostics = validate_file(path, version)  # the XSD, then the resolve step
        refusal = _warning_refusal(diagnostics, path)
        for diag in [*diagnostics, *([refusal] if refusal else [])]:
            click.echo(str(diag), err=True)
        if device is None or any(d.severity == "error" for d in diagnostics) or refusal:
            bad = True
            continue
        used = device.extensions()
        if device.schema_version == "1.0":
            click.echo(f"{path}: valid MDL 1.0 (extensions: {', '.join(used) or 'none'})")
        else:
            click.echo(f"{path}: valid MDL 0.9b")
    sys.exit(EXIT_INVALID if bad else 0)


@main.command()
@click.argument("file", type=INPUT)
@click.option(
    "--lang",
    type=click.Choice([*targets.names(), "all"], case_sensitive=False),
    default="all",
    show_default=True,
    help="A registered target (" + "; ".join(targets.summaries()) + "), or all of them.",
)
@click.option(
    "-o",
    "--output-dir",
    "outdir",
    type=click.Path(path_type=Path),
    default=Path("."),
    show_default=True,
    help="Directory for the generated files.",
)
@click.option("--check", is_flag=True, help="Write nothing; exit 1 if any output would change.")
@fail_on_warning_option
def gen(file: Path, lang: str, outdir: Path, check: bool) -> None:
    """Generate drivers for the registered targets (--lang) from MDL (or Toolkit YAML).

    Files are written only when their content changes (Makefile friendly), and all of a run's files
    or none: a failed run leaves the old ones as they were.

    \b
    Example:
      mdl gen examples/temco_tstat/temco_tstat.xml --lang all -o drivers/
    """
    from mdl.fileio import all_or_none
    from mdl.targets import generate

    if str(outdir) == STDIO_ARG:
        raise click.BadParameter("mdl gen writes several files: give a directory, not -", param_hint="'-o'")
    resolved = _resolved(file)
    for note in targets.notes(resolved, file):
        click.echo(str(note), err=True)
    with all_or_none():
        changed = generate(resolved, file, lang, outdir, check)
    for path in changed:
        click.echo(f"{'would change' if check else 'wrote'} {path}", err=check)
    if check and changed:
        sys.exit(EXIT_INVALID)


MAX_UNIT = 247


@main.command()
@click.argument("files", nargs=-1, required=True, type=INPUT)
@connection_options(serving=True)
@click.option(
    "--unit",
    "units",
    type=click.IntRange(0, MAX_UNIT),
    multiple=True,
    help="Unit id of each FILE, by position (default 1, 2, ...; 0: any unit, one FILE only).",
)
@click.option("--registers", type=INPUT, multiple=True, help="Initial raw values (JSON) of each FILE, by position.")
@click.option(
    "--set",
    "settings",
    multiple=True,
    metavar="NAME=VALUE",
    help="Initial value of a function, in every FILE that has it.",
)
@click.option(
    "--scenario",
    "scenarios",
    multiple=True,
    help="Seed each FILE's registers from its embedded test scenario of this id, by position.",
)
@click.option("--permissive", is_flag=True, help="Answer addresses the device does not define.")
@fail_on_warning_option
def sim(
    files: tuple[Path, ...],
    connection: Connection,
    units: tuple[int, ...],
    registers: tuple[Path, ...],
    settings: tuple[str, ...],
    scenarios: tuple[str, ...],
    permissive: bool,
) -> None:
    """Serve devices (MDL or Toolkit YAML) on one connection until SIGINT/SIGTERM: Modbus TCP, Modbus RTU
    on a serial line (--serial DEVICE), or RTU frames over TCP (--framer rtu).

    Several FILEs share the connection as devices share a bus, each at its own unit id. Any other
    unit id gets exception 11 on Modbus TCP, and no answer at all on RTU framing, as on a bus.
    --unit, --registers and --scenario go with the FILEs by position (the same FILE may be given
    more than once). When ready it prints, per device, `mdl sim: serving NAME on HOST:PORT unit U`
    (on a serial line `on DEVICE unit U`).

    \b
    Examples:
      mdl sim examples/temco_tstat/temco_tstat.xml --port 5020 --set room_temperature=21.5
      mdl sim examples/toolkit_heat_pump/heat_pump.yaml --port 5021 --scenario Heating
      mdl sim examples/temco_tstat/temco_tstat.xml examples/toolkit_heat_pump/heat_pump.yaml --port 5022
      mdl sim examples/temco_tstat/temco_tstat.xml --port 5023 --framer rtu
      mdl sim examples/discovery/em100.xml --port 5024 --unit 3 --registers examples/discovery/em100.json
      mdl sim examples/discovery/rs4.xml --port 5025 --unit 7 --registers examples/discovery/rs4.json

    \b
    On a serial line (a pseudo terminal pair for a try: socat -d -d pty,raw,echo=0 pty,raw,echo=0):
      mdl sim examples/temco_tstat/temco_tstat.xml --serial /dev/pts/3 --baud 9600
    """
    from mdl.device import sim as simulator
    from mdl.device.scenarios import find_scenario

    _stdin_once(files + registers)
    served = _sim_units(units, len(files))
    raw_files = _by_position("--registers", registers, len(files))
    scenario_ids = _by_position("--scenario", scenarios, len(files))
    loaded = {path: _resolved(path) for path in dict.fromkeys(files)}
    devices = [simulator.Registers(loaded[path], permissive) for path in files]
    for regs, raw, scenario in zip(devices, raw_files, scenario_ids, strict=True):
        if scenario is not None:
            regs.load_scenario(find_scenario(regs.device, scenario))
        if raw is not None:
            regs.load_json(raw)
    for item in settings:
        name, sep, value = item.partition("=")
        if not sep:
            raise click.BadParameter(f"expected NAME=VALUE, got {item!r}", param_hint="--set")
        simulator.set_value(devices, name.strip(), value.strip())
    simulator.run(dict(zip(served, devices, strict=True)), connection)


def _by_position(option: str, values: tuple[T, ...], files: int) -> list[T | None]:
    """An option repeated once per FILE, in the FILEs' order; absent, None for each."""
    if not values:
        return [None] * files
    if len(values) != files:
        raise click.UsageError(
            f"{option} is given {len(values)} time{'s' * (len(values) != 1)} for {files} "
            f"FILE{'s' * (files != 1)}: give it once per FILE, in the same order"
        )
    return list(values)


def _sim_units(units: tuple[int, ...], files: int) -> list[int]:
    """The unit id of each FILE: --unit by position, else 1, 2, ..."""
    if not units:
        if files > MAX_UNIT:
            raise click.UsageError(f"{files} FILEs: one connection serves at most {MAX_UNIT} units")
        return list(range(1, files + 1))
    _by_position("--unit", units, files)
    served = list(units)
    if files > 1 and 0 in served:
        raise click.UsageError("--unit 0 (any unit) serves one FILE only; give each FILE a unit from 1 to 247")
    repeated = sorted({unit for unit in served if served.count(unit) > 1})
    if repeated:
        raise click.UsageError(f"--unit {repeated[0]} is given to more than one FILE: each FILE needs its own unit")
    return served


unit_option = click.option(
    "--unit", type=click.IntRange(0, 255), default=1, show_default=True, help="Unit (device) id to talk to."
)


@main.command(name="import")
@click.argument("file", type=INPUT)
@click.option(
    "--from",
    "fmt",
    type=click.Choice(formats.names(), case_sensitive=False),
    help="Input format (guessed from the file: .mod or a first line #filetype,Modbus_xif is XIF; "
    ".yaml/.yml a Modbus Schema Toolkit schema; an INI with a [Platform] section WISE-Agent).",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, allow_dash=True),
    help="Output MDL file, - for stdout (default: stdout).",
)
@fail_on_warning_option
def import_(file: Path, fmt: str | None, output: Path | None) -> None:
    """Convert another device description to MDL 1.0.

    \b
    Examples:
      mdl import examples/toolkit_heat_pump/heat_pump.yaml -o heat_pump.xml
      mdl import examples/xif_meter/meter.mod -o meter.xml
      mdl import examples/wise_4012e/Modbus.ini --from wise -o wise_4012e.xml
    """
    from mdl.sources.loading import import_format
    from mdl.sources.mdlxml import device_to_xml

    fmt = fmt or import_format(file)
    xml = device_to_xml(formats.by_name(fmt).to_mdl(_resolved(file, fmt)))
    _emit_text(xml, output)


def _emit_text(text: str, output: Path | None) -> None:
    """`text` to standard output (no -o, or -o -) or to the file, written whole or not at all."""
    from mdl.fileio import write_atomic

    if output is None or str(output) == STDIO_ARG:
        click.echo(text, nl=False)
    else:
        write_atomic(output, text)


@main.command(name="export")
@click.argument("file", type=INPUT)
@click.option(
    "--to",
    "fmt",
    required=True,
    type=click.Choice(list(engines.outputs()), case_sensitive=False),
    help="Output format: " + "; ".join(f"{k}: {v.summary}" for k, v in engines.outputs().items()) + ".",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, allow_dash=True),
    help="Output file (default: stdout); a folder for volttron.",
)
@connection_options(optional=True)
@unit_option
@click.option(
    "--interval",
    type=click.FloatRange(0.1, 7 * 86400),
    metavar="S",
    help="Seconds between polls the engine should use (default 60).",
)
@click.option("--force", is_flag=True, help="Write into a folder (volttron) that is not empty.")
@fail_on_warning_option
def export_(
    file: Path,
    fmt: str,
    output: Path | None,
    connection: Connection | None,
    unit: int,
    interval: float | None,
    force: bool,
) -> None:
    """Convert an MDL description to another format or to a polling engine's configuration.

    What the format cannot express is reported as one warning per kind of loss naming the functions
    it concerns (exit 1 with --fail-on-warning, before anything is written). Output is deterministic.

    \b
    Examples:
      mdl export examples/temco_tstat/temco_tstat.xml --to xif -o temco.mod
      mdl export examples/temco_tstat/temco_tstat.xml --to wise --host 192.0.2.10 --unit 3 --interval 5
      mdl export examples/temco_tstat/temco_tstat.xml --to senml
      mdl export examples/temco_tstat/temco_tstat.xml --to volttron -o volttron/ --host 192.0.2.10
      mdl export examples/temco_tstat/temco_tstat.xml --to telegraf --host 192.0.2.10 --interval 10
    """
    from mdl.diagnostics import error
    from mdl.exchange.export import DEFAULT_INTERVAL, Settings
    from mdl.fileio import all_or_none, write_atomic

    if engines.outputs()[fmt].folder and (output is None or str(output) == STDIO_ARG):
        raise click.UsageError(f"--to {fmt} writes a folder of files: give -o DIR")
    settings = Settings(connection, unit, interval or DEFAULT_INTERVAL, interval is not None)
    result = engines.export(_resolved(file), fmt, settings)
    _report_warnings(result.warnings, file)
    if result.text is not None:
        _emit_text(result.text, output)
        return
    assert output is not None
    if output.exists() and not output.is_dir():
        raise error("not a directory", output)
    if output.is_dir() and any(output.iterdir()) and not force:
        raise error("the folder is not empty; give --force to write into it", output)
    output.mkdir(parents=True, exist_ok=True)
    with all_or_none():
        for name, text in result.files.items():
            write_atomic(output / name, text)


@main.command()
@click.argument("files", nargs=-1, required=True, type=INPUT)
@connection_options(timeout=0.5, retries=0)
@click.option(
    "--units",
    default="1-247",
    show_default=True,
    metavar="LIST",
    help="Unit ids to ask: numbers and ranges, e.g. 1-10,17.",
)
@click.option(
    "--format", "fmt", type=click.Choice(["table", "json"], case_sensitive=False), default="table", show_default=True
)
@fail_on_warning_option
def discover(files: tuple[Path, ...], connection: Connection, units: str, fmt: str) -> None:
    """Find which description answers at each unit id, by the marker values of its functions.

    A description matches a unit when every function with a marker reads one of its marker values
    there; one without markers never matches. Where a unit answers Read Device Identification
    (function 43 / MEI 14), its vendor, product code and revision are shown too. A unit that does
    not answer costs one --timeout. Progress goes to stderr. Exit 0 when some unit matched, else 1;
    3 when no unit answered at all.

    Units that answer are listed (matched or not); units that do not are left out. Unit ids are
    0-255. See docs/discovery.md.

    \b
    Examples (the sims of examples/discovery in mdl sim --help: an EM100 at unit 3, an RS4 at unit 7):
      mdl discover examples/discovery/em100.xml examples/discovery/em200.xml --host 127.0.0.1 --port 5024
      mdl discover examples/discovery/rs4.xml --host 127.0.0.1 --port 5025 --units 1-10 --format json

    \b
    On a serial line (RTU: a unit that does not answer costs one --timeout):
      $ mdl discover library/*.xml --serial /dev/ttyUSB0 --baud 9600 --units 1-32,100 --format json
    """
    from mdl.device.discover import discover as find
    from mdl.device.discover import library_warnings, parse_units, render

    _stdin_once(files)
    try:
        wanted = parse_units(units)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--units") from None
    library = [(path, _resolved(path)) for path in files]
    for path, resolved in library:
        _report_warnings(library_warnings(path, resolved), path)
    results = find(library, connection, wanted)
    click.echo(render(results, fmt), nl=False)
    sys.exit(0 if any(r.matches for r in results) else 1)


@main.command(name="test")
@click.argument("files", nargs=-1, required=True, type=INPUT)
@fail_on_warning_option
def test_(files: tuple[Path, ...]) -> None:
    """Run the test scenarios embedded in MDL 1.0 or Toolkit YAML files.

    Prints each failure and a last line `N passed, M failed`; exit 1 if any failed.

    \b
    Example:
      mdl test examples/toolkit_heat_pump/heat_pump.yaml examples/toolkit_inverter/inverter.yaml
    """
    from mdl.device.evaluate import Evaluator
    from mdl.device.scenarios import run_scenario

    _stdin_once(files)
    passed = failed = 0
    loaded = [(path, _resolved(path)) for path in files]  # every file checked before any scenario runs
    for path, resolved in loaded:
        device = resolved.device
        evaluator = Evaluator(resolved)  # compiled once for all of the file's scenarios
        for sc in device.tests:
            failures = run_scenario(evaluator, sc)
            for failure in failures:
                click.echo(f"{path}: {failure}")
            if failures:
                failed += 1
            else:
                passed += 1
    click.echo(f"{passed} passed, {failed} failed")
    sys.exit(EXIT_INVALID if failed else 0)


def _select(device: Device, names: Iterable[str], want_write: bool = False) -> list[Function]:
    from mdl.diagnostics import error

    by_name = {fn.name: fn for fn in device.functions}
    out = []
    for name in names:
        fn = by_name.get(name)
        if fn is None:
            raise error(f"the device has no function '{name}'")
        if want_write and not fn.writable:
            raise error(f"function '{name}' is read-only")
        if not want_write and not fn.readable:
            raise error(f"function '{name}' is write-only")
        out.append(fn)
    return out


@main.command()
@click.argument("file", type=INPUT)
@click.argument("names", nargs=-1)
@connection_options()
@unit_option
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["table", "json", "csv", "senml"], case_sensitive=False),
    default="table",
    show_default=True,
)
@click.option(
    "--interval",
    type=click.FloatRange(0.1, 86400),
    metavar="S",
    help="Poll: read every S seconds (start to start) and print a record each time, until SIGINT.",
)
@click.option("--count", type=click.IntRange(1), metavar="N", help="With --interval: stop after N polls.")
@fail_on_warning_option
def read(
    file: Path,
    names: tuple[str, ...],
    connection: Connection,
    unit: int,
    fmt: str,
    interval: float | None,
    count: int | None,
) -> None:
    """Read functions (all readable ones by default) with the coalesced read plan.

    With --interval, poll: one record per poll (json: one object per line, "time" first; csv: a header,
    then a row per poll; table: a block per poll; senml: one document per line with the time as bt),
    flushed at once. A failed poll is reported on stderr and polling goes on, connecting again; SIGINT
    or --count ends it, exit 0, or 3 if the last poll failed. A poll slower than S is followed at once
    by the next, never by a burst to catch up.

    \b
    Examples:
      mdl read examples/temco_tstat/temco_tstat.xml --host 127.0.0.1 --port 5020 fan_speed --format json
      mdl read examples/temco_tstat/temco_tstat.xml --host 127.0.0.1 --port 5020 --interval 0.5 --count 3 --format csv
      mdl read examples/temco_tstat/temco_tstat.xml --host 127.0.0.1 --port 5023 --framer rtu room_temperature

    \b
    The sim on a pseudo terminal pair (mdl sim --help), from the pair's other end:
      mdl read examples/temco_tstat/temco_tstat.xml --serial /dev/pts/4 --baud 9600 room_temperature

    \b
    On a real serial line, and as a logger to stop with Ctrl-C:
      $ mdl read examples/temco_tstat/temco_tstat.xml --serial /dev/ttyUSB0 --baud 9600 --parity E --unit 3
      $ mdl read examples/temco_tstat/temco_tstat.xml --host 192.0.2.10 --interval 1 --format csv > log.csv
    """
    from mdl.device import output
    from mdl.device.poll import poll
    from mdl.device.runtime import Session

    if count is not None and interval is None:
        raise click.UsageError("--count needs --interval (polling)")
    resolved = _resolved(file)  # the one resolve: the session reads this
    device = resolved.device
    functions = _select(device, names) if names else [fn for fn in device.functions if fn.readable]
    if interval is not None:
        sys.exit(poll(Session(resolved, connection, unit), functions, fmt, interval, count))
    with Session(resolved, connection, unit) as session:
        values = session.read(functions)
    click.echo(output.render(functions, values, fmt, device.name), nl=False)


@main.command()
@click.argument("file", type=INPUT)
@click.argument("assignments", nargs=-1, required=True, metavar="NAME=VALUE...")
@connection_options()
@unit_option
@fail_on_warning_option
def write(file: Path, assignments: tuple[str, ...], connection: Connection, unit: int) -> None:
    """Encode and write values; read-only functions and values outside minimum/maximum are refused.

    \b
    Examples:
      mdl write examples/temco_tstat/temco_tstat.xml --host 127.0.0.1 --port 5020 occupied_setpoint=22.5
      mdl write examples/temco_tstat/temco_tstat.xml --host 127.0.0.1 --port 5023 --framer rtu fan_speed=2

    \b
    On a serial line:
      $ mdl write examples/temco_tstat/temco_tstat.xml --serial /dev/ttyUSB0 --unit 3 fan_speed=2
    """
    from mdl.device.runtime import Session
    from mdl.diagnostics import error
    from mdl.values import codec

    resolved = _resolved(file)
    device = resolved.device
    todo = []
    for item in assignments:
        name, sep, text = item.partition("=")
        if not sep:
            raise click.BadParameter(f"expected NAME=VALUE, got {item!r}", param_hint="NAME=VALUE")
        (fn,) = _select(device, [name.strip()], want_write=True)
        try:
            value = codec.parse_value(fn, text.strip())
            codec.encode(fn, value)
        except (codec.CodecError, ValueError, ZeroDivisionError) as exc:
            raise error(f"{fn.name}={text}: {exc}") from None
        todo.append((fn, value))
    with Session(resolved, connection, unit) as session:
        for fn, value in todo:
            session.write(fn, value)
