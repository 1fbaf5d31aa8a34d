"""`mdl read` / `mdl write`: a session with one unit of a device, over a pymodbus client: the read
plan of a resolved device, its decoders, and writes.

Every reply is checked before it is trusted (mdl.device.frames); anything wrong, and any broken
connection, is a DeviceError (exit 3) naming the connection, the unit and what was wrong.
"""

from __future__ import annotations

import errno
import socket
from collections.abc import Callable, Generator
from typing import Any

from pymodbus.exceptions import ConnectionException, ModbusException, ModbusIOException
from pymodbus.pdu import ModbusPDU

from mdl.device.connection import Connection
from mdl.device.evaluate import BufferDecoder, Evaluator
from mdl.device.frames import Wire
from mdl.diagnostics import DeviceError, error
from mdl.ir import codec
from mdl.ir.steps import Merge, find_step
from mdl.model import Function, Scalar, Value
from mdl.model.layout import Layout, address_runs
from mdl.plan import Request, defined_addresses, plan_reads, split_request
from mdl.resolver import ResolvedDevice

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


ReadSteps = Generator[Request, list[int], dict[str, Value]]


def drive(steps: ReadSteps, fetch: Callable[[Request], list[int]]) -> dict[str, Value]:
    """Run a read's steps (Session.read_steps) with `fetch` answering each request; a Modbus exception
    is thrown back into the steps, which decide what it means. mdl.device.fleet.run drives the same steps
    with an asyncio client."""
    try:
        req = next(steps)
        while True:
            try:
                regs = fetch(req)
            except ModbusExceptionError as exc:
                req = steps.throw(exc)
            else:
                req = steps.send(regs)
    except StopIteration as done:
        values: dict[str, Value] = done.value
        return values


class _ReadPlan:
    """What a read of some functions needs, worked out once: the requests, each with where its
    registers go in the read's buffer and its smaller requests for exception 2 (None: split when
    refused), the buffer's size, the slots of every function without an expression (these must
    have all their registers) and the decoder of the buffer."""

    __slots__ = ("groups", "size", "plain", "layouts", "decode")

    def __init__(
        self,
        groups: list[tuple[Request, int, list[Request] | None]],
        size: int,
        plain: list[tuple[str, Layout, tuple[int, ...]]],
        layouts: dict[str, Layout],
        decode: BufferDecoder,
    ) -> None:
        self.groups, self.size, self.plain, self.layouts, self.decode = groups, size, plain, layouts, decode


