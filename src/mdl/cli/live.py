"""The commands that talk to a device or are one: `mdl read`, `mdl write`, `mdl sim`, `mdl serve`."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import click

from mdl.cli.app import main
from mdl.cli.options import INPUT, InputOrTarget, connection_options, fail_on_warning_option, stdin_once, unit_option
from mdl.cli.printer import resolved_file, say
from mdl.device.connection import TARGET_FORMS, Connection, looks_like_target

if TYPE_CHECKING:
    from mdl.device.fleet.run import Sink, Target
    from mdl.device.survey.rawread import RawRange, RawSession
    from mdl.model import Function
    from mdl.resolver import ResolvedDevice


T = TypeVar("T")


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
    from mdl.device.server import sim as simulator
    from mdl.device.server.scenarios import find_scenario

    stdin_once(files + registers)
    if as_ is None and profile is not None:
        raise click.UsageError("--profile goes with --as sunspec")
    if as_ is not None and len(files) != 1:
        raise click.UsageError(f"--as sunspec serves one FILE, not {len(files)}")
    served = _sim_units(units, len(files))
    raw_files = _by_position("--registers", registers, len(files))
    scenario_ids = _by_position("--scenario", scenarios, len(files))
    loaded = {path: resolved_file(path) for path in dict.fromkeys(files)}
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
        from mdl.device.server.serve import run_sim

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
    from mdl.device.server.serve import parse_from, run_serve

    polled, named = parse_from(source, poll_timeout, poll_retries)
    if named is not None and click.get_current_context().get_parameter_source("from_unit") is not (
        click.core.ParameterSource.DEFAULT
    ):
        raise click.UsageError("the unit is given twice: --from-unit and #UNIT in --from")
    run_serve(
        file, resolved_file(file), profile, (polled, from_unit if named is None else named, interval), unit, connection
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
@click.option(
    "--count",
    type=click.IntRange(1),
    metavar="N",
    help="With --interval or --inventory: stop after N polls (each device's).",
)
@click.option(
    "--publish",
    multiple=True,
    metavar="URL",
    help="With --interval or --inventory: send each poll on: mqtt://HOST[:PORT]/PREFIX (MQTT, Home Assistant "
    "discovery; mqtts:// with TLS), prometheus://[HOST]:PORT (metrics of the last poll). See docs/fleet.md.",
)
@click.option(
    "--mqtt-ca",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    metavar="FILE",
    help="With --publish mqtts://: trust only the CA certificates (PEM) in FILE, not the system's.",
)
@click.option(
    "--inventory",
    type=INPUT,
    metavar="FLEET.yaml|FLEET.csv",
    help="Poll every device the inventory names, each on its own interval, until SIGINT/SIGTERM (or --count "
    "polls each); NAMES are functions of every device. See docs/fleet.md, Inventory.",
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
    inventory: Path | None,
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

    \b
    A site's inventory (docs/fleet.md, Inventory): every device it names on its own interval, records
    {"time", "device": ID, "values"}; a device that fails 3 polls in a row is polled again after 2, 4, 8 ...
    intervals (at most 10 minutes apart), said once on stderr as it goes (ID: backing off: ...) and once as
    it comes back (ID: answering again):
      $ mdl read --inventory examples/fleet/site.yml --format json --publish mqtt://broker.lan/site1
    """
    if mqtt_ca is not None and not any(url.lower().startswith("mqtts://") for url in publish):
        raise click.UsageError("--mqtt-ca goes with --publish mqtts://...")
    if inventory is not None:
        _refuse_beside_inventory(file, connection, raw, (as_type, word_order, byte_order), interval)
        names = (str(file), *names) if file is not None else names
        sys.exit(_read_inventory(inventory, names, fmt, count, publish, mqtt_ca))
    if count is not None and interval is None:
        raise click.UsageError("--count needs --interval (polling)")
    if publish and interval is None:
        raise click.UsageError("--publish needs --interval (polling)")
    address = next((n for n in names if re.compile(_ADDRESS).fullmatch(n)), None)
    if address is not None:  # no function is named so: a connection written where NAMES go
        raise click.UsageError(f"'{address}' looks like where the device is, not a function: write --host {address}")
    if isinstance(file, str) and not publish and not any(map(looks_like_target, names)):
        # one device however it is written: FILE@CONNECTION reads and polls as FILE --host does
        (target,) = _targets(file, names, connection)
        file, connection, unit = target.file, target.connection, target.unit
    if isinstance(file, str) or publish or any(map(looks_like_target, names)):
        sys.exit(_read_targets(file, names, connection, unit, fmt, interval, count, publish, mqtt_ca))
    if connection is None:
        raise click.UsageError(NO_CONNECTION)
    if raw or file is None:
        sys.exit(raw_read(file, names, raw, connection, unit, fmt, (as_type, word_order, byte_order), interval, count))
    for option, value in (("--as", as_type), ("--word-order", word_order), ("--byte-order", byte_order)):
        if value is not None:
            raise click.UsageError(f"{option} goes with --raw (a description says how its values are read)")
    from mdl.device import output
    from mdl.device.runtime import Session

    resolved = resolved_file(file)  # the one resolve: the session reads this
    device = resolved.device
    functions = device.select(names)
    if interval is not None:
        from mdl.device.fleet.poll import poll

        sys.exit(poll(Session(resolved, connection, unit), functions, fmt, interval, count))
    with Session(resolved, connection, unit) as session:
        values = session.read(functions)
    click.echo(output.render(functions, values, fmt, device.name), nl=False)


