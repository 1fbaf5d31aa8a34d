"""The options several commands share, in one place: input files (`-` is standard input), the
unit, -q/--quiet (every command), --fail-on-warning, and the CONNECTION options (SPEC 9)."""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar, cast

import click
from click.core import ParameterSource

from mdl.device.connection import LINE_SETTINGS, SETTINGS, Connection, split_host
from mdl.diagnostics import Diagnostic
from mdl.exchange.connection import DEVICE_PORT, LINE_ONLY, SIM_HOST, SIM_PORT
from mdl.fileio import STDIO_ARG, input_path, is_stdin

SCHEMAS = click.Choice(["0.9b", "1.0"], case_sensitive=False)
STDOUT = Path(STDIO_ARG)


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
    """An input file (INPUT), or a FILE@CONNECTION target of `mdl read` (kept as text: mdl.device.fleet.run
    parses it)."""

    def __init__(self) -> None:
        super().__init__(path_type=Path, allow_dash=True, readable=False)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Path | str:
        from mdl.device.connection import looks_like_target

        if isinstance(value, str) and looks_like_target(value):
            return value
        return INPUT.convert(value, param, ctx)


def stdin_once(paths: Iterable[Path]) -> None:
    if sum(1 for path in paths if is_stdin(path)) > 1:
        raise click.UsageError("standard input (-) can be read only once")


QUIET = "mdl.quiet"


