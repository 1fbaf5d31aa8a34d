"""`mdl read` / `mdl write`: a session with one unit of a device, over a pymodbus client: the read
plan of a resolved device, its decoders, and writes.

Its link (mdl.device.link) checks every reply before it is trusted; anything wrong, and any broken
connection, is a DeviceError (exit 3) naming the connection, the unit and what was wrong.
"""

from __future__ import annotations

from collections.abc import Callable, Generator

from mdl.device.connection import Connection
from mdl.device.evaluate import BufferDecoder, Evaluator
from mdl.device.link import Link, ModbusExceptionError
from mdl.diagnostics import error
from mdl.ir import codec
from mdl.ir.steps import Merge, find_step
from mdl.model import Function, Scalar, Value
from mdl.model.layout import Layout
from mdl.plan import Request, defined_addresses, plan_reads, split_request
from mdl.resolver import ResolvedDevice

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


class Session(Link):
    """A link to one unit of a device with its description: reads by function name through the read plan,
    decoded, and encoded writes."""

    def __init__(self, resolved: ResolvedDevice, connection: Connection, unit: int = 1):
        super().__init__(connection, unit)
        self.resolved, self.device = resolved, resolved.device  # resolved once, by the caller
        self.refused: set[Request] = set()  # groups the device refused (exception 2): read split from then on
        self._evaluator: Evaluator | None = None
        self._plans: dict[tuple[str, ...], _ReadPlan] = {}  # the names read -> how to read them
        # the functions of the last read and their plan: a poll reads the same list again and again, and
        # comparing the lists (identity first, in C) costs less than naming their functions each time
        self._last: tuple[list[Function], _ReadPlan] | None = None

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

    def read(self, functions: list[Function]) -> dict[str, Value]:
        """Values of the functions (reading what their expressions depend on too)."""
        return drive(self.read_steps(functions), self.read_request)

    def read_steps(self, functions: list[Function]) -> ReadSteps:
        """`read` as steps: yields each request and is sent its registers (`drive`)."""
        last = self._last
        if last is not None and last[0] == functions:
            plan = last[1]
        else:
            plan = self._plan(tuple(fn.name for fn in functions))
            self._last = (list(functions), plan)
        raw: list[int | None] = [None] * plan.size
        missing: list[Request] = []
        whole = True  # every group read whole (none refused): no slot is left None
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
            whole = False
            for req in smaller or ():
                try:
                    at = offset + req.start - group.start
                    raw[at : at + req.count] = yield req
                except ModbusExceptionError as exc:
                    if exc.code != 2:
                        raise
                    missing.append(req)
        if missing:  # only expressions may read a register the device does not answer
            unanswered = []
            for name, lay, slots in plan.plain:
                if any(raw[s] is None for s in slots):
                    req = next(
                        r for r in missing if r.table == lay.table and any(r.start <= a < r.end for a in lay.addresses)
                    )
                    unanswered.append((name, req))
            self.without_value(unanswered)
        try:
            return plan.decode(raw, whole and not missing)
        except (ValueError, ZeroDivisionError, ArithmeticError) as exc:
            raise error(f"cannot compute a value: {exc}") from None

    def without_value(self, unanswered: list[tuple[str, Request]]) -> None:
        """Functions whose registers the device refuses even alone (exception 2), each with the request
        refused: an error (exit 3) naming the first. RawSession reads on without them."""
        if unanswered:
            _, req = unanswered[0]
            raise ModbusExceptionError(self.where(f"reading {req.count} {req.table} from {req.start}"), 2)

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
