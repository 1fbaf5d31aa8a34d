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
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mdl.exchange.connection import DEVICE_PORT, SIM_PORT, Endpoint, host_port

if TYPE_CHECKING:
    from pymodbus.client import ModbusBaseClient, ModbusBaseSyncClient
    from pymodbus.datastore import ModbusServerContext
    from pymodbus.framer import FramerType
    from pymodbus.server import ModbusBaseServer

Trace = Callable[[bool, bytes], bytes]

LOOPBACK = ("127.0.0.1", "localhost", "::1")


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
