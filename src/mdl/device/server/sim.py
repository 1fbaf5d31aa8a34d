"""`mdl sim`: devices as a Modbus server, each at its unit id, holding exactly the addresses it uses.

The server is Modbus TCP, RTU on a serial line, or RTU frames over TCP (mdl.device.connection builds it).
The datastore is our own (a ModbusServerContext that answers itself), so that every address the
device does not define gets exception 2 (ILLEGAL DATA ADDRESS), bits included, and writes to
functions the description marks read-only are refused with exception 2 as well.

Function 43 / MEI 14 (Read Device Identification) is answered by each unit from its own device's
identity elements (SPEC 2.2 and 10): pymodbus answers it from one identity per process (a global
control block), so the server's decoder is given a request class of ours that asks the unit.

A server on TCP holds at most `most_clients()` connections (CLIENTS_MOST, fewer where the open-file limit is
low, keeping FILES_KEPT files for the process itself and a gateway's connection to its device): one more
closes the connection idle the longest, one that never sent a request first, so that clients that ask
keep being answered; connections whose clients have left already, unread, make room first (`peers_gone`).
That, and a connection the system refuses to accept (out of open files), is said in one line at most
every NOTICE_EVERY seconds (`Crowd`), never as a traceback per attempt.
"""

from __future__ import annotations

import asyncio
import errno
import functools
import json
import logging
import os
import select
import signal
import struct
import sys
import time
from collections import Counter
from collections.abc import Awaitable, Callable, Iterable, Sequence
from contextvars import ContextVar
from itertools import repeat
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, TextIO

from pymodbus.constants import DeviceInformation, ExcCodes
from pymodbus.datastore import ModbusServerContext
from pymodbus.exceptions import ModbusException, NoSuchIdException
from pymodbus.logging import Log
from pymodbus.pdu import DecodePDU, ExceptionResponse, ModbusPDU
from pymodbus.pdu.device import DeviceInformationFactory, ModbusDeviceIdentification
from pymodbus.pdu.mei_message import ReadDeviceInformationRequest, ReadDeviceInformationResponse
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersResponse,
    ReadInputRegistersResponse,
    ReadWriteMultipleRegistersResponse,
)
from pymodbus.server.requesthandler import ServerRequestHandler

from mdl.device.connection import Connection
from mdl.diagnostics import error, one_line
from mdl.fileio import read_text
from mdl.ir import codec
from mdl.ir import steps as ir
from mdl.ir.build import encode_steps
from mdl.model import Device, Function, Scenario, Value
from mdl.plan import TABLE_ORDER, defined_addresses
from mdl.resolver import ResolvedDevice

if TYPE_CHECKING:
    from _typeshed import StrPath
    from pymodbus.server import ModbusBaseServer

FC_TABLE = {
    1: "coil",
    5: "coil",
    15: "coil",
    2: "discrete",
    4: "input",
    3: "holding",
    6: "holding",
    16: "holding",
    22: "holding",
    23: "holding",
}
# the functions served: the tables', diagnostics (8) and Read Device Identification (43 / MEI 14); the
# others pymodbus knows (file records, FIFO, event counters, report server id) it would answer from one
# process-wide state, not from the device, and file records with no reply at all for some requests
SERVED_FUNCTIONS = frozenset({*FC_TABLE, 8, 43})

# the basic objects of Read Device Identification (object id = position) and the identity element
# (SPEC 2.2) each is answered from; mdl discover shows them under these names
IDENTIFICATION = (("VendorName", "manufacturer"), ("ProductCode", "product"), ("MajorMinorRevision", "product_version"))
# the longest object sent: one object and the reply's header must fit one PDU (pymodbus: 253 - 6 bytes in all)
MAX_OBJECT_BYTES = 240
# what pymodbus logs while serving: at most this many lines per client and in all per window of seconds
LOG_PER_CLIENT, LOG_TOTAL, LOG_WINDOW = 3, 20, 1.0
SPANS_KEPT = 4096  # spans of addresses a device remembers it defines (polls ask the same few again and again)
CLIENTS_MOST = 100  # connections one server holds at once, at most
FILES_KEPT = 32  # open files no client may take: the process's own, a gateway's connection to its device
NOTICE_EVERY = 10.0  # seconds between two lines about connections closed or not accepted
ACCEPT_BURST = 32  # the listen backlog, which is also how many connections asyncio accepts at once
CLIENT: ContextVar[str] = ContextVar("mdl_sim_client", default="")  # host:port of the client being served
# what pymodbus logs that says nothing to a user of the sim (its error lines may have frames appended):
# its own stand-in for a repeated message, and the reply to a client that left before it was answered
UNSAID = ("Repeating....", "Cancel send, because not connected!")


