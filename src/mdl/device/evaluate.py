"""Values of functions from raw registers, expressions and their dependencies included: the value
IR of a resolved device run in Python, compiled once per device (`Evaluator`), and per list of
functions read (`BufferDecoder`)."""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterable, Mapping, Sequence

from mdl.ir.build import decode_steps
from mdl.ir.codec import CodecError, Compiled, Decoder, compile_codec, compile_decoder, parse_value
from mdl.ir.steps import DecodeStep
from mdl.model import Device, Scalar, Value
from mdl.resolver import ResolvedDevice, resolve

RawLookup = Callable[[str, int], int | None]  # (table, address) -> register or bit value, None: none
Buffer = Sequence[int | None]  # registers and bits by slot; None where the device gave none
# a function's decoding: name, its slots, decoder (None for an expression), expression, its dependencies
_Step = tuple[str, tuple[int, ...], Decoder | None, Callable[..., Value] | None, tuple[str, ...]]


class Evaluator:
    """A resolved device's decoders and encoders, compiled once: `values` decodes what a read got,
    `encode` turns a value into registers, `parse` reads a value a user typed."""

    def __init__(self, resolved: ResolvedDevice):
        self.resolved = resolved
        self._compiled: dict[str, Compiled] = {f.name: compile_codec(f.name, f.codec) for f in resolved.functions}
        self._expressions: dict[str, Callable[..., Value]] = {}
        if any(f.compiled is not None for f in resolved.functions):
            from mdl.dsl.expr.fields import python_function  # the expressions' printer, for a device that has them

            self._expressions = {f.name: python_function(f.compiled) for f in resolved.functions if f.compiled}
        self._orders: dict[tuple[str, ...], list[str]] = {}

    def order(self, names: Iterable[str]) -> list[str]:
        """The named functions and what their expressions need, each after what it needs."""
        key = tuple(names)
        if key not in self._orders:
            self._orders[key] = [f.name for f in self.resolved.closure(list(key))]
        return self._orders[key]

    def values(self, names: Iterable[str], raw: RawLookup) -> dict[str, Value]:
        """name -> value for the named functions (and their dependencies, in decode order);
        `raw(table, address)` gives a register or bit value, or None where there is none."""
        order = self.order(names)
        buffer: list[int | None] = []
        slots: dict[str, tuple[int, ...]] = {}
        for name in order:
            lay = self.resolved.by_name[name].layout
            slots[name] = tuple(range(len(buffer), len(buffer) + len(lay.addresses)))
            buffer += [raw(lay.table, a) for a in lay.addresses]
        return self._run([self._step(name, slots[name]) for name in order], buffer)

    def decoder(self, names: Sequence[str], slots: Mapping[str, tuple[int, ...]]) -> BufferDecoder:
        """What decodes `names` from a buffer where each function's registers are at `slots[name]`
        (every function of `order(names)` has its slots)."""
        return BufferDecoder(self, tuple(names), self.order(names), slots)

    def _step(self, name: str, slots: tuple[int, ...]) -> _Step:
        """What decoding one function needs."""
        f = self.resolved.by_name[name]
        decode = self._compiled[name].decode
        if decode is None and name not in self._expressions:  # a write-only function, read by the simulator
            decode = compile_decoder(name, decode_steps(f.fn, f.layout))
        return name, slots, decode, self._expressions.get(name), f.deps

    @staticmethod
    def _run(steps: list[_Step], raw: Buffer) -> dict[str, Value]:
        """Every step's value, in order, running each function's closures (mdl.ir.codec)."""
        values: dict[str, Value] = {}
        for name, slots, decode, expression, deps in steps:
            regs = [raw[s] for s in slots]
            if expression is not None:
                values[name] = expression(regs, *[values[d] for d in deps])
            elif None in regs:
                values[name] = None
            else:  # a scaled function's decoder takes its factor's value
                values[name] = decode(regs, *[values[d] for d in deps])  # type: ignore[misc]  # not an expression
        return values

    def encode(self, name: str, value: Scalar, *factor: Value) -> list[int]:
        """The registers of a value (only its bits for a function with bits: ir.Merge); a function scaled
        by another takes that one's value as `factor`."""
        encoder = self._compiled[name].encode
        if encoder is None:
            raise CodecError(f"function '{name}' cannot be written")
        return encoder(value, *factor)

    def parse(self, name: str, text: str) -> Scalar:
        return parse_value(self.resolved.by_name[name].fn, text)


class BufferDecoder:
    """Decodes a list of functions (and what their expressions need) from a poll's buffer: registers
    and bits by slot, None where the device gave none. Returns {name: value} for the names asked.

    The first decode runs each function's closures (mdl.ir.codec): a one-off `mdl read` never
    imports Jinja. From the second on (a poll), a buffer without a gap goes through one Python
    function printed for these functions by the Python target's own templates (the decoders every
    generated driver carries, one per shape of IR: mdl.targets.python.reader) and compiled once;
    a buffer with a gap (a register refused: expressions read None) still takes the closures."""

    def __init__(
        self, evaluator: Evaluator, names: tuple[str, ...], order: list[str], slots: Mapping[str, tuple[int, ...]]
    ) -> None:
        self.evaluator, self.names = evaluator, names
        self.steps = [evaluator._step(name, slots[name]) for name in order]
        self.uses = 0
        self.compiled: Callable[[Buffer], dict[str, Value]] | None = None

    def __call__(self, raw: Buffer, whole: bool = False) -> dict[str, Value]:
        """The values; `whole`: the caller knows that no slot is None (every request was answered whole)."""
        self.uses += 1
        if self.compiled is None and self.uses > 1:
            self.compiled = self._compile()
        if self.compiled is not None and (whole or None not in raw):
            return self.compiled(raw)
        values = self.evaluator._run(self.steps, raw)
        return {name: values[name] for name in self.names}

    def _compile(self) -> Callable[[Buffer], dict[str, Value]]:
        from mdl.targets.python.reader import Row, reader_source

        resolved = self.evaluator.resolved
        shapes: dict[str, int] = {}  # decode shape -> its printed decoder
        shape_steps: list[tuple[DecodeStep, ...]] = []
        namespace: dict[str, object] = {"struct": struct}
        var_of: dict[str, int] = {}
        rows = []
        for var, (name, slots, decode, expression, deps) in enumerate(self.steps):
            f = resolved.by_name[name]
            var_of[name] = var
            shape = f.decode_shape
            if shape is not None and expression is None:
                if shape not in shapes:
                    shapes[shape] = len(shape_steps)
                    shape_steps.append(f.codec.decode)  # type: ignore[arg-type]  # a shape: not None
                rows.append(Row(var, "shape", shapes[shape], slots, tuple(var_of[d] for d in deps)))
            else:  # a fragment, an expression or a write-only function: its closure
                namespace[f"_f{var}"] = expression if expression is not None else decode
                rows.append(Row(var, "call", var, slots, tuple(var_of[d] for d in deps)))
        source = reader_source(shape_steps, rows, [(name, var_of[name]) for name in self.names])
        exec(compile(source, f"<mdl decoder of {resolved.name}>", "exec"), namespace)  # noqa: S102  # our own printing
        decode_all: Callable[[Buffer], dict[str, Value]] = namespace["decode"]  # type: ignore[assignment]
        return decode_all


def evaluate(device: ResolvedDevice | Device, names: Iterable[str], raw: RawLookup) -> dict[str, Value]:
    """name -> value for the named functions, with a one-off Evaluator."""
    return Evaluator(device if isinstance(device, ResolvedDevice) else resolve(device)).values(names, raw)
