"""Where a device is and how frames travel there (SPEC section 9), as a plain value: what a format or an
engine's configuration names. mdl.device.connection turns the command line's options into one and makes
it a pymodbus client or server."""

from __future__ import annotations

from mdl.records import record

SIM_HOST, DEVICE_PORT = "127.0.0.1", 502
SIM_PORT = 5020  # where mdl sim listens unless --port says otherwise


def host_port(host: str, port: int) -> str:
    """`host:port` as messages and `--host` write it: an IPv6 address in brackets, `[::1]:502`."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


LINE_ONLY = ""  # `serial` of a line given by its settings alone (mdl export --to esphome --baud 9600)


@record
class Endpoint:
    """Where a device is and how frames travel there. `serial` set: RTU on that serial device;
    otherwise TCP to host:port, with RTU frames when `rtu` is true."""

    host: str = SIM_HOST
    port: int = DEVICE_PORT
    serial: str | None = None
    baud: int = 19200
    parity: str = "N"
    stopbits: int = 1
    bytesize: int = 8
    rtu: bool = False
    timeout: float = 3.0
    retries: int = 1

    def __str__(self) -> str:
        """The connection as messages name it: `/dev/ttyUSB0 (19200 8N1)`, `host:port`, `host:port (RTU over TCP)`."""
        if self.serial is not None:
            return f"{self.serial} ({self.baud} {self.bytesize}{self.parity}{self.stopbits})"
        return f"{host_port(self.host, self.port)}{' (RTU over TCP)' if self.rtu else ''}"