def _remember_quiet(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[QUIET] = ctx.meta.get(QUIET, False) or value


QUIET_HELP = "Print no notes, summary or progress: only warnings and errors."


def quiet_option() -> click.Option:
    """-q/--quiet, which Group gives every command (SPEC 1): notes, `wrote FILE` and progress go."""
    return click.Option(["-q", "--quiet"], is_flag=True, expose_value=False, callback=_remember_quiet, help=QUIET_HELP)


def is_quiet() -> bool:
    ctx = click.get_current_context(silent=True)
    return ctx is not None and bool(ctx.meta.get(QUIET) or ctx.params.get("quiet"))


FAIL_ON_WARNING = "mdl.fail_on_warning"


def _remember_fail_on_warning(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[FAIL_ON_WARNING] = value


fail_on_warning_option = click.option(
    "--fail-on-warning",
    is_flag=True,
    expose_value=False,
    callback=_remember_fail_on_warning,
    help="Exit 1, before doing anything, if reading the input gives any warning (they print either way).",
)


def warning_refusal(warnings: Iterable[Diagnostic], file: Path) -> Diagnostic | None:
    """With --fail-on-warning, the error that warnings about `file` make; else None."""
    n = sum(1 for d in warnings if d.severity == "warning")
    if n and click.get_current_context().meta.get(FAIL_ON_WARNING):
        return Diagnostic(str(file), None, None, f"{n} warning{'s' * (n != 1)} and --fail-on-warning")
    return None


unit_option = click.option(
    "--unit", type=click.IntRange(0, 255), default=1, show_default=True, help="Unit (device) id to talk to."
)


# -- CONNECTION (SPEC 9): --host/--port, --serial and the line, --framer, --timeout/--retries ----------
SERIAL_OPTIONS = ("baud", "parity", "stopbits", "bytesize")
OPTION_NAMES = ("host", "port", "serial", *SERIAL_OPTIONS, "framer", "timeout", "retries")
PORT_HELP = (
    f"TCP port (default {DEVICE_PORT}, the Modbus TCP port; mdl sim listens on {SIM_PORT} by default). "
    "--host HOST:PORT gives both."
)
F = TypeVar("F", bound=Callable[..., Any])
Decorator = Callable[[Callable[..., Any]], Callable[..., Any]]


def connection_options(
    serving: bool = False, optional: bool = False, timeout: float = 3.0, retries: int = 1, line_alone: bool = False
) -> Callable[[F], F]:
    """The CONNECTION options of SPEC section 9, handed to the command as one `connection: Connection`.

    `serving` (mdl sim): --host defaults to 127.0.0.1 and --port to 5020 (0 picks a free port), and there
    is no --timeout/--retries. Otherwise (a client) --host or --serial is required, --port defaults to 502;
    `optional` (mdl export): neither is required, and without them `connection` is None. `timeout` and
    `retries` are the defaults of --timeout and --retries (mdl discover asks many units that may not
    answer: one short wait each). `line_alone` (mdl export, whose ESPHome node is itself on the line):
    --baud, --parity, --stopbits and --bytesize without --serial describe a line whose device is not
    named, a Connection with `serial` LINE_ONLY."""

    def decorate(command: F) -> F:
        @functools.wraps(command)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            given = {name: kwargs.pop(name) for name in OPTION_NAMES if name in kwargs}
            kwargs["connection"] = _build(given, serving, optional, line_alone)
            return command(*args, **kwargs)

        decorated: Callable[..., Any] = wrapper
        for option in reversed(_options(serving, timeout, retries)):
            decorated = option(decorated)
        return cast(F, decorated)

    return decorate


def _range(name: str) -> click.IntRange | click.FloatRange:
    """The click type of a connection setting, its range from mdl.device.connection (a URL's query
    takes the same)."""
    kind, low, high = {**SETTINGS, **LINE_SETTINGS}[name]
    return click.FloatRange(low, high) if kind is float else click.IntRange(int(low), int(high))


def _options(serving: bool, timeout: float = 3.0, retries: int = 1) -> list[Decorator]:
    """The click options, in the order --help lists them."""
    if serving:
        address = [
            click.option(
                "--host",
                default=SIM_HOST,
                show_default=True,
                metavar="HOST[:PORT]",
                help="Address to listen on (TCP); HOST:PORT ([IPV6]:PORT) gives the port too.",
            ),
            click.option(
                "--port",
                type=click.IntRange(0, 65535),
                default=SIM_PORT,
                show_default=True,
                help="TCP port; 0 picks a free port.",
            ),
        ]
    else:
        address = [
            click.option(
                "--host",
                metavar="HOST[:PORT]",
                help="Device address (Modbus TCP): HOST, HOST:PORT or [IPV6]:PORT; or give --serial.",
            ),
            click.option("--port", type=click.IntRange(1, 65535), default=DEVICE_PORT, help=PORT_HELP),
        ]
    line = [
        click.option("--serial", metavar="DEVICE", help="Serial device for Modbus RTU, e.g. /dev/ttyUSB0."),
        click.option("--baud", type=_range("baud"), default=19200, show_default=True, help="Serial line speed."),
        click.option(
            "--parity",
            type=click.Choice(["N", "E", "O"], case_sensitive=False),
            default="N",
            show_default=True,
            help="Serial parity: none, even, odd.",
        ),
        click.option("--stopbits", type=_range("stopbits"), default=1, show_default=True),
        click.option(
            "--bytesize", type=_range("bytesize"), default=8, show_default=True, help="Data bits (Modbus RTU uses 8)."
        ),
        click.option(
            "--framer",
            type=click.Choice(["tcp", "rtu"], case_sensitive=False),
            help="Framing on TCP: tcp (Modbus TCP, the default) or rtu (RTU frames, as serial-to-Ethernet "
            "converters carry them). A serial line always carries RTU.",
        ),
    ]
    client: list[Decorator] = (
        []
        if serving
        else [
            click.option(
                "--timeout",
                type=_range("timeout"),
                default=timeout,
                show_default=True,
                help="Seconds to wait for each reply.",
            ),
            click.option(
                "--retries",
                type=_range("retries"),
                default=retries,
                show_default=True,
                help="Times a request that got no reply is sent again.",
            ),
        ]
    )
    return address + line + client


def _build(given: dict[str, Any], serving: bool, optional: bool = False, line_alone: bool = False) -> Connection | None:
    """The Connection the options describe (None when `optional` and no --host or --serial is given);
    options that contradict each other are a usage error."""
    ctx = click.get_current_context()
    explicit = {name for name in given if ctx.get_parameter_source(name) is not ParameterSource.DEFAULT}
    serial, framer = given.get("serial"), given.get("framer")
    if serial is not None and not serial.strip():
        raise click.BadParameter(
            "give the serial device's name (such as /dev/ttyUSB0 or COM3)", param_hint="'--serial'"
        )
    if serial is not None:
        both = sorted(explicit & {"host", "port"})
        if both:
            raise click.UsageError(f"--serial and --{both[0]}: give one connection, a serial line or a TCP address")
        if framer == "tcp":
            raise click.UsageError("--framer tcp: a serial line carries RTU frames (--framer tcp needs --host)")
    else:
        line_only = [name for name in SERIAL_OPTIONS if name in explicit]
        if line_only and line_alone and given.get("host") is None:
            values = {
                name: given[name] for name in (*SERIAL_OPTIONS, "timeout", "retries") if given.get(name) is not None
            }
            return Connection(rtu=True, serial=LINE_ONLY, **values)
        if line_only:
            raise click.UsageError(line_needs_serial(line_only[0]))
        if not serving and given.get("host") is None:
            if optional:
                given_too = sorted(explicit & {"port", "framer", "timeout", "retries"})
                if given_too:
                    raise click.UsageError(f"--{given_too[0]} needs a connection: give --host HOST or --serial DEVICE")
                return None
            raise click.UsageError("no connection: give --host HOST (Modbus TCP) or --serial DEVICE (Modbus RTU)")
    if given.get("host") is not None:
        given["host"], given["port"] = _host_and_port(given["host"], given.get("port"), "port" in explicit, serving)
    values = {name: value for name, value in given.items() if name != "framer" and value is not None}
    return Connection(rtu=serial is not None or framer == "rtu", **values)


def line_needs_serial(option: str) -> str:
    return f"--{option} sets a serial line: it needs --serial DEVICE"


def _host_and_port(text: str, port: int | None, port_given: bool, serving: bool) -> tuple[str, int | None]:
    """--host HOST[:PORT] and --port as one address: the port in --host wins over --port's default, and
    one given both ways must agree (a usage error naming both otherwise)."""
    try:
        host, in_host = split_host(text)
    except ValueError as exc:
        raise click.BadParameter(f"{text!r}: {exc}", param_hint="'--host'") from None
    if in_host is None:
        return host, port
    low = 0 if serving else 1
    if not low <= in_host <= 65535:
        raise click.BadParameter(
            f"{text!r}: the port {in_host} is not in the range {low} to 65535", param_hint="'--host'"
        )
    if port_given and port != in_host:
        raise click.UsageError(
            f"--host {text} and --port {port} disagree: give the port once (--host HOST:PORT or --port PORT)"
        )
    return host, in_host