class Session:
    """A connection to one unit of a device: Modbus TCP, RTU on a serial line, or RTU over TCP."""

    def __init__(self, resolved: ResolvedDevice, connection: Connection, unit: int = 1):
        self.resolved, self.device = resolved, resolved.device  # resolved once, by the caller
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
        self.refused: set[Request] = set()  # groups the device refused (exception 2): read split from then on
        self._evaluator: Evaluator | None = None
        self._plans: dict[tuple[str, ...], _ReadPlan] = {}  # the names read -> how to read them

    @property
    def evaluator(self) -> Evaluator:
        """The device's decoders, compiled once per session."""
        if self._evaluator is None:
            self._evaluator = Evaluator(self.resolved)
        return self._evaluator

    def _plan(self, names: tuple[str, ...]) -> _ReadPlan:
        """How to read `names`: computed once per list of names, then reused by every read (a poll)."""
        plan = self._plans.get(names)
        if plan is None:
            resolved = self.resolved
            order = self.evaluator.order(names)
            layouts = {f.name: f.layout for f in resolved.functions}
            groups: list[tuple[Request, int, list[Request] | None]]
            if set(order) == {f.name for f in resolved.readable}:  # all: the plan resolve made
                groups = [(g.request, g.offset, list(g.smaller)) for g in resolved.plan]
                size = resolved.buffer_size
                table_slots = resolved.table_slots
            else:
                by_name = resolved.by_name
                requests = plan_reads(
                    self.device,
                    [by_name[n].fn for n in order],
                    layouts=layouts,
                    defined=defined_addresses(self.device, layouts),
                )
                groups, size, table_slots = [], 0, {}
                for req in requests:  # split only if the device refuses one
                    groups.append((req, size, None))
                    table_slots.setdefault(req.table, {}).update(
                        zip(range(req.start, req.end), range(size, size + req.count), strict=True)
                    )
                    size += req.count
            slots = {
                n: tuple(map(table_slots.get(layouts[n].table, {}).__getitem__, layouts[n].addresses)) for n in order
            }
            plain = [(n, layouts[n], slots[n]) for n in order if resolved.by_name[n].compiled is None]
            plan = self._plans[names] = _ReadPlan(groups, size, plain, layouts, self.evaluator.decoder(names, slots))
        return plan

    def __enter__(self) -> Session:
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

    def read(self, functions: list[Function]) -> dict[str, Value]:
        """Values of the functions (reading what their expressions depend on too)."""
        return drive(self.read_steps(functions), self.read_request)

    def read_steps(self, functions: list[Function]) -> ReadSteps:
        """`read` as steps: yields each request and is sent its registers (`drive`)."""
        plan = self._plan(tuple(fn.name for fn in functions))
        raw: list[int | None] = [None] * plan.size
        missing: list[Request] = []
        for i, (group, offset, smaller) in enumerate(plan.groups):
            if group not in self.refused:
                try:
                    raw[offset : offset + group.count] = yield group
                except ModbusExceptionError as exc:
                    if exc.code != 2:
                        raise
                else:
                    continue
                if smaller is None:
                    smaller = split_request(self.device, group, plan.layouts)
                    plan.groups[i] = (group, offset, smaller)  # the next read goes straight to them
                if smaller in ([], [group]):
                    missing.append(group)  # refused even alone: these registers have no value
                    continue
                self.refused.add(group)
            for req in smaller or ():
                try:
                    at = offset + req.start - group.start
                    raw[at : at + req.count] = yield req
                except ModbusExceptionError as exc:
                    if exc.code != 2:
                        raise
                    missing.append(req)
        if missing:  # only expressions may read a register the device does not answer
            for _, lay, slots in plan.plain:
                if any(raw[s] is None for s in slots):
                    req = next(
                        r for r in missing if r.table == lay.table and any(r.start <= a < r.end for a in lay.addresses)
                    )
                    raise ModbusExceptionError(self.where(f"reading {req.count} {req.table} from {req.start}"), 2)
        try:
            return plan.decode(raw)
        except (ValueError, ZeroDivisionError, ArithmeticError) as exc:
            raise error(f"cannot compute a value: {exc}") from None

    def write(self, fn: Function, value: Scalar) -> None:
        """Encode `value` and write it: one request per run of consecutive addresses. One register is
        written with function 6 and one coil with function 5, unless the function says `write_multiple`
        (devices that refuse 5 and 6): then always 16 and 15; more registers always take function 16.
        A function scaled by another reads that one's value first (never a stale one); a function with
        bits reads its registers and writes them back with only its bits changed, or, with
        write_function_code 22, sends Mask Write Register for each register holding its bits."""
        f = self.resolved.by_name[fn.name]
        lay = f.layout
        factor: tuple[Value, ...] = ()
        if fn.factor is not None:
            factor = (self.read([self.resolved.by_name[fn.factor].fn])[fn.factor],)
        try:
            regs = self.evaluator.encode(fn.name, value, *factor)
        except codec.CodecError as exc:
            said = f" ('{fn.factor}' reads {'null' if factor[0] is None else factor[0]})" if factor else ""
            raise error(f"{fn.name}={value}: {exc}{said}") from None
        merge = find_step(f.codec.encode, Merge)
        if merge is not None and merge.mask_write:
            for address, mask, bits in zip(lay.addresses, merge.masks, regs, strict=True):
                if mask:
                    self._call(
                        f"writing {fn.name} at {lay.table} {address} (function 22)",
                        self.client.mask_write_register,
                        address=address,
                        and_mask=~mask & 0xFFFF,
                        or_mask=bits,
                    )
            return
        if merge is not None:  # read, change only these bits, write back
            current: list[int] = []
            for start, count in lay.runs:
                current += self.read_request(Request(lay.table, start, count, (fn.name,)))
            regs = codec.merge(current, regs, merge.masks)
        at = 0
        for start, count in lay.runs:
            values, at = regs[at : at + count], at + count
            what = f"writing {fn.name} at {lay.table} {start}"
            if lay.table == "coil" and fn.write_multiple:
                self._call(what, self.client.write_coils, start, [bool(v) for v in values])
            elif lay.table == "coil":
                self._call(what, self.client.write_coil, start, bool(values[0]))
            elif count == 1 and not fn.write_multiple:
                self._call(what, self.client.write_register, start, values[0])
            else:
                self._call(what, self.client.write_registers, start, values)
