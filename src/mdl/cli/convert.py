"""`mdl csv2xml`, `mdl import` and `mdl export`: descriptions from and to other formats."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from mdl import exports, formats
from mdl.cli.app import main
from mdl.cli.options import (
    FAIL_ON_WARNING,
    INPUT,
    QUIET_HELP,
    SERIAL_OPTIONS,
    connection_options,
    fail_on_warning_option,
    line_needs_serial,
    stdin_once,
    unit_option,
)
from mdl.cli.printer import emit_text, report_warnings, resolved_file, say, wrote
from mdl.device.connection import Connection
from mdl.exchange.connection import LINE_ONLY
from mdl.fileio import STDIO_ARG

if TYPE_CHECKING:
    from mdl.exchange.export import Settings


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
    help="Read the Nth table of a .md, .html or .pdf file (or sheet of an .xlsx; default: the first holding the "
    "INI's column names, else the first with an address column).",
)
@click.option("--pages", metavar="PAGES", help="Read these pages of a PDF manual (12-19, or 3,5-7; default: all).")
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
    pages: str | None,
    quiet: bool,
) -> None:
    """Convert a vendor register table (CSV, Markdown, HTML, Excel or a PDF manual) to MDL XML.

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
    from mdl.cli.csv2xml import run_csv2xml
    from mdl.formats.table.readers.document import chosen
    from mdl.formats.table.target import output_target

    stdin_once([source] + ([ini] if ini else []))
    target = output_target(source, ini, output, allow_outside, force)
    fail_on_warning = bool(click.get_current_context().meta.get(FAIL_ON_WARNING))
    with chosen(table_no, sheet, pages):
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

    With -o FILE it says `wrote FILE` on stderr (not with -q/--quiet); without -o (or with -o -) the MDL goes
    to stdout and nothing more is said.

    \b
    Examples:
      mdl import examples/toolkit_heat_pump/heat_pump.yaml -o heat_pump.xml
      mdl import examples/xif_meter/meter.mod -o meter.xml
      mdl import examples/wise_4012e/Modbus.ini --from wise -o wise_4012e.xml
      mdl import --from sunspec 103 120 160 --repeat 2 -o inverter.xml
    """
    from mdl.formats.loading import import_format
    from mdl.formats.mdl import device_to_xml
    from mdl.formats.mdl.load import check_written

    if fmt is not None and fmt.lower() == "sunspec":
        from mdl.formats.sunspec.read import import_chain
        from mdl.resolver import resolve

        resolved = resolve(import_chain(sources, base, repeat), "sunspec")
        report_warnings(resolved.warnings, Path("sunspec"))
        emit_text(check_written(device_to_xml(resolved.device), "import"), output)
        return
    if base is not None or repeat is not None:
        raise click.UsageError("--base and --repeat are options of --from sunspec")
    if len(sources) != 1:
        raise click.UsageError("give one FILE (only --from sunspec takes several models)")
    file = INPUT.convert(sources[0], None, None)
    fmt = fmt or import_format(file)
    xml = device_to_xml(formats.by_name(fmt).to_mdl(resolved_file(file, fmt)))
    emit_text(check_written(xml, "import"), output)


def _pin(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """A pin option's value, checked before it reaches the node's YAML (a usage error, exit 2)."""
    from mdl.exports.esphome import pin_problem

    problem = None if value is None else pin_problem(value)
    if problem is not None:
        raise click.BadParameter(problem, ctx, param)
    return value


@main.command(name="export")
@click.argument("file", type=INPUT, required=False)
@click.option(
    "--to",
    "fmt",
    required=True,
    type=click.Choice(list(exports.outputs()), case_sensitive=False),
    help="Output format: " + "; ".join(f"{k}: {v.summary}" for k, v in exports.outputs().items()) + ".",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, allow_dash=True),
    help="Output file (default: stdout); a folder for volttron. Says `wrote FILE` on stderr.",
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
@click.option(
    "--tx-pin",
    default="GPIO17",
    show_default=True,
    callback=_pin,
    help="esphome: the UART's TX pin (to the RS-485 DI).",
)
@click.option(
    "--rx-pin",
    default="GPIO16",
    show_default=True,
    callback=_pin,
    help="esphome: the UART's RX pin (from the RS-485 RO).",
)
@click.option(
    "--flow-control-pin",
    metavar="PIN",
    callback=_pin,
    help="esphome: the pin driving the RS-485 transceiver's DE/RE (a MAX485 module), high while sending "
    "(default: none, for a transceiver that switches itself).",
)
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
@click.option("--tm", is_flag=True, help="wot: the device type's Thing Model instead of a Thing Description.")
@click.option(
    "--publish",
    metavar="mqtt://HOST[:PORT]/PREFIX",
    help="nodered: wire each poll's message to an MQTT broker (an mqtt out node); telegraf: an outputs.mqtt.",
)
@click.option(
    "--inventory",
    type=INPUT,
    metavar="FLEET.yaml|FLEET.csv",
    help="Instead of FILE: one configuration for an inventory's devices (docs/fleet.md), written to -o DIR.",
)
@click.option(
    "--shards",
    type=click.IntRange(1, 10_000),
    default=1,
    show_default=True,
    help="With --inventory --to telegraf: this many agents, a serial line or gateway never split.",
)
@fail_on_warning_option
def export_(
    file: Path | None,
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
    flow_control_pin: str | None,
    tm: bool,
    publish: str | None,
    inventory: Path | None,
    shards: int,
) -> None:
    """Convert an MDL description to another format or to a polling engine's configuration.

    What the format cannot express is reported as one warning per kind of loss naming the functions
    it concerns (exit 1 with --fail-on-warning, before anything is written). Output is deterministic.
    Each file written is said on stderr as `wrote FILE` (not with -q/--quiet, nor for stdout).

    --to homeassistant makes a thermostat (a writable set point in °C or °F, with its room temperature)
    a climate entity and a writable register of range 0..1 a switch (docs/fleet.md). --to esphome
    writes the node; --flow-control-pin gives its RS-485 transceiver's DE/RE pin (MAX485 modules).

    \b
    Examples:
      mdl export examples/temco_tstat/temco_tstat.xml --to xif -o temco.mod
      mdl export examples/temco_tstat/temco_tstat.xml --to wise --host 192.0.2.10 --unit 3 --interval 5
      mdl export examples/temco_tstat/temco_tstat.xml --to senml
      mdl export examples/temco_tstat/temco_tstat.xml --to volttron -o volttron/ --host 192.0.2.10
      mdl export examples/temco_tstat/temco_tstat.xml --to telegraf --host 192.0.2.10 --interval 10
      mdl export examples/profiles/meter_b.xml --to telegraf --names roles --profile meter --host 192.0.2.10
      mdl export examples/temco_tstat/temco_tstat.xml --to esphome --baud 9600 --flow-control-pin GPIO4 -o node.yaml
      mdl export examples/temco_tstat/temco_tstat.xml --to thingsboard --host 192.0.2.10 -o modbus.json
      mdl export --inventory examples/fleet/site.yml --to telegraf --shards 2 -o telegraf/
      mdl export --inventory examples/fleet/site.yml --to thingsboard -o thingsboard/
    """
    from mdl.exchange.export import DEFAULT_INTERVAL, Settings

    if (file is None) == (inventory is None):
        raise click.UsageError("give FILE (one description) or --inventory FLEET (a fleet's devices)")
    if inventory is not None and (output is None or str(output) == STDIO_ARG):
        raise click.UsageError("--inventory writes a folder of files: give -o DIR")
    if shards != 1 and inventory is None:
        raise click.UsageError("--shards splits an inventory's devices: it needs --inventory")
    if exports.outputs()[fmt].folder and (output is None or str(output) == STDIO_ARG):
        raise click.UsageError(f"--to {fmt} writes a folder of files: give -o DIR")
    given = click.get_current_context().get_parameter_source
    node = [
        n
        for n in ("board", "tx_pin", "rx_pin", "flow_control_pin")
        if given(n) not in (None, click.core.ParameterSource.DEFAULT)
    ]
    if node and fmt.lower() != "esphome":
        raise click.UsageError(f"--{node[0].replace('_', '-')} sets the ESPHome node: it needs --to esphome")
    _distinct_pins({"--tx-pin": tx_pin, "--rx-pin": rx_pin, "--flow-control-pin": flow_control_pin})
    if tm and fmt.lower() != "wot":
        raise click.UsageError("--tm writes a WoT Thing Model: it needs --to wot")
    if publish is not None and fmt.lower() not in ("nodered", "telegraf"):
        raise click.UsageError(
            "--publish wires a Node-RED flow or a Telegraf agent to a broker: it needs --to nodered or telegraf"
        )
    if connection is not None and connection.serial == LINE_ONLY and fmt.lower() != "esphome":
        line = next(n for n in SERIAL_OPTIONS if given(n) is not click.core.ParameterSource.DEFAULT)
        raise click.UsageError(line_needs_serial(line))  # only the ESPHome node is on a line it need not name
    settings = Settings(
        connection,
        unit,
        interval or DEFAULT_INTERVAL,
        interval is not None,
        board,
        tx_pin,
        rx_pin,
        flow_control_pin,
        thing_model=tm,
        publish=publish,
        profile=profile,
    )
    if inventory is not None:
        _export_inventory(inventory, fmt, settings, shards, output, force)
        return
    assert file is not None
    resolved = resolved_file(file)
    if profile is not None and names.lower() != "roles":
        raise click.UsageError("--profile gives values in the roles' units: use it with --names roles")
    if names.lower() == "roles":
        from mdl.exports.role_names import named_by_roles
        from mdl.profiles.load import load_profile

        resolved, said = named_by_roles(resolved, load_profile(profile) if profile else None)
        for diag in said:
            say(diag)
    result = exports.export(resolved, fmt, settings)
    report_warnings(result.warnings, file)
    if result.text is not None:
        emit_text(result.text, output)
        return
    assert output is not None
    _write_folder(result.files, output, force)


def _export_inventory(
    inventory: Path, fmt: str, settings: Settings, shards: int, output: Path | None, force: bool
) -> None:
    """`mdl export --inventory`: the fleet's configuration in the folder `output` (mdl.exports.fleet)."""
    from mdl.cli.inventory import load_members
    from mdl.exports.fleet import export_fleet

    assert output is not None
    members = load_members(inventory)
    result, notes = export_fleet(members, fmt.lower(), settings, shards)
    report_warnings(result.warnings, inventory)
    for note in notes:
        say(f"{inventory}: note: {note}")
    _write_folder(result.files, output, force)


def _write_folder(files: dict[str, str], output: Path, force: bool) -> None:
    """Every file into the folder, written whole or none of them, each said."""
    from mdl.diagnostics import error
    from mdl.fileio import all_or_none, write_atomic

    if output.exists() and not output.is_dir():
        raise error("not a directory", output)
    if output.is_dir() and any(output.iterdir()) and not force:
        raise error("the folder is not empty; give --force to write into it", output)
    output.mkdir(parents=True, exist_ok=True)
    with all_or_none():
        for name, text in files.items():
            (output / name).parent.mkdir(parents=True, exist_ok=True)
            write_atomic(output / name, text)
    for name in files:
        wrote(output / name)


def _distinct_pins(pins: dict[str, str | None]) -> None:
    """ESPHome refuses a pin used twice: the node's pins must be three (a usage error, exit 2)."""
    from mdl.exports.esphome import same_pin

    named = [(option, pin) for option, pin in pins.items() if pin is not None]
    for i, (option, pin) in enumerate(named):
        for other, pin2 in named[i + 1 :]:
            if same_pin(pin, pin2):
                raise click.UsageError(f"{option} {pin} and {other} {pin2} name one pin: each needs its own")