def identification(device: Device) -> tuple[dict[int, bytes], list[str]]:
    """The device's basic identification objects (object id -> UTF-8 bytes) from its identity elements,
    and a warning for each element too long for one reply (it is cut, at a character boundary)."""
    objects: dict[int, bytes] = {}
    warnings: list[str] = []
    for object_id, (name, attr) in enumerate(IDENTIFICATION):
        text: str | None = getattr(device, attr)
        if not text:
            continue
        data = text.encode("utf-8")
        if len(data) > MAX_OBJECT_BYTES:
            data = data[:MAX_OBJECT_BYTES].decode("utf-8", "ignore").encode("utf-8")
            warnings.append(
                f"{attr} is {len(text.encode('utf-8'))} bytes long; function 43 answers {name} "
                f"with its first {len(data)} bytes"
            )
        objects[object_id] = data
    return objects, warnings


class Registers:
    """The four tables of a simulated device: address -> value for defined addresses only (the layouts
    are the resolved device's: an expression's registers are known only there)."""

    def __init__(self, resolved: ResolvedDevice, permissive: bool = False):
        self.device = device = resolved.device
        self.layouts = layouts = {f.name: f.layout for f in resolved.functions}
        self.permissive = permissive
        objects, self.identity_warnings = identification(device)
        # None: the device answers function 43 with exception 1, as one without identification does
        identity: Callable[..., ModbusDeviceIdentification] = ModbusDeviceIdentification  # pymodbus leaves it untyped
        self.identity = identity(info=objects) if objects else None
        self.missing: set[tuple[str, int]] = set()  # no value in a scenario: answer exception 2
        self.spans: set[tuple[str, int, int]] = set()  # (table, address, count) found defined: clients ask again
        self.tables = {t: dict.fromkeys(sorted(addrs), 0) for t, addrs in defined_addresses(device, layouts).items()}
        self.read_only: dict[str, set[int]] = {t: set() for t in TABLE_ORDER}
        for fn in device.functions:
            if not fn.writable:
                lay = layouts[fn.name]
                self.read_only[lay.table].update(lay.addresses)
        for fn in device.functions:  # an address shared with a writable function stays writable
            if fn.writable:
                lay = layouts[fn.name]
                self.read_only[lay.table].difference_update(lay.addresses)
        for fn in device.functions:  # the raw values the device starts with (SPEC 2.2 initial)
            if fn.initial is not None and fn.expression is None:
                lay = layouts[fn.name]
                self.put_each(lay.table, lay.addresses, fn.initial)

    def defined(self, table: str, address: int, count: int) -> bool:
        span = (table, address, count)
        if self.permissive or span in self.spans:
            return True
        if not all(map(self.tables[table].__contains__, range(address, address + count))):
            return False
        if len(self.spans) >= SPANS_KEPT:  # a client that asks ever other spans: start again
            self.spans.clear()
        self.spans.add(span)  # addresses are never taken away: it stays defined
        return True

    def get(self, table: str, address: int, count: int) -> list[int]:
        return list(map(self.tables[table].get, range(address, address + count), repeat(0)))

    def answered(self, table: str, address: int, count: int) -> bool:
        """Whether a scenario gives every one of these addresses a value (`missing`)."""
        missing = self.missing
        return not missing or missing.isdisjoint(zip(repeat(table), range(address, address + count)))

    def put(self, table: str, address: int, values: Iterable[int]) -> None:
        for i, v in enumerate(values):
            self.tables[table][address + i] = int(v) & (1 if table in ("coil", "discrete") else 0xFFFF)

    def put_each(self, table: str, addresses: Iterable[int], values: Iterable[int]) -> None:
        """Values at addresses that need not follow each other."""
        for address, value in zip(addresses, values, strict=True):
            self.put(table, address, [value])

    def load_json(self, path: StrPath) -> None:
        text = read_text(path)
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise error(f"invalid JSON: {exc.msg}", path, exc.lineno, exc.colno) from None
        except ValueError as exc:  # a number of more digits than int() converts
            raise error(f"invalid JSON: {exc}", path) from None
        if not isinstance(data, dict):
            raise error("expected an object with keys holding, input, coil, discrete", path)
        for table, values in data.items():
            if table not in self.tables or not isinstance(values, dict):
                raise error(f"unknown table '{table}' (expected holding, input, coil, discrete)", path)
            for key, value in values.items():
                try:
                    address = int(key, 0)
                    if isinstance(value, float) and not value.is_integer():  # 1.5, Infinity, NaN
                        raise ValueError(value)
                    value = int(value)
                except (TypeError, ValueError):
                    raise error(f"{table} {key!r}: expected a wire address and an integer value", path) from None
                if not self.defined(table, address, 1):
                    raise error(f"{table} address {address} is not defined by the device", path)
                limit = 1 if table in ("coil", "discrete") else 0xFFFF
                if not 0 <= value <= limit:
                    raise error(f"{table} {address}: value {value} is out of range 0..{limit}", path)
                self.put(table, address, [value])

    def load_scenario(self, sc: Scenario) -> None:
        """Registers from a test scenario. A register the scenario gives no value ("----", or none
        at all) or a read error ("xxxx") answers exception 2, as one the device lacks: drivers then
        read it as having no value, as `mdl test` does (the wire cannot carry the difference)."""
        from mdl.device.server.scenarios import READ_ERROR, scenario_registers

        given = scenario_registers(sc)
        for table, addresses in self.tables.items():
            for address in addresses:
                value = given.get((table, address))
                if value is None or value == READ_ERROR:
                    self.missing.add((table, address))
                else:
                    addresses[address] = value

    def set_value(self, fn: Function, text: str) -> None:
        if fn.expression is not None:  # its registers are another function's, or none
            raise error(
                f"--set {fn.name}={text}: '{fn.name}' is an expression, computed from registers: "
                "set the functions or registers it reads instead"
            )
        lay = self.layouts[fn.name]
        factor: tuple[Value, ...] = ()
        if fn.factor is not None:  # encoded with the factor the device holds now (as a driver reads it)
            found = next(f for f in self.device.functions if f.name == fn.factor)
            at = self.layouts[found.name]
            factor = (codec.decode(found, self.get_each(at.table, at.addresses)),)
        try:
            regs = codec.encode(fn, codec.parse_value(fn, text), *factor)
        except (codec.CodecError, ValueError, ZeroDivisionError) as exc:
            said = f" ('{fn.factor}' holds {'null' if factor[0] is None else factor[0]})" if factor else ""
            raise error(f"--set {fn.name}={text}: {exc}{said}") from None
        merge = ir.find_step(encode_steps(fn, lay), ir.Merge)
        if merge is not None:  # only its bits: the functions sharing its registers keep theirs
            regs = codec.merge(self.get_each(lay.table, lay.addresses), regs, merge.masks)
        self.put_each(lay.table, lay.addresses, regs)

    def get_each(self, table: str, addresses: Iterable[int]) -> list[int]:
        return [self.tables[table].get(a, 0) for a in addresses]


