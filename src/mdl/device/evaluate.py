"""Values of functions from raw registers, expressions and their dependencies included: the value
IR of a resolved device run in Python, compiled once per device (`Evaluator`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable

from mdl.lang.expr.fields import python_function
from mdl.model import Device, Scalar, Value
from mdl.resolve import ResolvedDevice, resolve
from mdl.values.build import decode_steps
from mdl.values.codec import CodecError, Compiled, Decoder, compile_codec, compile_decoder, parse_value

RawLookup = Callable[[str, int], int | None]  # (table, address) -> register or bit value, None: none
# a function's decoding: name, table, addresses, decoder (None for an expression), expression, its dependencies
_Step = tuple[str, str, tuple[int, ...], Decoder | None, Callable[..., Value] | None, tuple[str, ...]]


class Evaluator:
    """A resolved device's decoders and encoders, compiled once: `values` decodes what a read got,
    `encode` turns a value into registers, `parse` reads a value a user typed."""

    def __init__(self, resolved: ResolvedDevice):
        self.resolved = resolved
        self._compiled: dict[str, Compiled] = {f.name: compile_codec(f.name, f.codec) for f in resolved.functions}
        self._expressions = {f.name: python_function(f.fn.compiled) for f in resolved.functions
                             if f.fn.compiled is not None}
        self._orders: dict[tuple[str, ...], list[str]] = {}
        self._steps: dict[tuple[str, ...], list[_Step]] = {}

    def order(self, names: Iterable[str]) -> list[str]:
        """The named functions and what their expressions need, each after what it needs."""
        key = tuple(names)
        if key not in self._orders:
            self._orders[key] = [f.name for f in self.resolved.closure(list(key))]
        return self._orders[key]

    def values(self, names: Iterable[str], raw: RawLookup) -> dict[str, Value]:
        """name -> value for the named functions (and their dependencies); `raw(table, address)`
        gives a register or bit value, or None where there is none."""
        tables: dict[str, dict[int, int]] = {}
        for name in self.order(names):
            f = self.resolved.by_name[name]
            table = tables.setdefault(f.layout.table, {})
            for a in f.layout.addresses:
                value = raw(f.layout.table, a)
                if value is not None:
                    table[a] = value
        return self.values_from_tables(names, tables)

    def values_from_tables(self, names: Iterable[str], tables: dict[str, dict[int, int]]) -> dict[str, Value]:
        """As `values`, from what a read got: table -> address -> register or bit value."""
        key = tuple(names)
        steps = self._steps.get(key)
        if steps is None:
            steps = self._steps[key] = [self._step(name) for name in self.order(key)]
        values: dict[str, Value] = {}
        empty: dict[int, int] = {}
        for name, table, addresses, decode, expression, deps in steps:
            get = tables.get(table, empty).get
            regs = [get(a) for a in addresses]
            if expression is not None:
                values[name] = expression(regs, *[values[d] for d in deps])
            elif None in regs:
                values[name] = None
            else:
                values[name] = decode(regs)  # type: ignore[arg-type, misc]  # no None left; not an expression
        return values

    def _step(self, name: str) -> _Step:
        """What decoding one function needs, looked up once per list of names."""
        f = self.resolved.by_name[name]
        decode = self._compiled[name].decode
        if decode is None and name not in self._expressions:  # a write-only function, read by the simulator
            decode = compile_decoder(name, decode_steps(f.fn, f.layout))
        return name, f.layout.table, f.layout.addresses, decode, self._expressions.get(name), f.deps

    def encode(self, name: str, value: Scalar) -> list[int]:
        encoder = self._compiled[name].encode
        if encoder is None:
            raise CodecError(f"function '{name}' cannot be written")
        return encoder(value)

    def parse(self, name: str, text: str) -> Scalar:
        return parse_value(self.resolved.by_name[name].fn, text)


def evaluate(device: ResolvedDevice | Device, names: Iterable[str], raw: RawLookup) -> dict[str, Value]:
    """name -> value for the named functions, with a one-off Evaluator."""
    return Evaluator(device if isinstance(device, ResolvedDevice) else resolve(device)).values(names, raw)
