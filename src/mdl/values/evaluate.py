"""Values of functions from raw registers, expressions and their dependencies included."""

from __future__ import annotations

from collections.abc import Callable, Iterable

from mdl.lang.expr.fields import evaluation_order, python_function
from mdl.model import Device, Value
from mdl.model.layout import layout
from mdl.values import codec

RawLookup = Callable[[str, int], int | None]  # (table, address) -> register or bit value, None: none


def evaluate(device: Device, names: Iterable[str], raw: RawLookup) -> dict[str, Value]:
    """name -> value for the named functions (and their dependencies); `raw(table, address)`
    gives a register or bit value, or None where there is none."""
    values: dict[str, Value] = {}
    for fn in evaluation_order(device, names):
        lay = layout(fn)
        regs = [raw(lay.table, a) for a in lay.addresses]
        present = [r for r in regs if r is not None]
        if fn.compiled is not None:
            values[fn.name] = python_function(fn.compiled)(regs, *[values[d] for d in fn.compiled.deps])
        elif len(present) < len(regs):
            values[fn.name] = None
        else:
            values[fn.name] = codec.decode(fn, present)
    return values