def set_value(devices: Sequence[Registers], name: str, text: str) -> None:
    """`--set NAME=VALUE`: the value of the function in every device that has it (one at least)."""
    found = [(registers, fn) for registers in devices for fn in registers.device.functions if fn.name == name]
    if not found:
        where = "the device" if len(devices) == 1 else f"any of the {len(devices)} devices"
        raise error(f"--set {name}: no function '{name}' in {where}")
    for registers, fn in found:
        registers.set_value(fn, text)


class SimContext(ModbusServerContext):
    """Answers requests from the `Registers` of each unit served; pymodbus calls async_getValues/async_setValues.

    A request for a unit id no device is served at gets exception 11 (GATEWAY TARGET DEVICE FAILED TO
    RESPOND), as from a gateway to a bus; `silent` (RTU framing, where the server is the bus): no
    answer at all, as no device on a bus answers for another. Unit 0 stands for any unit id (one device only)."""

    def __init__(self, units: dict[int, Registers], silent: bool = False):  # pylint: disable=super-init-not-called
        self.units = units
        self.silent = silent
        self.old_simulator = True
        self.simdevices = []

    def device_ids(self) -> list[int]:
        return list(self.units)

    def at(self, device_id: int) -> Registers | None:
        """The device at `device_id`; None (exception 11) or, when silent, no answer if there is none."""
        registers = self.units.get(device_id, self.units.get(0))
        if registers is None and self.silent:
            raise NoSuchIdException(f"no device at unit {device_id}")  # the server then sends nothing
        return registers

    async def async_getValues(
        self, device_id: int, func_code: int, address: int, count: int = 1
    ) -> list[int] | list[bool] | ExcCodes:
        registers, table = self.at(device_id), FC_TABLE.get(func_code, "")
        if registers is None:  # no device at this unit id
            return ExcCodes.GATEWAY_NO_RESPONSE
        if not table:
            return ExcCodes.ILLEGAL_FUNCTION
        if not registers.defined(table, address, count):
            return ExcCodes.ILLEGAL_ADDRESS
        if not registers.answered(table, address, count):
            return ExcCodes.ILLEGAL_ADDRESS
        values = registers.get(table, address, count)
        return list(map(bool, values)) if table in ("coil", "discrete") else values

    async def async_setValues(
        self, device_id: int, func_code: int, address: int, values: Sequence[int] | Sequence[bool]
    ) -> ExcCodes | None:
        registers, table = self.at(device_id), FC_TABLE.get(func_code, "")
        if registers is None:  # no device at this unit id
            return ExcCodes.GATEWAY_NO_RESPONSE
        if table not in ("coil", "holding"):
            return ExcCodes.ILLEGAL_FUNCTION
        if not registers.defined(table, address, len(values)):
            return ExcCodes.ILLEGAL_ADDRESS
        if not registers.read_only[table].isdisjoint(range(address, address + len(values))):
            return ExcCodes.ILLEGAL_ADDRESS
        registers.put(table, address, values)
        if registers.missing:
            registers.missing.difference_update(zip(repeat(table), range(address, address + len(values))))
        return None


