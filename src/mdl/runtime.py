"""`mdl read` / `mdl write`: the model, the codec and the read plan over a pymodbus client."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from pymodbus.client import ModbusTcpClient
from pymodbus.exceptions import ModbusException
from pymodbus.pdu import ModbusPDU

from mdl import codec
from mdl.diagnostics import DeviceError, error
from mdl.evaluate import evaluate
from mdl.expr.fields import evaluation_order
from mdl.layout import layout
from mdl.model import Device, Function, Scalar, Value
from mdl.plan import Request, plan_reads, split_request

EXCEPTION_NAMES = {
    1: "ILLEGAL FUNCTION", 2: "ILLEGAL DATA ADDRESS", 3: "ILLEGAL DATA VALUE",
    4: "SERVER DEVICE FAILURE", 5: "ACKNOWLEDGE", 6: "SERVER DEVICE BUSY",
    8: "MEMORY PARITY ERROR", 10: "GATEWAY PATH UNAVAILABLE", 11: "GATEWAY TARGET DEVICE FAILED TO RESPOND",
}


class ModbusExceptionError(DeviceError):
    def __init__(self, what: str, code: int):
        super().__init__(f"{what}: Modbus exception {code} ({EXCEPTION_NAMES.get(code, 'unknown')})", code)


class Session:
    """A connection to one unit of a Modbus TCP device."""

    def __init__(self, device: Device, host: str, port: int = 502, unit: int = 1, timeout: float = 3.0):
        self.device = device
        self.host, self.port, self.unit = host, port, unit
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
        self.client = ModbusTcpClient(host, port=port, timeout=timeout, retries=1)
        self.refused: set[Request] = set()

    def __enter__(self) -> Session:
        connect: Callable[[], bool] = self.client.connect  # typed here: pymodbus leaves it unannotated
        if not connect():
            raise DeviceError(f"cannot connect to {self.host}:{self.port}: no Modbus TCP device answers")
        return self

    def __exit__(self, *exc: object) -> None:
        close: Callable[[], None] = self.client.close  # typed here: pymodbus leaves it unannotated
        close()

    def _call(self, what: str, method: Callable[..., ModbusPDU], *args: Any, **kw: Any) -> ModbusPDU:
        try:
            result = method(*args, device_id=self.unit, **kw)
        except ModbusException as exc:
            raise DeviceError(f"{what}: {exc} ({self.host}:{self.port})") from None
        if result.isError():
            raise ModbusExceptionError(what, getattr(result, "exception_code", 0))
        return result

    def read_request(self, req: Request) -> list[int]:
        what = f"reading {req.count} {req.table} from {req.start}"
        method = {"holding": self.client.read_holding_registers, "input": self.client.read_input_registers,
                  "coil": self.client.read_coils, "discrete": self.client.read_discrete_inputs}[req.table]
        result = self._call(what, method, req.start, count=req.count)
        values = [int(b) for b in result.bits] if req.table in ("coil", "discrete") else list(result.registers)
        if len(values) < req.count:
            raise DeviceError(f"{what}: short reply ({len(values)} values)")
        return values[: req.count]

    def read(self, functions: list[Function]) -> dict[str, Value]:
        """Values of the functions (reading what their expressions depend on too)."""
        needed = evaluation_order(self.device, [fn.name for fn in functions])
        raw: dict[tuple[str, int], int] = {}
        pending = list(plan_reads(self.device, needed))
        missing: list[Request] = []
        while pending:
            req = pending.pop(0)
            try:
                values = self.read_request(req)
            except ModbusExceptionError as exc:
                if exc.code != 2:
                    raise
                smaller = split_request(self.device, req)
                if smaller != [req]:
                    self.refused.add(req)
                    pending[:0] = smaller
                else:
                    missing.append(req)  # refused even alone: these registers have no value
                continue
            for i, v in enumerate(values):
                raw[(req.table, req.start + i)] = v
        for fn in needed:  # only expressions may read a register the device does not answer
            lay = layout(fn)
            if fn.compiled is None and any((lay.table, a) not in raw for a in lay.addresses):
                req = next(r for r in missing
                           if r.table == lay.table and any(r.start <= a < r.end for a in lay.addresses))
                raise ModbusExceptionError(f"reading {req.count} {req.table} from {req.start}", 2)
        try:
            computed = evaluate(self.device, [fn.name for fn in functions], lambda t, a: raw.get((t, a)))
        except (ValueError, ZeroDivisionError, ArithmeticError) as exc:
            raise error(f"cannot compute a value: {exc}") from None
        return {fn.name: computed[fn.name] for fn in functions}

    def write(self, fn: Function, value: Scalar) -> None:
        regs = codec.encode(fn, value)
        lay = layout(fn)
        runs: list[tuple[int, list[int]]] = []
        for a, v in zip(lay.addresses, regs, strict=True):
            if runs and runs[-1][0] + len(runs[-1][1]) == a:
                runs[-1][1].append(v)
            else:
                runs.append((a, [v]))
        for start, values in runs:
            what = f"writing {fn.name} at {lay.table} {start}"
            if lay.table == "coil":
                self._call(what, self.client.write_coil, start, bool(values[0]))
            elif len(values) == 1:
                self._call(what, self.client.write_register, start, values[0])
            else:
                self._call(what, self.client.write_registers, start, values)