# a connection written where NAMES go: localhost, an IPv4 or [IPv6] address, or any HOST:PORT (a function's
# name may hold dots, never a colon and digits at its end)
# a pattern's text, compiled where it is used (re.compile keeps it): no compiling at import (issue 40)
_ADDRESS = r"(localhost|\d{1,3}(\.\d{1,3}){3}|\[[0-9a-fA-F:]+\])(:\d{1,5})?|[\w.-]+:\d{1,5}"
NO_CONNECTION = "no connection: give --host HOST (Modbus TCP) or --serial DEVICE (Modbus RTU)"


def _targets(file: str, names: tuple[str, ...], connection: Connection | None) -> list[Target]:
    """The FILE@CONNECTION[#UNIT] targets of FILE and NAMES; usage errors for --host, --serial or --unit
    beside them and for a target that does not parse."""
    from click.core import ParameterSource

    from mdl.device.fleet import run as fleet

    if connection is not None:
        raise click.UsageError("a FILE@CONNECTION target gives its own connection: leave out --host and --serial")
    if click.get_current_context().get_parameter_source("unit") is not ParameterSource.DEFAULT:
        raise click.UsageError("--unit: a target gives its unit id as FILE@CONNECTION#UNIT")
    targets = []
    for text in [file, *(n for n in names if looks_like_target(n))]:
        try:
            targets.append(fleet.parse_target(text))
        except ValueError as exc:
            raise click.BadParameter(f"{text!r}: {exc}", param_hint="FILE@CONNECTION") from None
    return targets


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
    """`mdl read` of several FILE@CONNECTION targets, or of one FILE with --publish (mdl.device.fleet.run)."""
    from mdl.device.fleet import run as fleet

    if isinstance(file, str):
        targets = _targets(file, names, connection)
        names = tuple(n for n in names if not looks_like_target(n))
    elif any(looks_like_target(n) for n in names) or file is None:
        raise click.UsageError(f"several devices are each {TARGET_FORMS}")
    elif connection is None:
        raise click.UsageError(NO_CONNECTION)
    else:
        targets = [fleet.Target(str(file), file, connection, unit)]
    sinks = _publishers(publish, mqtt_ca)
    files: dict[Path, ResolvedDevice] = {}
    polled = []
    for target in targets:
        resolved = (
            files[target.file] if target.file in files else files.setdefault(target.file, resolved_file(target.file))
        )
        device = resolved.device
        functions = device.select(names)
        polled.append(fleet.Polled(target, resolved, functions, ""))
    ids, notes = fleet.device_ids([p.resolved.stem for p in polled], [t.unit for t in targets])
    for p, ident in zip(polled, ids, strict=True):
        p.ident = ident
    for note in notes:
        say(f"mdl read: note: {note}")
    printer = fleet.Printer(fmt, len(targets) > 1, sys.stdout, sys.stderr)
    # publishers take each poll before it is printed: a record on stdout means every publisher holds it
    return fleet.poll_fleet(polled, [*sinks, printer], interval or 1.0, count if interval is not None else 1)


def _publishers(publish: tuple[str, ...], mqtt_ca: Path | None) -> list[Sink]:
    """The sinks --publish names; a usage error (never quoting a password) for a URL that is not one."""
    from mdl.device.fleet import run as fleet
    from mdl.exports.ha_units import ha_unit

    sinks: list[fleet.Sink] = []
    for url in publish:
        try:
            sinks.append(fleet.publisher(url, sys.stderr, ha_unit, mqtt_ca))
        except ValueError as exc:
            raise click.BadParameter(f"{fleet.redacted(url)!r}: {exc}", param_hint="'--publish'") from None
    return sinks


def _refuse_beside_inventory(
    file: Path | str | None,
    connection: Connection | None,
    raw: tuple[str, ...],
    how: tuple[str | None, ...],
    interval: float | None,
) -> None:
    """Usage errors for what an inventory gives itself (its devices, their connections and intervals)."""
    from click.core import ParameterSource

    if isinstance(file, str):
        raise click.UsageError(f"{file!r}: --inventory names the devices; leave out FILE@CONNECTION targets")
    if connection is not None:
        raise click.UsageError("--inventory gives each device its connection: leave out --host and --serial")
    if click.get_current_context().get_parameter_source("unit") is not ParameterSource.DEFAULT:
        raise click.UsageError("--inventory gives each device its unit: leave out --unit")
    if interval is not None:
        raise click.UsageError("--inventory gives each device its interval (or its defaults): leave out --interval")
    if raw or any(how):
        raise click.UsageError("--raw (--as, --word-order, --byte-order) reads no description: not with --inventory")