class ReadIdentification(ReadDeviceInformationRequest):
    """Function 43 / MEI 14 answered by the unit asked, from its device's identity elements: exception 1
    (ILLEGAL FUNCTION) from a device without any, exception 11 or silence where no device is served
    (as for reads). Read codes 1-4 (basic, regular, extended, one object) are served by pymodbus's
    own object selection."""

    async def datastore_update(self, context: ModbusServerContext, device_id: int) -> ModbusPDU:
        if not isinstance(context, SimContext):
            return await super().datastore_update(context, device_id)
        registers = context.at(device_id)
        if registers is None:
            return ExceptionResponse(self.function_code, ExcCodes.GATEWAY_NO_RESPONSE)
        if registers.identity is None:
            return ExceptionResponse(self.function_code, ExcCodes.ILLEGAL_FUNCTION)
        if not DeviceInformation.BASIC <= self.read_code <= DeviceInformation.SPECIFIC:
            return ExceptionResponse(self.function_code, ExcCodes.ILLEGAL_VALUE)
        control = SimpleNamespace(Identity=registers.identity)
        select: Callable[..., dict[int, bytes]] = DeviceInformationFactory.get  # typed here: pymodbus leaves it untyped
        information = select(control, self.read_code, self.object_id)
        if self.read_code == DeviceInformation.SPECIFIC and not information.get(self.object_id):
            return ExceptionResponse(self.function_code, ExcCodes.ILLEGAL_ADDRESS)
        return ReadDeviceInformationResponse(
            read_code=self.read_code, information=information, dev_id=device_id, transaction_id=self.transaction_id
        )


