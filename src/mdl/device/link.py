"""A Modbus client with checked frames and no description: one unit (or, for discover and probe,
several units in turn) at a connection, asked for raw registers and bits. Every reply is checked
before it is trusted (mdl.device.frames); anything wrong, and any broken connection, is a
DeviceError (exit 3) naming the connection, the unit and what was wrong. `mdl.device.runtime.Session`
is a Link with a description; probe, discover and capture use a Link alone."""

from __future__ import annotations

import errno
import socket
from collections.abc import Callable
from typing import Any, TypeVar

from pymodbus.exceptions import ConnectionException, ModbusException, ModbusIOException
from pymodbus.pdu import ModbusPDU

from mdl.device.connection import Connection
from mdl.device.frames import Wire
from mdl.diagnostics import DeviceError
from mdl.model.layout import address_runs
from mdl.plan import Request

EXCEPTION_NAMES = {
    1: "ILLEGAL FUNCTION",
    2: "ILLEGAL DATA ADDRESS",
    3: "ILLEGAL DATA VALUE",
    4: "SERVER DEVICE FAILURE",
    5: "ACKNOWLEDGE",
    6: "SERVER DEVICE BUSY",
    8: "MEMORY PARITY ERROR",
    10: "GATEWAY PATH UNAVAILABLE",
    11: "GATEWAY TARGET DEVICE FAILED TO RESPOND",
}


def local_shortage() -> str | None:
    """Why this process cannot open a socket now (its open files, the system's, or memory used up), in words
    that say the fault is here, not at the device; None if it can. pymodbus's clients only say that they
    could not connect: this asks the system the same question again."""
    try:
        socket.socket(socket.AF_INET, socket.SOCK_STREAM).close()
    except OSError as exc:
        if exc.errno == errno.EMFILE:
            return f"too many open files in mdl ({_file_limit()}); the device was not asked"
        if exc.errno == errno.ENFILE:
            return "too many open files on this machine; the device was not asked"
        if exc.errno in (errno.ENOBUFS, errno.ENOMEM):
            return "this machine has no memory left for a connection; the device was not asked"
    return None


def _file_limit() -> str:
    try:
        import resource
    except ImportError:  # not a POSIX system
        return "the system's limit"
    soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
    return "its limit" if soft == resource.RLIM_INFINITY else f"its limit is {soft}: raise it with ulimit -n"


class ModbusExceptionError(DeviceError):
    def __init__(self, what: str, code: int):
        super().__init__(f"{what}: Modbus exception {code} ({EXCEPTION_NAMES.get(code, 'unknown')})", code)


_L = TypeVar("_L", bound="Link")


class Link:
    """A connection to one unit: Modbus TCP, RTU on a serial line, or RTU over TCP."""

    def __init__(self, connection: Connection, unit: int = 1):
        self.connection, self.unit = connection, unit
        self.asking = f"unit {unit}"  # the unit, or the units, that a connection error names (SPEC 9)
        self.tries = connection.retries + 1
        self.wire = Wire(connection.rtu)
        self.client = connection.client(self.wire.trace)
        self._methods: dict[str, Callable[..., ModbusPDU]] = {
            "holding": self.client.read_holding_registers,
            "input": self.client.read_input_registers,
            "coil": self.client.read_coils,
            "discrete": self.client.read_discrete_inputs,
        }

    def __enter__(self: _L) -> _L:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def connect(self) -> None:
        """Open the connection unless it is open (again, after `close`); DeviceError if it cannot be opened."""
        connect: Callable[[], bool] = self.client.connect  # typed here: pymodbus leaves it unannotated
        if connect():
            return
        raise self.connect_error()

    def connect_error(self) -> DeviceError:
        """Why the connection could not be opened."""
        conn = self.connection
        if conn.serial is not None:
            why = conn.open_error() or "pymodbus refused it"
            return DeviceError(f"cannot open serial device {conn.serial} for {self.asking}: {why}")
        shortage = local_shortage()
        if shortage is not None:
            return DeviceError(f"cannot connect to {conn} for {self.asking}: {shortage}")
        nobody = "no converter or device accepts connections there" if conn.rtu else "no Modbus TCP device answers"
        hint = conn.refused_hint()
        return DeviceError(f"cannot connect to {conn} for {self.asking}: {nobody}{'; ' + hint if hint else ''}")

    def asking_units(self, units: list[int]) -> None:
        """Name `units` in a connection error (discover and probe ask many through one connection)."""
        runs = address_runs(sorted(set(units)))
        spans = ", ".join(str(a) if n == 1 else f"{a}-{a + n - 1}" for a, n in runs)
        self.asking = f"unit {spans}" if len(units) == 1 else f"units {spans}"

    def close(self) -> None:
        close: Callable[[], None] = self.client.close  # typed here: pymodbus leaves it unannotated
        close()

    def where(self, what: str) -> str:
        return f"{self.connection} unit {self.unit}: {what}"

    def _call(self, what: str, method: Callable[..., ModbusPDU], *args: Any, **kw: Any) -> ModbusPDU:
        self.wire.clear()
        try:
            result = method(*args, device_id=self.unit, **kw)
        except (ModbusException, OSError) as exc:
            raise self.failed(what, exc) from None
        return self.checked(what, result)

    def failed(self, what: str, exc: ModbusException | OSError) -> DeviceError:
        """The error of a request that got no reply the client would decode."""
        return DeviceError(f"{self.where(what)}: {self._failure(exc)}")

    def checked(self, what: str, result: ModbusPDU) -> ModbusPDU:
        """The reply, once the wire's bytes and the reply's exception code say it can be trusted."""
        problem = self.wire.accepted_problem()
        if problem:
            raise DeviceError(f"{self.where(what)}: {problem}")
        if result.isError():
            raise ModbusExceptionError(self.where(what), getattr(result, "exception_code", 0))
        return result

    def _failure(self, exc: ModbusException | OSError) -> str:
        """Why a request got no reply the client would decode; on an RTU line that gave no answer at all,
        or no RTU frame, what to check."""
        problem = self.wire.refused_problem()
        hint = self.connection.silence_hint()
        if problem:
            return f"{problem}; {hint}" if hint and problem.startswith("the reply is not") else problem
        if isinstance(exc, ConnectionException):
            if self.connection.serial is not None:
                return f"the serial device failed: {self.connection.open_error() or 'it closed'}"
            return "the connection closed without a reply"
        if isinstance(exc, ModbusIOException):
            tries = f"{self.tries} {'try' if self.tries == 1 else 'tries'}"
            silent = f"no reply within {self.connection.timeout:g} s ({tries})"
            return f"{silent}; {hint}" if hint else silent
        if isinstance(exc, OSError):
            return f"connection error: {exc.strerror or exc}"
        return str(exc)

    def read_request(self, req: Request) -> list[int]:
        """The `req.count` registers or bits of one request (the reply's byte count was checked)."""
        what = self.reading(req)
        return self.unpacked(req, self._call(what, self._methods[req.table], req.start, count=req.count))

    @staticmethod
    def reading(req: Request) -> str:
        return f"reading {req.count} {req.table} from {req.start}"

    def unpacked(self, req: Request, result: ModbusPDU) -> list[int]:
        """The registers or bits of a checked reply to `req`."""
        if req.table in ("coil", "discrete"):  # the padding bits are dropped
            return [int(b) for b in result.bits[: req.count]]
        registers = list(result.registers)
        if len(registers) != req.count:  # the byte count was checked: never, but a buffer must not shift
            raise DeviceError(self.where(f"{self.reading(req)}: the reply carries {len(registers)} registers"))
        return registers
