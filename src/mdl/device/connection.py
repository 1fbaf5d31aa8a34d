"""Connections to Modbus devices (SPEC section 9): the one place that turns connection options into
pymodbus clients and servers.

Three kinds: Modbus TCP (`--host H --port P`), Modbus RTU on a serial line (`--serial DEVICE` with
`--baud --parity --stopbits --bytesize`), and RTU frames over TCP (`--host H --port P --framer rtu`,
as serial-to-Ethernet converters carry them). A `Connection` is the plain mdl.exchange.connection.Endpoint
with what opens it (a pymodbus client or server, the serial device); the command line's options make one
(mdl.cli.options.connection_options).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Any
from urllib.parse import parse_qsl

from mdl.exchange.connection import DEVICE_PORT, SIM_PORT, Endpoint, host_port

if TYPE_CHECKING:
    from pymodbus.client import ModbusBaseClient, ModbusBaseSyncClient
    from pymodbus.datastore import ModbusServerContext
    from pymodbus.framer import FramerType
    from pymodbus.server import ModbusBaseServer

Trace = Callable[[bool, bytes], bytes]

LOOPBACK = ("127.0.0.1", "localhost", "::1")


SCHEMES = ("tcp", "rtu+tcp", "rtu")
# the ranges of the connection settings, as the CONNECTION options (mdl.cli.options) and a URL's query
# (parse_connection) take them: (type, lowest, highest)
SETTINGS: dict[str, tuple[type, float, float]] = {"timeout": (float, 0.1, 600), "retries": (int, 0, 10)}
LINE_SETTINGS: dict[str, tuple[type, float, float]] = {
    "baud": (int, 50, 4_000_000),
    "stopbits": (int, 1, 2),
    "bytesize": (int, 7, 8),
}


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


class Connection(Endpoint):
    """An Endpoint (the same fields; a record) the device commands open: its pymodbus client or server, its
    serial device checked as pyserial opens it, and what their messages say about it."""

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
        """An asyncio pymodbus client (mdl.device.fleet.run), not yet connected, that never reconnects on
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


_AT = re.compile(r"@(?=(?:tcp|rtu\+tcp|rtu)://)")  # FILE@CONNECTION: where the connection starts
TARGET_FORMS = (
    "FILE@tcp://HOST[:PORT][#UNIT], FILE@rtu+tcp://HOST[:PORT][#UNIT] or FILE@rtu://DEVICE[?baud=B&parity=P][#UNIT]"
)


def looks_like_target(text: str) -> bool:
    """Whether a command-line argument is a FILE@CONNECTION target (not a file or a function name)."""
    return _AT.search(text) is not None


def parse_connection(url: str, **defaults: Any) -> tuple[Connection, int | None]:
    """A connection as a URL (the one grammar of targets and of `mdl serve --from`): `tcp://HOST[:PORT]`
    (a bare `HOST[:PORT]` too), `rtu+tcp://HOST[:PORT]`, `rtu://DEVICE[?baud=B&parity=P&stopbits=S&
    bytesize=8]`, each with `?timeout=S&retries=N` and `#UNIT`; `defaults` are the connection's settings
    the URL does not give. (connection, unit or None); ValueError saying what is wrong."""
    scheme, sep, rest = url.partition("://")
    if not sep:
        scheme, rest = "tcp", url
    if scheme.lower() not in SCHEMES:
        raise ValueError(f"unknown scheme '{scheme}://' (write {', '.join(s + '://' for s in SCHEMES)})")
    scheme = scheme.lower()
    rest, hash_sign, fragment = rest.partition("#")
    rest, _, query = rest.partition("?")
    settings = {**defaults, **_query(query, scheme)}
    unit = _unit(fragment) if hash_sign else None
    if scheme == "rtu":
        if not rest:
            raise ValueError("rtu:// needs the serial device: rtu:///dev/ttyUSB0")
        return Connection(serial=rest, rtu=True, **settings), unit
    if "/" in rest:
        raise ValueError(f"'{rest}' is no HOST[:PORT] (a serial device is rtu:///dev/...)")
    host, port = split_host(rest)
    if port is not None and not 1 <= port <= 65535:
        raise ValueError(f"the port {port} is not in the range 1 to 65535")
    return Connection(host=host, port=port or DEVICE_PORT, rtu=scheme == "rtu+tcp", **settings), unit


def _unit(text: str) -> int:
    if not text.isascii() or not text.isdigit() or not 0 <= int(text) <= 255:
        raise ValueError(f"the unit id {text!r} after '#' is not a number from 0 to 255")
    return int(text)


def _query(query: str, scheme: str) -> dict[str, Any]:
    """A target's ?key=value&... settings, checked."""
    known = {**SETTINGS, **(LINE_SETTINGS if scheme == "rtu" else {})}
    out: dict[str, Any] = {}
    for key, value in parse_qsl(query, keep_blank_values=True):
        if key == "parity" and scheme == "rtu":
            if value.upper() not in ("N", "E", "O"):
                raise ValueError(f"parity={value}: write N, E or O")
            out[key] = value.upper()
            continue
        if key not in known:
            names = ", ".join([*known, *(["parity"] if scheme == "rtu" else [])])
            raise ValueError(f"unknown setting {key!r} (a {scheme}:// target takes {names})")
        kind, low, high = known[key]
        try:
            number = kind(value)
        except ValueError:
            raise ValueError(f"{key}={value}: not a number") from None
        if not low <= number <= high:
            raise ValueError(f"{key}={value}: not in the range {low:g} to {high:g}")
        out[key] = number
    return out