def _read_inventory(
    path: Path, names: tuple[str, ...], fmt: str, count: int | None, publish: tuple[str, ...], mqtt_ca: Path | None
) -> int:
    """`mdl read --inventory FILE`: every device of the inventory polled on its own interval, backed off while
    it fails (mdl.device.fleet.run), records naming it by its id; the exit status."""
    from mdl.cli.inventory import load_members
    from mdl.device.fleet import run as fleet
    from mdl.device.fleet.inventory import DEFAULT_INTERVAL

    sinks = _publishers(publish, mqtt_ca)
    members = load_members(path)
    polled = []
    for member in members:
        entry = member.entry
        target = fleet.Target(entry.id, entry.description, entry.connection, entry.unit)
        functions = member.resolved.device.select(names)
        polled.append(fleet.Polled(target, member.resolved, functions, entry.id, entry.interval))
    printer = fleet.Printer(fmt, True, sys.stdout, sys.stderr)
    # publishers take each poll before it is printed, as for targets
    status = fleet.poll_fleet(polled, [*sinks, printer], DEFAULT_INTERVAL, count)
    # a site's poller ends on SIGINT/SIGTERM with exit 0 whatever its devices do (SPEC 15): a dead device
    # is said on stderr, not in the status; --count (a test's bounded run) says 3 if a last poll failed
    return status if count is not None else 0


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
    from mdl.device import output
    from mdl.device.runtime import Session
    from mdl.diagnostics import error
    from mdl.ir import codec

    resolved = resolved_file(file)
    device = resolved.device
    todo = []
    for item in assignments:
        name, sep, text = item.partition("=")
        if not sep:
            raise click.BadParameter(f"expected NAME=VALUE, got {item!r}", param_hint="NAME=VALUE")
        (fn,) = device.select([name.strip()], write=True)
        try:
            value = codec.parse_value(fn, text.strip())
            codec.encode(fn, value)
        except (codec.CodecError, ValueError, ZeroDivisionError) as exc:
            raise error(f"{fn.name}={text}: {exc}") from None
        todo.append((fn, value))
    with Session(resolved, connection, unit) as session:
        for fn, value in todo:
            session.write(fn, value)
            units = f" {fn.units.strip()}" if fn.units and fn.units.strip() else ""
            say(f"wrote {fn.name} = {output.shown_text(fn, value)}{units} to {connection} unit {unit}")


def raw_read(
    file: Path | None,
    names: tuple[str, ...],
    texts: tuple[str, ...],
    connection: Connection,
    unit: int,
    fmt: str,
    how: tuple[str | None, str | None, str | None],
    interval: float | None,
    count: int | None,
) -> int:
    """`mdl read` without FILE: read (or poll) the `--raw` ranges and print them; the exit status. Usage
    errors (click's, exit 2) for no FILE and no --raw, FILE and --raw together, a bad range or --as."""
    from mdl.device import output
    from mdl.device.survey.rawread import AS_TYPES, RawSession, modicon_hint, parse_raw_range, raw_device, raw_functions
    from mdl.diagnostics import DeviceError

    if not texts:
        raise click.UsageError("missing FILE: give a description to read, or --raw TABLE:RANGE (e.g. hr:0-9)")
    if file is not None:
        given = " ".join([str(file), *names])
        raise click.UsageError(f"--raw reads without a description: leave out FILE and NAME ({given})")
    as_type, word_order, byte_order = how
    as_type = (as_type or "uint16").lower()
    if as_type not in AS_TYPES:
        raise click.BadParameter(f"'{as_type}' is not one of {', '.join(AS_TYPES)}", param_hint="'--as'")
    try:
        ranges = [parse_raw_range(text) for text in texts]
        functions = raw_functions(ranges, as_type, word_order or "big", byte_order or "big")
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="'--raw'") from None
    resolved = raw_device(functions)
    session = RawSession(resolved, connection, unit, as_type)
    if interval is not None:
        from mdl.device.fleet.poll import poll

        status = poll(session, functions, fmt, interval, count)
        _say_refused(functions, session, ranges)
        return status
    with session:
        values = session.read(functions)
    if len(session.unanswered) == len(functions):  # nothing to show: the error of a read that fails
        first = next(iter(session.unanswered.values()))
        hint = next((modicon_hint(r) for r in ranges if modicon_hint(r)), "")
        raise DeviceError(
            session.where(f"reading {first.count} {first.table} from {first.start}")
            + f": Modbus exception 2 (ILLEGAL DATA ADDRESS){hint}",
            2,
        )
    click.echo(output.render(functions, values, fmt, resolved.name), nl=False)
    _say_refused(functions, session, ranges)
    return 0


def _say_refused(functions: list[Function], session: RawSession, ranges: list[RawRange]) -> None:
    from mdl.device.survey.rawread import refused
    from mdl.diagnostics import Diagnostic

    for text in refused(functions, session.unanswered, ranges):
        say(Diagnostic(None, None, None, text, "warning"))