class Refused(ModbusPDU):
    """A request the sim does not serve, answered with an exception by the unit asked: 1 (ILLEGAL FUNCTION)
    for a function code it does not serve (SERVED_FUNCTIONS), one with the exception bit set (0x81), or a
    sub-function it does not know (function 8 with an unknown diagnostic); 3 (ILLEGAL DATA VALUE) for a
    request too short for its function. pymodbus would answer these with a logged traceback and
    exception 4, with function code 0x80, or not at all."""

    def __init__(self, function_code: int, code: ExcCodes) -> None:
        super().__init__()
        self.function_code, self.code = function_code, code

    async def datastore_update(self, context: ModbusServerContext, device_id: int) -> ModbusPDU:
        if isinstance(context, SimContext) and context.at(device_id) is None:  # at() raises when silent
            return ExceptionResponse(self.function_code, ExcCodes.GATEWAY_NO_RESPONSE)
        return ExceptionResponse(self.function_code, self.code)


class SimDecoder(DecodePDU):
    """The server's request decoder: pymodbus's, with function 43 / MEI 14 as ReadIdentification, and every
    request it cannot serve turned into a `Refused` one instead of an error in its request handler."""

    def __init__(self) -> None:
        super().__init__(is_server=True)
        table = {code: dict(subs) for code, subs in DecodePDU.pdu_sub_table.items()}  # this decoder's own
        table.setdefault(ReadIdentification.function_code, {})[ReadIdentification.sub_function_code] = (
            ReadIdentification,
            ReadDeviceInformationResponse,
        )
        self.pdu_sub_table = table

    def lookupPduClass(self, data: bytes) -> type[ModbusPDU] | None:  # noqa: N802  (pymodbus's name)
        """On RTU framing, the class that sizes a request's frame: a known function's own where the
        sub-function is unknown, so that the request is answered rather than skipped."""
        found = super().lookupPduClass(data)
        if found is None and len(data) > 1 and data[1] in self.pdu_table:
            return self.pdu_table[data[1]][0]
        return found

    def decode(self, frame: bytes) -> ModbusPDU | None:
        if not frame:
            return None
        code = frame[0]
        if code not in SERVED_FUNCTIONS:  # the exception bit set (0x81) too
            return Refused(code, ExcCodes.ILLEGAL_FUNCTION)
        pdu = self._request(code, frame)
        if pdu is None:
            return Refused(code, ExcCodes.ILLEGAL_VALUE)
        subs = self.pdu_sub_table.get(code)
        if subs is not None and pdu.sub_function_code >= 0 and pdu.sub_function_code not in subs:
            return Refused(code, ExcCodes.ILLEGAL_FUNCTION)
        return pdu

    def _request(self, code: int, frame: bytes) -> ModbusPDU | None:
        """DecodePDU.decode of a request of a function served (never an exception reply), without its debug
        line, whose text it would make for every request even when nothing is logged at that level."""
        try:
            found = self.pdu_table.get(code)
            if found is None:
                raise ModbusException(f"Unknown response {code}")
            pdu = found[0]()
            pdu.decode(frame[1:])
            if pdu.sub_function_code >= 0:
                sub = self.pdu_sub_table.get(pdu.function_code, {}).get(pdu.sub_function_code)
                if sub is not None:
                    pdu = sub[0]()
                    pdu.decode(frame[1:])
            return pdu
        except (ModbusException, ValueError, IndexError, struct.error) as exc:
            warn: Callable[..., None] = Log.warning  # typed here: pymodbus leaves it untyped
            warn("Unable to decode frame {}", exc)
        return None


_REPLY_LAYOUTS: dict[int, struct.Struct] = {}  # registers in a reply -> its layout (byte count, registers)


def _registers_at_once(registers: Sequence[int]) -> bytes:
    """A reply of registers as pymodbus encodes it (the byte count, then each register), in one pack."""
    count = len(registers)
    layout = _REPLY_LAYOUTS.get(count)
    if layout is None:
        layout = _REPLY_LAYOUTS[count] = struct.Struct(f">B{count}H")
    return layout.pack(2 * count, *registers)


class HoldingReply(ReadHoldingRegistersResponse):
    def encode(self) -> bytes:
        return _registers_at_once(self.registers)


class InputReply(ReadInputRegistersResponse):
    def encode(self) -> bytes:
        return _registers_at_once(self.registers)


class ReadWriteReply(ReadWriteMultipleRegistersResponse):
    def encode(self) -> bytes:
        return _registers_at_once(self.registers)


