"""The `mdl` command: options -> one library call -> diagnostics -> exit status (SPEC section 1)."""

from __future__ import annotations

import contextlib
import gc
import logging
import os
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

import click

from mdl import __version__, engines, formats, targets
from mdl.device.connection import SERIAL_OPTIONS, Connection, connection_options, line_needs_serial
from mdl.diagnostics import EXIT_INVALID, Diagnostic, MdlError
from mdl.exchange.connection import LINE_ONLY
from mdl.fileio import STDIO_ARG, input_path, is_stdin

if TYPE_CHECKING:
    from mdl.model import Device, Function
    from mdl.resolver import ResolvedDevice

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


class InputOrTarget(click.Path):
    """An input file (INPUT), or a FILE@CONNECTION target of `mdl read` (kept as text: mdl.device.fleet parses it)."""

    def __init__(self) -> None:
        super().__init__(path_type=Path, allow_dash=True, readable=False)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Path | str:
        from mdl.device.fleet import looks_like_target

        if isinstance(value, str) and looks_like_target(value):
            return value
        return INPUT.convert(value, param, ctx)


def _stdin_once(paths: Iterable[Path]) -> None:
    if sum(1 for path in paths if is_stdin(path)) > 1:
        raise click.UsageError("standard input (-) can be read only once")


_QUIET = "mdl.quiet"


