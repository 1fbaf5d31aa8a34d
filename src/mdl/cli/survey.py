"""The commands that survey devices: `mdl discover`, `mdl probe`, `mdl capture`."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from mdl.cli.app import main
from mdl.cli.options import INPUT, connection_options, fail_on_warning_option, is_quiet, stdin_once
from mdl.cli.printer import emit_text, report_warnings, resolved_file, say
from mdl.device.connection import Connection

if TYPE_CHECKING:
    from mdl.device.survey.probe_options import ProbeOptions


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
    from mdl.device.survey.discover import discover as find
    from mdl.device.survey.discover import library_warnings, parse_units, render

    stdin_once(files)
    try:
        wanted = parse_units(units)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--units") from None
    library = [(path, resolved_file(path)) for path in files]
    for path, resolved in library:
        report_warnings(library_warnings(path, resolved), path)
    results = find(library, connection, wanted)
    click.echo(render(results, fmt), nl=False)
    sys.exit(0 if any(r.matches for r in results) else 1)


def _discover_sunspec(files: tuple[Path, ...], connection: Connection, unit: int | None, output: Path | None) -> None:
    """`mdl discover --sunspec`: the MDL of the device's chain to `output` (stdout), written whole or not at all."""
    from mdl.device.sunspec.discover import discover_sunspec
    from mdl.formats.mdl import device_to_xml
    from mdl.formats.mdl.load import check_written
    from mdl.resolver import resolve

    given = click.get_current_context().get_parameter_source
    if files:
        raise click.UsageError("--sunspec takes no FILE: it writes the description of what it finds")
    for name, option in (("units", "--units"), ("fmt", "--format")):
        if given(name) is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError(f"{option} does not go with --sunspec (give --unit U; the output is MDL)")
    if unit == 0 and connection.serial is not None:
        raise click.UsageError("unit 0 is the broadcast address on a serial line, which no device answers")
    resolved = resolve(discover_sunspec(connection, 1 if unit is None else unit), "sunspec")
    report_warnings(resolved.warnings, Path("sunspec"))
    emit_text(check_written(device_to_xml(resolved.device), "discover --sunspec"), output)


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
    --max-requests are spent. Guesses at the address base and word order are said as guesses. Progress
    goes to stderr (on a terminal, a line redrawn as the requests go; not with -q). With --format json
    each unit also lists the spans it could not judge ("unknown") and those not probed ("not_probed"),
    with why. Exit 3 when no unit answered. See docs/probe.md.

    \b
    Examples (the EM100 of mdl sim --help at unit 3; the other units get exception 11):
      mdl probe --host 127.0.0.1 --port 5024 --units 1-4 --range 0-99 --rate 0
      $ mdl probe --host 192.0.2.10 --units 1-10 --range 0-999
      $ mdl probe --serial /dev/ttyUSB0 --bauds 9600,19200 --parities N,E --units 1-32 --format json
    """
    from mdl.device.survey.probe import probe as run_probe
    from mdl.device.survey.probe import render

    options = probe_options(connection, **given)  # units, bauds, parities, tables, span, max_requests, rate
    results = run_probe(connection, options, quiet=is_quiet())
    if fmt == "json":
        for r in results:
            for note in r.notes:
                say(f"mdl probe: unit {r.unit}: {note}")
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
    from mdl.device.survey import capture as cap

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
        resolved = resolved_file(file)
        image, warnings = cap.capture_described(resolved, connection, 1 if unit is None else unit)
        for warning in warnings:
            click.echo(f"mdl capture: warning: {warning}", err=True)
        if scenario is None:
            text = cap.image_json(image)
        else:
            where = f"{connection} unit {1 if unit is None else unit}"
            text = cap.with_scenario(resolved.device, cap.scenario(resolved, image, scenario, where), file)
    emit_text(text, output)


def probe_options(
    connection: Connection,
    units: str,
    bauds: str | None,
    parities: str | None,
    tables: str,
    span: str,
    max_requests: int,
    rate: float,
) -> ProbeOptions:
    """The options of `mdl probe` as the probe takes them; click.BadParameter (exit 2) naming the option
    that is wrong. --bauds and --parities default to the connection's --baud and --parity, and need
    --serial."""
    from mdl.device.survey.discover import parse_units
    from mdl.device.survey.probe_options import PARITIES, ProbeOptions, parse_bauds, parse_list, parse_span
    from mdl.device.survey.rawread import RAW_TABLES

    if connection.serial is None and (bauds or parities):
        raise click.UsageError(f"{'--bauds' if bauds else '--parities'} tries serial settings: it needs --serial")
    baud_list = _checked("--bauds", lambda: parse_bauds(bauds) if bauds else [connection.baud])
    parity_list = _checked(
        "--parities", lambda: parse_list(parities, "a parity", PARITIES) if parities else [connection.parity]
    )
    low, high = _checked("--range", lambda: parse_span(span))
    return ProbeOptions(
        _checked("--units", lambda: parse_units(units)),
        [(b, p) for b in baud_list for p in parity_list],
        _checked("--tables", lambda: parse_list(tables, "a table", RAW_TABLES)),
        low,
        high,
        max_requests,
        rate,
    )


T = TypeVar("T")


def _checked(option: str, parse: Callable[[], T]) -> T:
    """What `parse` gives; click.BadParameter naming `option` where it raises ValueError."""
    try:
        return parse()
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint=f"'{option}'") from None