# pymodbus's replies of registers -> the same, packed at once (pymodbus packs and appends the registers one
# at a time: a third of the work of a read of 125 registers)
AT_ONCE: dict[type[ModbusPDU], type[ModbusPDU]] = {
    ReadHoldingRegistersResponse: HoldingReply,
    ReadInputRegistersResponse: InputReply,
    ReadWriteMultipleRegistersResponse: ReadWriteReply,
}


def most_clients() -> int:
    """The connections one server holds at once: CLIENTS_MOST, or fewer where the open-file limit is low
    (half of what FILES_KEPT leaves: asyncio accepts bursts of ACCEPT_BURST connections before it closes any)."""
    try:
        import resource
    except ImportError:  # not a POSIX system
        return CLIENTS_MOST
    soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
    if soft == resource.RLIM_INFINITY:
        return CLIENTS_MOST
    return max(1, min(CLIENTS_MOST, (soft - FILES_KEPT) // 2))


def peers_gone(handlers: list[ClientHandler]) -> list[ClientHandler]:
    """Those of `handlers` whose client has closed or reset its connection, though the event loop has not read
    that yet (asyncio accepts a burst of connections before it reads from any): one poll of their sockets,
    which reads nothing. An empty list where the system has no poll()."""
    poll = getattr(select, "poll", None)
    if poll is None:
        return []
    hangup = getattr(select, "POLLRDHUP", 0)  # Linux: the peer closed its side
    watch, by_fd = poll(), {}
    for handler in handlers:
        sock = handler.transport.get_extra_info("socket") if handler.transport is not None else None
        fd = sock.fileno() if sock is not None else -1
        if fd >= 0:  # -1: its socket closed already
            by_fd[fd] = handler
            watch.register(fd, select.POLLIN | hangup)
    gone = select.POLLHUP | select.POLLERR | hangup
    return [by_fd[fd] for fd, events in watch.poll(0) if events & gone]


class Crowd:
    """The connections of one server: at most `most`, and what is said when more arrive (connections closed
    for newer ones, connections the system refused to accept), one line at most every NOTICE_EVERY seconds."""

    def __init__(self, most: int, stream: TextIO | None = None) -> None:
        self.most, self.stream = most, stream
        self.closed, self.refused, self.why = 0, 0, ""
        self.said = -NOTICE_EVERY

    def admit(self, new: ClientHandler) -> None:
        """Make room for `new`: close the connection idle the longest (one that never asked first)."""
        listener = new.listener
        others = [c for c in getattr(listener, "active_connections", {}).values() if c is not new and c.transport]
        if len(others) < self.most:
            return
        gone = peers_gone(others)
        if gone:  # clients that left already, their leaving not yet read: closed, and nothing to say
            for handler in gone:
                handler.close()
            return
        oldest = min(others, key=lambda c: (getattr(c, "asked", True), getattr(c, "last", 0.0)))
        oldest.close()
        self.closed += 1
        self.tell()

    def accept_failed(self, exc: OSError) -> None:
        self.refused += 1
        self.why = exc.strerror or str(exc)
        self.tell()

    def tell(self, now: bool = False) -> None:
        """Say what happened since the last line, if anything did and (unless `now`) NOTICE_EVERY has passed."""
        if not (self.closed or self.refused) or (not now and time.monotonic() - self.said < NOTICE_EVERY):
            return
        parts = []
        if self.closed:
            parts.append(
                f"{self.closed} connection{'s' * (self.closed != 1)} closed for newer ones "
                f"({self.most} at once at most: the one idle the longest goes)"
            )
        if self.refused:
            parts.append(f"{self.refused} connection{'s' * (self.refused != 1)} not accepted ({self.why})")
        stream = self.stream or sys.stderr
        stream.write(f"mdl sim: {'; '.join(parts)}\n")
        stream.flush()
        self.closed, self.refused, self.said = 0, 0, time.monotonic()

    def handle_loop_error(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        """The event loop's exception handler: an accept the system refused (out of open files) is counted,
        not logged with its traceback; anything else as asyncio says it."""
        exc = context.get("exception")
        if context.get("message") == "socket.accept() out of system resource" and isinstance(exc, OSError):
            self.accept_failed(exc)
            return
        loop.default_exception_handler(context)


class ClientHandler(ServerRequestHandler):
    """pymodbus's handler of one client connection, which names the client (CLIENT) while it decodes and
    answers its requests, so that what pymodbus logs meanwhile is counted against that client; and takes
    its place among the server's connections (`Crowd`), noting when it last asked."""

    name = ""
    crowd: Crowd | None = None
    asked = False  # whether it ever sent a request
    last = 0.0  # when it connected or last sent something (time.monotonic)

    @classmethod
    def serving(cls, server: ModbusBaseServer, crowd: Crowd | None = None) -> ClientHandler:
        make: Callable[..., ClientHandler] = cls  # typed here: pymodbus leaves the constructor untyped
        handler = make(server, server.trace_packet, server.trace_pdu, server.trace_connect)
        handler.crowd = crowd
        return handler

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        peer = transport.get_extra_info("peername")
        if isinstance(peer, tuple) and len(peer) >= 2:
            self.name = f"{peer[0]}:{peer[1]}"
        self.last = time.monotonic()
        super().connection_made(transport)
        if self.crowd is not None:
            self.crowd.admit(self)

    def callback_data(self, data: bytes, addr: tuple[Any, ...] | None = None) -> int:
        self.asked, self.last = True, time.monotonic()
        token = CLIENT.set(self.name)  # call_soon copies it into the task that answers the request
        try:
            handle: Callable[[bytes, tuple[Any, ...] | None], int] = super().callback_data
            return handle(data, addr)
        finally:
            CLIENT.reset(token)

    def server_send(self, pdu: ModbusPDU | None, addr: tuple[Any, ...] | None) -> None:
        at_once = AT_ONCE.get(type(pdu)) if pdu is not None else None
        if at_once is not None:
            pdu.__class__ = at_once  # the same reply, encoded faster
        send: Callable[[ModbusPDU | None, tuple[Any, ...] | None], None] = super().server_send
        send(pdu, addr)


class LogLimiter(logging.Handler):
    """What pymodbus logs while the sim serves (a request it cannot decode, a unit not served), on stderr as
    `mdl sim: CLIENT: MESSAGE`: the first line of each message only (never a traceback), at most
    LOG_PER_CLIENT lines per client and LOG_TOTAL in all per LOG_WINDOW seconds. The rest are counted and
    said in one line, `mdl sim: N more messages suppressed (from K clients)`, when the window ends (`roll`).
    What says nothing to the user (UNSAID: pymodbus's "Cancel send" when a client left before its reply) is
    not said at all."""

    def __init__(self, where: str, stream: TextIO | None = None) -> None:
        super().__init__(logging.WARNING)
        self.where, self.stream = where, stream  # where: the client's name on a serial line
        self.started = time.monotonic()
        self.shown: Counter[str] = Counter()
        self.suppressed: Counter[str] = Counter()

    def emit(self, record: logging.LogRecord) -> None:
        if str(record.msg).startswith(UNSAID):
            return
        self.roll_if_due()
        client = CLIENT.get() or self.where
        if self.shown[client] >= LOG_PER_CLIENT or self.shown.total() >= LOG_TOTAL:
            self.suppressed[client] += 1
            return
        self.shown[client] += 1
        try:
            text = record.getMessage()
        except (TypeError, ValueError):  # arguments that do not fit the message
            text = str(record.msg)
        self._write(f"{one_line(client)}: {one_line(text.split(chr(10), 1)[0].split('; Traceback', 1)[0].strip())}")

    def roll_if_due(self) -> None:
        if time.monotonic() - self.started >= LOG_WINDOW:
            self.roll()

    def roll(self) -> None:
        """End the window: say how many messages were suppressed in it, if any."""
        total, clients = self.suppressed.total(), len(self.suppressed)
        if total:
            self._write(
                f"{total} more message{'s' * (total != 1)} suppressed (from {clients} client{'s' * (clients != 1)})"
            )
        self.started = time.monotonic()
        self.shown.clear()
        self.suppressed.clear()

    def _write(self, line: str) -> None:
        stream = self.stream or sys.stderr
        stream.write(f"mdl sim: {line}\n")
        stream.flush()


def quiet_pymodbus(connection: Connection) -> LogLimiter:
    """Send what pymodbus logs through a LogLimiter (instead of Python's last-resort handler, which
    prints every message and every traceback pymodbus includes)."""
    limiter = LogLimiter(connection.serial or "client")
    logger = logging.getLogger("pymodbus")
    for handler in list(logger.handlers):
        logger.removeHandler(handler)
    logger.addHandler(limiter)
    logger.setLevel(logging.WARNING)
    logger.propagate = False
    return limiter


async def _roll_every_window(limiter: LogLimiter, crowd: Crowd | None = None) -> None:
    """Say what was suppressed once a window ends, also when nothing more is logged (and what the crowd of
    connections did, once NOTICE_EVERY has passed)."""
    while True:
        await asyncio.sleep(LOG_WINDOW / 4)
        limiter.roll_if_due()
        if crowd is not None:
            crowd.tell()


async def _listen(listen: Callable[..., Awaitable[Any]], connection: Connection) -> Any:
    """pymodbus's create_server, with a port another program holds said as such (pymodbus would log
    "Failed to start server" as a client's message and give up with "Could not start listen")."""
    try:
        return await listen()
    except OSError as exc:
        if exc.errno != errno.EADDRINUSE:
            raise
        where = connection.serving_at(connection.port)
        raise error(
            f"cannot serve on {where}: address already in use (another mdl sim, or another server): "
            "choose another --port, or --port 0 for a free one"
        ) from None


async def serve(units: dict[int, Registers], connection: Connection, out: TextIO = sys.stdout) -> None:
    """Serve every device at its unit on one connection; once listening, one ready line per device."""
    if connection.serial is not None:
        reason = connection.open_error()
        if reason:
            raise error(f"cannot serve on {connection.serial}: {reason}")
    for registers in units.values():
        for warning in registers.identity_warnings:
            print(f"mdl sim: warning: {one_line(registers.device.name)}: {warning}", file=sys.stderr)
    server = connection.server(SimContext(units, silent=connection.rtu))
    server.decoder = SimDecoder()
    limiter = quiet_pymodbus(connection)
    crowd = None if connection.serial is not None else Crowd(most_clients())
    if crowd is not None:  # pymodbus's listener is asyncio's create_server, made when it starts serving
        listen: Callable[..., Any] = server.call_create  # a partial of create_server: it takes the backlog too
        server.call_create = functools.partial(_listen, functools.partial(listen, backlog=ACCEPT_BURST), connection)
    server.callback_new_connection = functools.partial(ClientHandler.serving, server, crowd)  # type: ignore[method-assign]
    refused: tuple[type[Exception], ...] = (OSError,)
    if os.name == "posix":
        import termios

        refused += (termios.error,)  # what pyserial raises for a setting the device refuses (parity on a pty)
    try:
        await server.serve_forever(background=True)
    except refused as exc:
        why = exc.args[-1] if exc.args else exc
        if connection.serial is not None and not isinstance(exc, OSError):  # termios.error: the line's settings
            why = connection.settings_refusal(why)
        raise error(f"cannot serve on {connection.serial or connection}: {why}") from None
    sockets = getattr(server.transport, "sockets", None) or []
    where = connection.serving_at(sockets[0].getsockname()[1] if sockets else connection.port)
    loop = asyncio.get_running_loop()
    if crowd is not None:
        loop.set_exception_handler(crowd.handle_loop_error)
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    out.write(
        "".join(
            f"mdl sim: serving {one_line(registers.device.name)} on {where} unit {unit}\n"
            for unit, registers in units.items()
        )
    )
    out.flush()
    rolling = asyncio.create_task(_roll_every_window(limiter, crowd))
    try:
        await stop.wait()
    finally:
        rolling.cancel()
        shutdown: Callable[[], Awaitable[None]] = server.shutdown  # typed here: pymodbus leaves it unannotated
        await shutdown()
        limiter.roll()
        if crowd is not None:
            crowd.tell(now=True)


def run(units: dict[int, Registers], connection: Connection) -> None:
    where = connection.serving_at(connection.port)
    try:
        asyncio.run(serve(units, connection))
    except RuntimeError as exc:
        raise error(f"cannot serve on {where}: {exc}") from None
    except OSError as exc:
        raise error(f"cannot serve on {where}: {exc.strerror or exc}") from None