def _remember_quiet(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[_QUIET] = ctx.meta.get(_QUIET, False) or value


QUIET_HELP = "Print no notes, summary or progress: only warnings and errors."


def quiet_option() -> click.Option:
    """-q/--quiet, which Group gives every command (SPEC 1): notes, `wrote FILE` and progress go."""
    return click.Option(["-q", "--quiet"], is_flag=True, expose_value=False, callback=_remember_quiet, help=QUIET_HELP)


def _quiet() -> bool:
    ctx = click.get_current_context(silent=True)
    return ctx is not None and bool(ctx.meta.get(_QUIET) or ctx.params.get("quiet"))


def _say(diag: Diagnostic | str) -> None:
    """A diagnostic on stderr, or a note's own text; notes not under -q/--quiet."""
    if (isinstance(diag, str) or diag.severity == "note") and _quiet():
        return
    click.echo(str(diag), err=True)


def _wrote(path: Path | str) -> None:
    """`wrote FILE` on stderr, as every command that writes a file says (SPEC 1); not under -q."""
    _say(f"wrote {path}")


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
        _say(diag)
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
# they are built (a third of `mdl gen`'s time in resolve). Collections stay on, just rarer (`mdl gen`
# pauses them: _collector_paused).
GC_THRESHOLDS = (100_000, 50, 100)


@contextlib.contextmanager
def _collector_paused() -> Iterator[None]:
    """No cyclic garbage collection while `mdl gen` runs: what it builds lives until it ends, and each
    collection walked 100,000 young objects that were all still in use (5 to 8 collections, 7 % of
    generating 10,000 functions), while the cycles left unfreed add some 4 % to its peak memory. The
    collector's state is restored after (the tests run commands in one process)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class Group(click.Group):
    def add_command(self, cmd: click.Command, name: str | None = None) -> None:
        if not any(param.name == "quiet" for param in cmd.params):
            cmd.params.append(quiet_option())
        super().add_command(cmd, name)

    def invoke(self, ctx: click.Context) -> Any:
        gc.set_threshold(*GC_THRESHOLDS)
        # pymodbus logs every failed exchange itself; the commands say each failure once, their own way
        # (the library, mdl.api, leaves logging to its user)
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
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
@click.option("-q", "--quiet", is_flag=True, help=QUIET_HELP)
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
@click.option(
    "--profile",
    metavar="NAME|FILE.yaml",
    help="Also say which of the profile's roles the device provides (exit 1 if a required one is missing).",
)
@fail_on_warning_option
def validate(files: tuple[Path, ...], version: str, profile: str | None) -> None:
    """Validate MDL files (- for stdin) against the XSD and the semantic rules.

    \b
    Example:
      mdl validate examples/temco_tstat/temco_tstat.xml examples/discovery/em100.xml
      mdl validate examples/temco_tstat/temco_tstat.xml --schema 1.0
      mdl validate examples/profiles/meter_a.xml --profile meter
    """
    from mdl.sources.mdlxml import validate_file

    _stdin_once(files)
    chosen = None
    if profile is not None:
        from mdl.profiles.load import load_profile

        chosen = load_profile(profile)
    bad = False
    for path in files:
        device, diagnostics = validate_file(path, version)  # the XSD, then the resolve step
        refusal = _warning_refusal(diagnostics, path)
        for diag in [*diagnostics, *([refusal] if refusal else [])]:
            _say(diag)
        if device is None or any(d.severity == "error" for d in diagnostics) or refusal:
            bad = True
            continue
        used = device.extensions()
        if device.schema_version == "1.0":
            click.echo(f"{path}: valid MDL 1.0 (extensions: {', '.join(used) or 'none'})")
        else:
            click.echo(f"{path}: valid MDL 0.9b")
        if chosen is not None:
            from mdl.profiles.fit import fit
            from mdl.profiles.report import fit_diagnostics, fit_lines
            from mdl.resolver import resolve

            fitted = fit(chosen, resolve(device, str(path)))
            for line in fit_lines(str(path), fitted):
                click.echo(line)
            for diag in fit_diagnostics(str(path), fitted, {f.name: f for f in device.functions}):
                _say(diag)
            bad = bad or not fitted.ok
    sys.exit(EXIT_INVALID if bad else 0)


@main.command()
@click.argument("name", required=False, metavar="[NAME|FILE.yaml]")
@click.option(
    "--format", "fmt", type=click.Choice(["table", "json"], case_sensitive=False), default="table", show_default=True
)
def profiles(name: str | None, fmt: str) -> None:
    """List the profiles mdl ships, or show one profile's roles (a shipped NAME or your own FILE.yaml).

    \b
    Examples:
      mdl profiles
      mdl profiles meter
      mdl profiles meter --format json
    """
    from mdl.profiles.load import load_profile
    from mdl.profiles.report import listing, roles_json, roles_table

    if name is None:
        if fmt == "json":
            import json

            from mdl.profiles.load import shipped

            click.echo(json.dumps(shipped()))
            return
        for line in listing():
            click.echo(line)
        return
    chosen = load_profile(name)
    if fmt == "json":
        click.echo(roles_json(chosen))
    else:
        for line in roles_table(chosen):
            click.echo(line)


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
@click.option(
    "--profile",
    metavar="NAME|FILE.yaml",
    help="Also generate the profile's interface, implemented by the driver (docs/profiles.md).",
)
@fail_on_warning_option
def gen(file: Path, lang: str, outdir: Path, check: bool, profile: str | None) -> None:
    """Generate drivers for the registered targets (--lang) from MDL (or Toolkit YAML).

    Files are written only when their content changes (Makefile friendly), and all of a run's files
    or none: a failed run leaves the old ones as they were.

    \b
    Example:
      mdl gen examples/temco_tstat/temco_tstat.xml --lang all -o drivers/
      mdl gen examples/profiles/meter_a.xml --lang python --profile meter -o drivers/
    """
    if str(outdir) == STDIO_ARG:
        raise click.BadParameter("mdl gen writes several files: give a directory, not -", param_hint="'-o'")
    with _collector_paused():
        _gen(file, lang, outdir, check, profile)


def _gen(file: Path, lang: str, outdir: Path, check: bool, profile: str | None) -> None:
    from mdl.fileio import all_or_none
    from mdl.targets import generate

    resolved = _resolved(file)
    for note in targets.notes(resolved, file):
        _say(note)
    interface = None
    if profile is not None:
        from mdl.targets.profile import prepare

        interface, said, resolved = prepare(profile, resolved, str(file))
        for note in said:
            _say(note)
    with all_or_none():
        changed = generate(resolved, file, lang, outdir, check, interface)
    for path in changed:
        if check:
            click.echo(f"would change {path}", err=True)
        else:
            _wrote(path)
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
@click.option(
    "--as",
    "as_",
    type=click.Choice(["sunspec"], case_sensitive=False),
    help="Serve the device (one FILE) as its profile's SunSpec models at 40000 (docs/sunspec.md, Gateway).",
)
@click.option("--profile", metavar="NAME|FILE.yaml", help="With --as sunspec: the profile (default: the one it fits).")
@fail_on_warning_option
def sim(
    files: tuple[Path, ...],
    connection: Connection,
    units: tuple[int, ...],
    registers: tuple[Path, ...],
    settings: tuple[str, ...],
    scenarios: tuple[str, ...],
    permissive: bool,
    as_: str | None,
    profile: str | None,
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
      mdl sim examples/profiles/meter_a.xml --port 5026 --as sunspec --set total_active_power=1.5

    \b
    On a serial line (a pseudo terminal pair for a try: socat -d -d pty,raw,echo=0 pty,raw,echo=0):
      mdl sim examples/temco_tstat/temco_tstat.xml --serial /dev/pts/3 --baud 9600
    """
    from mdl.device import sim as simulator
    from mdl.device.scenarios import find_scenario

    _stdin_once(files + registers)
    if as_ is None and profile is not None:
        raise click.UsageError("--profile goes with --as sunspec")
    if as_ is not None and len(files) != 1:
        raise click.UsageError(f"--as sunspec serves one FILE, not {len(files)}")
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
    if as_ is not None:
        from mdl.device.serve import run_sim

        run_sim(files[0], loaded[files[0]], devices[0], profile, served[0], connection)
        return
    simulator.run(dict(zip(served, devices, strict=True)), connection)


@main.command()
@click.argument("file", type=INPUT)
@click.option(
    "--from",
    "source",
    required=True,
    metavar="CONNECTION",
    help="The device to poll: HOST[:PORT] or tcp://HOST[:PORT] (Modbus TCP, port 502), rtu+tcp://HOST:PORT "
    "(RTU frames over TCP), or serial:DEVICE[?baud=19200&parity=N&stopbits=1&bytesize=8] (Modbus RTU).",
)
@click.option("--from-unit", type=click.IntRange(0, 255), default=1, show_default=True, help="The device's unit id.")
@click.option(
    "--as", "as_", type=click.Choice(["sunspec"], case_sensitive=False), required=True, help="What to serve it as."
)
@click.option("--profile", metavar="NAME|FILE.yaml", help="The profile (default: the one its roles fit).")
@click.option(
    "--interval", type=click.FloatRange(0.1, 86400), default=1.0, show_default=True, metavar="S", help="Poll every S s."
)
@click.option(
    "--timeout",
    "poll_timeout",
    type=click.FloatRange(0.1, 600),
    default=3.0,
    show_default=True,
    help="Polling: s per reply.",
)
@click.option(
    "--retries", "poll_retries", type=click.IntRange(0, 10), default=1, show_default=True, help="Polling: resends."
)
@connection_options(serving=True)
@click.option("--unit", type=click.IntRange(0, MAX_UNIT), default=1, show_default=True, help="Unit id served.")
@fail_on_warning_option
def serve(
    file: Path,
    source: str,
    from_unit: int,
    as_: str,
    profile: str | None,
    interval: float,
    poll_timeout: float,
    poll_retries: int,
    connection: Connection,
    unit: int,
) -> None:
    """A gateway: poll a device (--from) with its description and serve it as its profile's SunSpec models
    (SPEC 13; docs/sunspec.md, Gateway) until SIGINT/SIGTERM. Served values are the last poll's; while the
    device does not answer they are SunSpec's "not implemented". When ready it prints
    `mdl serve: serving NAME as SunSpec 1 + MODEL on HOST:PORT unit U`.

    \b
    Examples (a sim of meter A as the device, then the gateway in front of it):
      $ mdl sim examples/profiles/meter_a.xml --port 5030 --set total_active_power=1.5 &
      $ mdl serve examples/profiles/meter_a.xml --from 127.0.0.1:5030 --as sunspec --port 5031 --interval 2
      $ mdl serve meter.xml --from 'rtu:///dev/ttyUSB0?baud=9600&parity=E#3' --as sunspec --port 502
      mdl serve examples/profiles/meter_a.xml --from 127.0.0.1:5030 --as sunspec --profile evcharger  # exit 1
    """
    from mdl.device.serve import parse_from, run_serve

    polled, named = parse_from(source, poll_timeout, poll_retries)
    if named is not None and click.get_current_context().get_parameter_source("from_unit") is not (
        click.core.ParameterSource.DEFAULT
    ):
        raise click.UsageError("the unit is given twice: --from-unit and #UNIT in --from")
    run_serve(
        file, _resolved(file), profile, (polled, from_unit if named is None else named, interval), unit, connection
    )


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
@click.argument("sources", nargs=-1, required=True, metavar="FILE|MODEL...")
@click.option(
    "--from",
    "fmt",
    type=click.Choice(formats.names(), case_sensitive=False),
    help="Input format (guessed from the file: .mod or a first line #filetype,Modbus_xif is XIF; "
    ".yaml/.yml a Modbus Schema Toolkit schema; an INI with a [Platform] section WISE-Agent). "
    "sunspec takes model ids or model JSON files (SPEC 12).",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, allow_dash=True),
    help="Output MDL file, - for stdout (default: stdout).",
)
@click.option("--base", type=click.IntRange(0, 65535), help="--from sunspec: the chain's first address (40000).")
@click.option("--repeat", type=click.IntRange(0, 65535), help="--from sunspec: instances of each repeating group (1).")
@fail_on_warning_option
def import_(
    sources: tuple[str, ...], fmt: str | None, output: Path | None, base: int | None, repeat: int | None
) -> None:
    """Convert another device description to MDL 1.0.

    \b
    Examples:
      mdl import examples/toolkit_heat_pump/heat_pump.yaml -o heat_pump.xml
      mdl import examples/xif_meter/meter.mod -o meter.xml
      mdl import examples/wise_4012e/Modbus.ini --from wise -o wise_4012e.xml
      mdl import --from sunspec 103 120 160 --repeat 2 -o inverter.xml
    """
    from mdl.sources.loading import import_format
    from mdl.sources.mdlxml import device_to_xml
    from mdl.sources.mdlxml.load import check_written

    if fmt is not None and fmt.lower() == "sunspec":
        from mdl.formats.sunspec.read import import_chain
        from mdl.resolver import resolve

        resolved = resolve(import_chain(sources, base, repeat), "sunspec")
        _report_warnings(resolved.warnings, Path("sunspec"))
        _emit_text(check_written(device_to_xml(resolved.device), "import"), output)
        return
    if base is not None or repeat is not None:
        raise click.UsageError("--base and --repeat are options of --from sunspec")
    if len(sources) != 1:
        raise click.UsageError("give one FILE (only --from sunspec takes several models)")
    file = INPUT.convert(sources[0], None, None)
    fmt = fmt or import_format(file)
    xml = device_to_xml(formats.by_name(fmt).to_mdl(_resolved(file, fmt)))
    _emit_text(check_written(xml, "import"), output)


