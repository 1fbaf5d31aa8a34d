"""Values of functions from raw registers, expressions and their dependencies included."""

from __future__ import annotations

from mdl import codec
from mdl.expr.fields import evaluation_order, python_function
from mdl.layout import layout
from mdl.model import Device


def evaluate(device: Device, names, raw) -> dict:
    """name -> value for the named functions (and their dependencies); `raw(table, address)`
    gives a register or bit value, or None where there is none."""
    values: dict = {}
    for fn in evaluation_order(device, names):
        lay = layout(fn)
        regs = [raw(lay.table, a) for a in lay.addresses]
        if fn.compiled is not None:
            values[fn.name] = python_function(fn)(regs, *[values[d] for d in fn.compiled.deps])
        elif any(r is None for r in regs):
            values[fn.name] = None
        else:
            values[fn.name] = codec.decode(fn, regs)
    return values
