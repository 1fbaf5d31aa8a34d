"""Values of functions from raw registers, expressions and their dependencies included: the value
IR of a resolved device run in Python, compiled once per device (`Evaluator`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable

from mdl.lang.expr.fields import python_function
from mdl.model import Device, Scalar, Value
from mdl.resolve import ResolvedDevice, resolve
from mdl.values.codec import CodecError, Compiled, compile_codec, parse_value

RawLookup = Callable[[str, int], int | None]  # (table, address) -> register or bit value, None: none


class Evaluator:
    """A resolved device's decoders and encoders, compiled once: `values` decodes what a read got,
    `encode` turns a value into registers, `parse` reads a value a user typed."""

    def __init__(self, resolved: ResolvedDevice):
        self.resolved = resolved
        self._compiled: dict[str, Compiled] = {f.name: compile_codec(f.name, f.codec) for f in resolved.functions}
        self._expressions = {f.name: python_function(f.fn.compiled) for f in resolved.functions
                             if f.fn.compiled is not None}
        self._orders: dict[tuple[str, ...], list[str]] = {}

    def order(self, names: Iterable[str]) -> list[str]:
        """The named functions and what their expressions need, each after what it needs."""
        key = tuple(names)
        if key not in self._orders:
            self._orders[key] = [f.name for f in self.resolved.closure(list(key))]
        return self._orders[key]

    def values(self, names: Iterable[str], raw: RawLookup) -> dict[str, Value]:
        """name -> value for the named functions (and their dependencies); `raw(table, address)`
        gives a register or bit value, or None where there is none."""
        values: dict[str, Value] = {}
        by_name = self.resolved.by_name
        for name in self.order(names):
            f = by_name[name]
            table = f.layout.table
            regs = [raw(table, a) for a in f.layout.addresses]
            expression = self._expressions.get(name)
            if expression is not None:
                values[name] = expression(regs, *[values[d] for d in f.deps])
            elif None in regs:
                values[name] = None
            else:
                decode = self._compiled[name].decode
                values[name] = decode(regs) if decode is not None else self._decode_unreadable(name, regs)  # type: ignore[arg-type]
        return values

    def _decode_unreadable(self, name: str, regs: list[int]) -> Value:
        from mdl.values.codec import decode

        return decode(self.resolved.by_name[name].fn, regs)

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