def _emit_text(text: str, output: Path | None) -> None:
    """`text` to standard output (no -o, or -o -) or to the file, written whole or not at all."""
    from mdl.fileio import write_atomic

    if output is None or str(output) == STDIO_ARG:
        click.echo(text, nl=False)
    else:
        write_atomic(output, text)
        _wrote(output)


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
@connection_options(optional=True, line_alone=True)
@unit_option
@click.option(
    "--interval",
    type=click.FloatRange(0.1, 7 * 86400),
    metavar="S",
    help="Seconds between polls the engine should use (default 60).",
)
@click.option("--force", is_flag=True, help="Write into a folder (volttron) that is not empty.")
@click.option("--board", default="esp32dev", show_default=True, help="esphome: the ESP32 board.")
@click.option("--tx-pin", default="GPIO17", show_default=True, help="esphome: the UART's TX pin (to the RS-485 DI).")
@click.option("--rx-pin", default="GPIO16", show_default=True, help="esphome: the UART's RX pin (from the RS-485 RO).")
@click.option(
    "--names",
    type=click.Choice(["functions", "roles"], case_sensitive=False),
    default="functions",
    show_default=True,
    help="Name points after the functions, or after the profile roles they play (docs/profiles.md).",
)
@click.option(
    "--profile",
    metavar="NAME|FILE.yaml",
    help="With --names roles: also give each role's value in the role's unit and sign (kW as W).",
)
@fail_on_warning_option
def export_(
    file: Path,
    fmt: str,
    output: Path | None,
    connection: Connection | None,
    unit: int,
    interval: float | None,
    force: bool,
    names: str,
    profile: str | None,
    board: str,
    tx_pin: str,
    rx_pin: str,
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
      mdl export examples/profiles/meter_b.xml --to telegraf --names roles --profile meter --host 192.0.2.10
      mdl export examples/temco_tstat/temco_tstat.xml --to esphome --baud 9600 --parity E -o node.yaml
      mdl export examples/temco_tstat/temco_tstat.xml --to thingsboard --host 192.0.2.10 -o modbus.json
    """
    from mdl.diagnostics import error
    from mdl.exchange.export import DEFAULT_INTERVAL, Settings
    from mdl.fileio import all_or_none, write_atomic

    if engines.outputs()[fmt].folder and (output is None or str(output) == STDIO_ARG):
        raise click.UsageError(f"--to {fmt} writes a folder of files: give -o DIR")
    given = click.get_current_context().get_parameter_source
    node = [n for n in ("board", "tx_pin", "rx_pin") if given(n) is not click.core.ParameterSource.DEFAULT]
    if node and fmt.lower() != "esphome":
        raise click.UsageError(f"--{node[0].replace('_', '-')} sets the ESPHome node: it needs --to esphome")
    if connection is not None and connection.serial == LINE_ONLY and fmt.lower() != "esphome":
        line = next(n for n in SERIAL_OPTIONS if given(n) is not click.core.ParameterSource.DEFAULT)
        raise click.UsageError(line_needs_serial(line))  # only the ESPHome node is on a line it need not name
    settings = Settings(connection, unit, interval or DEFAULT_INTERVAL, interval is not None, board, tx_pin, rx_pin)
    resolved = _resolved(file)
    if profile is not None and names.lower() != "roles":
        raise click.UsageError("--profile gives values in the roles' units: use it with --names roles")
    if names.lower() == "roles":
        from mdl.engines.role_names import named_by_roles
        from mdl.profiles.load import load_profile

        resolved, said = named_by_roles(resolved, load_profile(profile) if profile else None)
        for diag in said:
            _say(diag)
    result = engines.export(resolved, fmt, settings)
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
    for name in result.files:
        _wrote(output / name)


@main.command()
@click.argument("files", nargs=-1, type=INPUT)
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
@click.option("--sunspec", is_flag=True, help="Walk the SunSpec chain of one unit and write its MDL (no FILE).")
@click.option("--unit", type=click.IntRange(0, 255), help="With --sunspec: the unit id (default 1).")
@click.option(
    "-o", "--output", type=click.Path(path_type=Path, allow_dash=True), help="With --sunspec: the MDL file (stdout)."
)
@fail_on_warning_option
def discover(
    files: tuple[Path, ...],
    connection: Connection,
    units: str,
    fmt: str,
    sunspec: bool,
    unit: int | None,
    output: Path | None,
) -> None:
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

    \b
    --sunspec: walk a SunSpec device's chain (SunS at 40000, 0 or 50000) and write the MDL of the
    models found (exit 3 when there is none, or the device answers garbage; docs/sunspec.md):
      $ mdl discover --sunspec --host 192.168.1.50 --port 502 --unit 1 -o inverter.xml
    """
    if sunspec:
        _discover_sunspec(files, connection, unit, output)
        return
    given = click.get_current_context().get_parameter_source
    for name, option in (("unit", "--unit"), ("output", "-o/--output")):
        if given(name) is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError(f"{option} goes with --sunspec (the units to ask are --units)")
    if not files:
        raise click.UsageError("give the description FILE... to look for, or --sunspec")
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


def _discover_sunspec(files: tuple[Path, ...], connection: Connection, unit: int | None, output: Path | None) -> None:
    """`mdl discover --sunspec`: the MDL of the device's chain to `output` (stdout), written whole or not at all."""
    from mdl.device.sunspec_discover import discover_sunspec
    from mdl.resolver import resolve
    from mdl.sources.mdlxml import device_to_xml
    from mdl.sources.mdlxml.load import check_written

    given = click.get_current_context().get_parameter_source
    if files:
        raise click.UsageError("--sunspec takes no FILE: it writes the description of what it finds")
    for name, option in (("units", "--units"), ("fmt", "--format")):
        if given(name) is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError(f"{option} does not go with --sunspec (give --unit U; the output is MDL)")
    if unit == 0 and connection.serial is not None:
        raise click.UsageError("unit 0 is the broadcast address on a serial line, which no device answers")
    resolved = resolve(discover_sunspec(connection, 1 if unit is None else unit), "sunspec")
    _report_warnings(resolved.warnings, Path("sunspec"))
    _emit_text(check_written(device_to_xml(resolved.device), "discover --sunspec"), output)


@main.command()
@connection_options(timeout=0.5, retries=0)
@click.option("--units", default="1-247", show_default=True, metavar="LIST", help="Unit ids to ask, e.g. 1-10,17.")
@click.option("--bauds", metavar="LIST", help="With --serial: baud rates to try, e.g. 9600,19200 (default --baud).")
@click.option("--parities", metavar="LIST", help="With --serial: parities to try, e.g. N,E,O (default --parity).")
@click.option(
    "--tables", default="holding,input,coil,discrete", show_default=True, metavar="LIST", help="Tables to probe."
)
@click.option("--range", "span", default="0-65535", show_default=True, metavar="A-B", help="Wire addresses to try.")
@click.option(
    "--max-requests", type=click.IntRange(1), default=2000, show_default=True, help="Requests per unit at most."
)
@click.option(
    "--rate", type=click.FloatRange(0), default=50.0, show_default=True, help="Requests a second at most (0: no limit)."
)
@click.option(
    "--format", "fmt", type=click.Choice(["table", "json"], case_sensitive=False), default="table", show_default=True
)
def probe(connection: Connection, fmt: str, **given: Any) -> None:
    """Find the unit ids, serial settings and defined address ranges of an unknown device. It only reads.

    Each unit that answers gets its tables read in blocks (125 registers, 2000 bits); exception 2 splits a
    block until the edges of every defined run are exact. Replies that fail the checks, timeouts and other
    exceptions leave addresses unknown, never defined. A unit is left after 3 such signs in a row or when
    --max-requests are spent. Guesses at the address base and word order are said as guesses. Exit 3
    when no unit answered. See docs/probe.md.

    \b
    Examples (the EM100 of mdl sim --help at unit 3; the other units get exception 11):
      mdl probe --host 127.0.0.1 --port 5024 --units 1-4 --range 0-99 --rate 0
      $ mdl probe --host 192.0.2.10 --units 1-10 --range 0-999
      $ mdl probe --serial /dev/ttyUSB0 --bauds 9600,19200 --parities N,E --units 1-32 --format json
    """
    from mdl.device.probe import probe as run_probe
    from mdl.device.probe import render
    from mdl.device.probe_options import probe_options

    options = probe_options(connection, **given)  # units, bauds, parities, tables, span, max_requests, rate
    results = run_probe(connection, options)
    if fmt == "json":
        for r in results:
            for note in r.notes:
                _say(f"mdl probe: unit {r.unit}: {note}")
    click.echo(render(results, fmt), nl=False)


@main.command()
@click.argument("file", type=INPUT, required=False)
@connection_options()
@click.option("--unit", type=click.IntRange(0, 255), help="Unit id (default 1; with --ranges, the file's one unit).")
@click.option("--ranges", type=INPUT, metavar="PROBE.json", help="Read the ranges mdl probe --format json found.")
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, allow_dash=True),
    help="Write here, - for stdout (default: stdout).",
)
@click.option("--scenario", metavar="NAME", help="Write FILE with a test scenario NAME of the values read.")
@fail_on_warning_option
def capture(
    file: Path | None,
    connection: Connection,
    unit: int | None,
    ranges: Path | None,
    output: Path | None,
    scenario: str | None,
) -> None:
    """Record a device's registers: the raw image mdl sim --registers serves back, or a test scenario.

    Reads every register FILE's readable functions name (or, with --ranges, every address mdl probe found)
    in as few requests as the read plan allows, and writes the image as JSON (keys wire addresses). With
    --scenario, writes FILE again (as MDL 1.0, to -o or stdout, never over FILE unless -o names it) with
    a scenario holding the registers and the value each function read, for mdl test. See docs/probe.md.

    \b
    Examples (the first two with the EM100 of mdl sim --help):
      mdl capture examples/discovery/em100.xml --host 127.0.0.1 --port 5024 --unit 3 -o em100.raw.json
      mdl capture examples/discovery/em100.xml --host 127.0.0.1 --port 5024 --unit 3 --scenario now -o em100_now.xml
      $ mdl capture meter.xml --host 192.0.2.10 -o meter.raw.json
      $ mdl sim meter.xml --registers meter.raw.json
      $ mdl capture meter.xml --host 192.0.2.10 --scenario site_a -o meter_tested.xml
      $ mdl probe --host 192.0.2.10 --units 1 --range 0-999 --format json > probe.json
      $ mdl capture --ranges probe.json --host 192.0.2.10 -o raw.json
    """
    from mdl.device import capture as cap

    if (file is None) == (ranges is None):
        raise click.UsageError("give FILE (a description) or --ranges PROBE.json (from mdl probe), one of them")
    if scenario is not None and file is None:
        raise click.UsageError("--scenario needs FILE: a scenario's values are the description's functions")
    if ranges is not None:
        at, spans = cap.read_ranges(ranges, unit)
        captured, refused = cap.capture_ranges(spans, connection, at)
        for warning in refused:
            click.echo(f"mdl capture: warning: {warning}", err=True)
        text = cap.image_json(captured)
    else:
        assert file is not None
        resolved = _resolved(file)
        image, warnings = cap.capture_described(resolved, connection, 1 if unit is None else unit)
        for warning in warnings:
            click.echo(f"mdl capture: warning: {warning}", err=True)
        if scenario is None:
            text = cap.image_json(image)
        else:
            where = f"{connection} unit {1 if unit is None else unit}"
            text = cap.with_scenario(resolved.device, cap.scenario(resolved, image, scenario, where), file)
    _emit_text(text, output)


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
@click.argument("file", type=InputOrTarget(), required=False, metavar="[FILE | FILE@CONNECTION[#UNIT]...]")
@click.argument("names", nargs=-1)
@connection_options(optional=True)
@unit_option
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["table", "json", "csv", "senml"], case_sensitive=False),
    default="table",
    show_default=True,
)
@click.option(
    "--raw",
    "raw",
    multiple=True,
    metavar="TABLE:RANGE",
    help="Without FILE: read raw registers, e.g. hr:0-9, ir:5, co:0+16 (hr, ir, co, di; wire addresses).",
)
@click.option(
    "--as",
    "as_type",
    metavar="TYPE",
    help="With --raw: each value's type: uint16 (default), int16, uint32, int32, float32, uint64, int64, float64, "
    "string (the range is one text), hex, bits.",
)
@click.option(
    "--word-order", type=click.Choice(["big", "little"], case_sensitive=False), help="With --raw: registers of a value."
)
@click.option(
    "--byte-order", type=click.Choice(["big", "little"], case_sensitive=False), help="With --raw: bytes in a register."
)
@click.option(
    "--interval",
    type=click.FloatRange(0.1, 86400),
    metavar="S",
    help="Poll: read every S seconds (start to start) and print a record each time, until SIGINT.",
)
@click.option("--count", type=click.IntRange(1), metavar="N", help="With --interval: stop after N polls.")
@click.option(
    "--publish",
    multiple=True,
    metavar="URL",
    help="With --interval: send each poll on: mqtt://HOST[:PORT]/PREFIX (MQTT, Home Assistant discovery; "
    "mqtts:// with TLS), prometheus://[HOST]:PORT (metrics of the last poll). See docs/fleet.md.",
)
@click.option(
    "--mqtt-ca",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    metavar="FILE",
    help="With --publish mqtts://: trust only the CA certificates (PEM) in FILE, not the system's.",
)
@fail_on_warning_option
def read(
    file: Path | str | None,
    names: tuple[str, ...],
    connection: Connection | None,
    unit: int,
    fmt: str,
    raw: tuple[str, ...],
    as_type: str | None,
    word_order: str | None,
    byte_order: str | None,
    interval: float | None,
    count: int | None,
    publish: tuple[str, ...],
    mqtt_ca: Path | None,
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

    \b
    Without a description, raw registers as mbpoll reads them (wire addresses; see docs/probe.md):
      mdl read --host 127.0.0.1 --port 5020 --raw hr:0-7 --as hex
      $ mdl read --host 192.0.2.10 --raw hr:0-9 --raw ir:100+4 --as float32 --word-order little

    \b
    Several devices from one process, each FILE@CONNECTION[#UNIT] polled on its own (docs/fleet.md), and
    polls published to an MQTT broker (Home Assistant discovery) or served to Prometheus:
      $ mdl read meter.xml@tcp://192.0.2.10:502#3 'meter.xml@rtu:///dev/ttyUSB0?baud=9600&parity=E#2' --interval 5
      $ mdl read examples/temco_tstat/temco_tstat.xml --host 192.0.2.10 --interval 10 --publish mqtt://localhost/mdl
      $ mdl read meter.xml@tcp://192.0.2.10#1 meter.xml@tcp://192.0.2.10#2 --interval 15 --publish prometheus://:9105
    """
    from mdl.device import output
    from mdl.device.poll import poll
    from mdl.device.runtime import Session

    if count is not None and interval is None:
        raise click.UsageError("--count needs --interval (polling)")
    if publish and interval is None:
        raise click.UsageError("--publish needs --interval (polling)")
    if mqtt_ca is not None and not any(url.lower().startswith("mqtts://") for url in publish):
        raise click.UsageError("--mqtt-ca goes with --publish mqtts://...")
    from mdl.device.fleet import looks_like_target

    if isinstance(file, str) or publish or any(map(looks_like_target, names)):
        sys.exit(_read_targets(file, names, connection, unit, fmt, interval, count, publish, mqtt_ca))
    if connection is None:
        raise click.UsageError(NO_CONNECTION)
    if raw or file is None:
        from mdl.device.rawread import raw_read

        sys.exit(raw_read(file, names, raw, connection, unit, fmt, (as_type, word_order, byte_order), interval, count))
    for option, value in (("--as", as_type), ("--word-order", word_order), ("--byte-order", byte_order)):
        if value is not None:
            raise click.UsageError(f"{option} goes with --raw (a description says how its values are read)")
    resolved = _resolved(file)  # the one resolve: the session reads this
    device = resolved.device
    functions = _select(device, names) if names else [fn for fn in device.functions if fn.readable]
    if interval is not None:
        sys.exit(poll(Session(resolved, connection, unit), functions, fmt, interval, count))
    with Session(resolved, connection, unit) as session:
        values = session.read(functions)
    click.echo(output.render(functions, values, fmt, device.name), nl=False)


NO_CONNECTION = "no connection: give --host HOST (Modbus TCP) or --serial DEVICE (Modbus RTU)"


def _read_targets(
    file: Path | str | None,
    names: tuple[str, ...],
    connection: Connection | None,
    unit: int,
    fmt: str,
    interval: float | None,
    count: int | None,
    publish: tuple[str, ...],
    mqtt_ca: Path | None = None,
) -> int:
    """`mdl read` of several FILE@CONNECTION targets, or of one FILE with --publish (mdl.device.fleet)."""
    from click.core import ParameterSource

    from mdl.device import fleet

    if isinstance(file, str):
        if connection is not None:
            raise click.UsageError("a FILE@CONNECTION target gives its own connection: leave out --host and --serial")
        if click.get_current_context().get_parameter_source("unit") is not ParameterSource.DEFAULT:
            raise click.UsageError("--unit: a target gives its unit id as FILE@CONNECTION#UNIT")
        texts = [file, *(n for n in names if fleet.looks_like_target(n))]
        names = tuple(n for n in names if not fleet.looks_like_target(n))
        targets = []
        for text in texts:
            try:
                targets.append(fleet.parse_target(text))
            except ValueError as exc:
                raise click.BadParameter(f"{text!r}: {exc}", param_hint="FILE@CONNECTION") from None
    elif any(fleet.looks_like_target(n) for n in names) or file is None:
        raise click.UsageError(f"several devices are each {fleet.TARGET_FORMS}")
    elif connection is None:
        raise click.UsageError(NO_CONNECTION)
    else:
        targets = [fleet.Target(str(file), file, connection, unit)]
    from mdl.engines.ha_units import ha_unit

    sinks: list[fleet.Sink] = []
    for url in publish:
        try:
            sinks.append(fleet.publisher(url, sys.stderr, ha_unit, mqtt_ca))
        except ValueError as exc:
            raise click.BadParameter(f"{fleet.redacted(url)!r}: {exc}", param_hint="'--publish'") from None
    files: dict[Path, ResolvedDevice] = {}
    polled = []
    for target in targets:
        resolved = files[target.file] if target.file in files else files.setdefault(target.file, _resolved(target.file))
        device = resolved.device
        functions = _select(device, names) if names else [fn for fn in device.functions if fn.readable]
        polled.append(fleet.Polled(target, resolved, functions, ""))
    ids, notes = fleet.device_ids([p.resolved.stem for p in polled], [t.unit for t in targets])
    for p, ident in zip(polled, ids, strict=True):
        p.ident = ident
    for note in notes:
        _say(f"mdl read: note: {note}")
    printer = fleet.Printer(fmt, len(targets) > 1, sys.stdout, sys.stderr)
    # publishers take each poll before it is printed: a record on stdout means every publisher holds it
    return fleet.poll_fleet(polled, [*sinks, printer], interval or 1.0, count if interval is not None else 1)


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
