"""Connections to Modbus devices (SPEC section 9): the one place that turns connection options into
pymodbus clients and servers.

Three kinds: Modbus TCP (`--host H --port P`), Modbus RTU on a serial line (`--serial DEVICE` with
`--baud --parity --stopbits --bytesize`), and RTU frames over TCP (`--host H --port P --framer rtu`,
as serial-to-Ethernet converters carry them). `connection_options` is the click decorator that
`mdl read`, `mdl write` and `mdl sim` share: it turns the options into one `Connection` argument, the
plain mdl.exchange.connection.Endpoint with what opens it (a pymodbus client or server, the serial device).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar, cast

import click
from click.core import ParameterSource

from mdl.exchange.connection import DEVICE_PORT, LINE_ONLY, SIM_HOST, Endpoint, host_port

if TYPE_CHECKING:
    from pymodbus.client import ModbusBaseClient, ModbusBaseSyncClient
    from pymodbus.datastore import ModbusServerContext
    from pymodbus.framer import FramerType
    from pymodbus.server import ModbusBaseServer

F = TypeVar("F", bound=Callable[..., Any])
Trace = Callable[[bool, bytes], bytes]
Decorator = Callable[[Callable[..., Any]], Callable[..., Any]]

SERIAL_OPTIONS = ("baud", "parity", "stopbits", "bytesize")
OPTION_NAMES = ("host", "port", "serial", *SERIAL_OPTIONS, "framer", "timeout", "retries")
SIM_PORT = 5020
LOOPBACK = ("127.0.0.1", "localhost", "::1")
PORT_HELP = (
    f"TCP port (default {DEVICE_PORT}, the Modbus TCP port; mdl sim listens on {SIM_PORT} by default). "
    "--host HOST:PORT gives both."
)


def split_host(text: str) -> tuple[str, int | None]:
    """`--host` as users write it: `HOST`, `HOST:PORT`, `[IPV6]` or `[IPV6]:PORT` -> (host, port or None).
    An address with more than one colon and no brackets is an IPv6 address without a port.
    ValueError saying what is wrong."""
    if text.startswith("["):
        host, bracket, rest = text[1:].partition("]")
        if not bracket:
            raise ValueError("an IPv6 address in brackets needs its ']': [::1]:5020")
        if rest and not rest.startswith(":"):
            raise ValueError(f"{rest!r} after ']': write [IPV6]:PORT")
        port_text: str | None = rest[1:] if rest else None
    elif text.count(":") == 1:
        host, _, port_text = text.partition(":")
    else:
        host, port_text = text, None
    if not host.strip():
        raise ValueError("no host: write HOST or HOST:PORT, e.g. 127.0.0.1:5020")
    if port_text is None:
        return host, None
    if not port_text.isascii() or not port_text.isdigit():
        raise ValueError(f"the port {port_text!r} is not a number: write HOST:PORT, e.g. 127.0.0.1:5020")
    return host, int(port_text)


@dataclass(frozen=True)
class Connection(Endpoint):
    """An Endpoint the device commands open: its pymodbus client or server, its serial device checked
    as pyserial opens it, and what their messages say about it."""

    @property
    def framer(self) -> FramerType:
        from pymodbus.framer import FramerType

        return FramerType.RTU if self.rtu else FramerType.SOCKET

    def client(self, trace: Trace | None = None) -> ModbusBaseSyncClient:
        """A synchronous pymodbus client, not yet connected. `retries` counts the sends after the first."""
        from pymodbus.client import ModbusSerialClient, ModbusTcpClient

        client: ModbusBaseSyncClient = self._client(ModbusSerialClient, ModbusTcpClient, trace)
        return client

    def async_client(self, trace: Trace | None = None) -> ModbusBaseClient:
        """An asyncio pymodbus client (mdl.device.fleet), not yet connected, that never reconnects on
        its own: the poller connects again at its next poll, as the synchronous one does."""
        from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient

        client: ModbusBaseClient = self._client(AsyncModbusSerialClient, AsyncModbusTcpClient, trace, reconnect_delay=0)
        return client

    def _client(self, serial: type, tcp: type, trace: Trace | None, **more: Any) -> Any:
        """A client of class `serial` or `tcp` (pymodbus's synchronous or asyncio ones take the same arguments)."""
        if self.serial is not None:
            return serial(
                self.serial,
                **self.line_settings(),
                timeout=self.timeout,
                retries=self.retries,
                trace_packet=trace,
                **more,
            )
        return tcp(
            self.host,
            port=self.port,
            framer=self.framer,
            timeout=self.timeout,
            retries=self.retries,
            trace_packet=trace,
            **more,
        )

    def line_settings(self) -> dict[str, Any]:
        """The serial line's settings as pyserial and pymodbus take them."""
        return {"baudrate": self.baud, "parity": self.parity, "stopbits": self.stopbits, "bytesize": self.bytesize}

    def server(self, context: ModbusServerContext) -> ModbusBaseServer:
        """A pymodbus server of `context` (to be created inside the running event loop). On RTU framing a
        request for a unit the context does not serve gets no answer, as on a bus."""
        from pymodbus.server import ModbusSerialServer, ModbusTcpServer

        if self.serial is not None:
            return ModbusSerialServer(
                context,
                port=self.serial,
                **self.line_settings(),
                ignore_missing_devices=True,
            )
        return ModbusTcpServer(
            context, framer=self.framer, address=(self.host, self.port), ignore_missing_devices=self.rtu
        )

    def serving_at(self, bound_port: int) -> str:
        """Where a server listens, for `mdl sim`'s ready line: the serial device, or host:port."""
        return self.serial if self.serial is not None else host_port(self.host, bound_port)

    def open_error(self) -> str | None:
        """Why the serial device cannot be opened as pyserial opens it (read-write, an exclusive lock, a
        terminal's settings), in the operating system's words; None if it can, or if the system cannot tell."""
        if self.serial is None or "://" in self.serial or os.name != "posix":
            return None
        import fcntl
        import termios

        try:
            fd = os.open(self.serial, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError as exc:
            return exc.strerror or str(exc)
        try:
            termios.tcgetattr(fd)
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except termios.error as exc:
            return f"not a serial device ({exc.args[-1]})"
        except OSError:
            return "another program has it open"
        finally:
            os.close(fd)  # which releases the lock
        return self._settings_error()

    def _settings_error(self) -> str | None:
        """Why the device refuses this connection's baud rate, parity, stop bits or byte size (a
        pseudo terminal refuses parity on some kernels), in the system's words; None if it takes them."""
        import termios

        import serial  # type: ignore[import-untyped]  # pyserial ships no types

        try:
            serial.Serial(self.serial, **self.line_settings()).close()
        except (serial.SerialException, ValueError, OSError, termios.error) as exc:
            reason = exc.args[-1] if isinstance(exc, (OSError, termios.error)) and exc.args else exc
            return self.settings_refusal(reason)
        return None

    def settings_refusal(self, reason: object) -> str:
        """The serial device refused this line's settings, for `reason` (the system's words)."""
        return f"it refuses {self.baud} {self.bytesize}{self.parity}{self.stopbits} ({reason})"

    def refused_hint(self) -> str:
        """What to check when no TCP connection could be made; empty where there is nothing to add. The
        default --port of a client (502) is not the sim's (5020): a sim on this machine is the likely one."""
        if self.serial is None and self.port == DEVICE_PORT and self.host.lower() in LOOPBACK:
            return f"is `mdl sim` running? it listens on {SIM_PORT} unless --port says otherwise"
        return ""

    def silence_hint(self) -> str:
        """What to check when an RTU line gives no answer at all; empty on Modbus TCP."""
        if self.serial is not None:
            return "check baud rate, parity and unit id"
        if self.rtu:
            return "check the unit id, and the converter's baud rate and parity"
        return ""


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
        click.option(
            "--baud", type=click.IntRange(50, 4_000_000), default=19200, show_default=True, help="Serial line speed."
        ),
        click.option(
            "--parity",
            type=click.Choice(["N", "E", "O"], case_sensitive=False),
            default="N",
            show_default=True,
            help="Serial parity: none, even, odd.",
        ),
        click.option("--stopbits", type=click.IntRange(1, 2), default=1, show_default=True),
        click.option(
            "--bytesize", type=click.IntRange(7, 8), default=8, show_default=True, help="Data bits (Modbus RTU uses 8)."
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
                type=click.FloatRange(0.1, 600),
                default=timeout,
                show_default=True,
                help="Seconds to wait for each reply.",
            ),
            click.option(
                "--retries",
                type=click.IntRange(0, 10),
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
