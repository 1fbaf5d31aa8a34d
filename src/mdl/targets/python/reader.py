"""The Python target's printing of the IR, for mdl's own runtime: the source of one function that
decodes a list of functions from a poll's buffer (templates/reader.py.j2), which
mdl.device.evaluate compiles in memory. The decoders are printed by the same templates/ops.j2 as
every generated driver's, so the IR has one printer as Python."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from mdl.ir import steps as ir
from mdl.targets.python.emit import environment, span
from mdl.targets.python.per_function import inline_lines


@dataclass(frozen=True)
class Row:
    """One function of the list, in decode order: its value is local `v<var>`; `kind` shape: decoded
    by the printed decoder of shape `index`; call: by the caller's function `_f<index>` of its
    registers (and, for an expression, of the values `deps`, the vars of the functions it names)."""

    var: int
    kind: Literal["shape", "call"]
    index: int
    slots: tuple[int, ...]  # its registers' slots in the buffer, in address order
    deps: tuple[int, ...] = ()

    def as_tuple(self) -> tuple[int, str, int, tuple[int, ...], tuple[int, int] | None, tuple[int, ...]]:
        """(var, kind, index, slots, (first, end) where they are read as a slice, deps): what the
        template unpacks."""
        return self.var, self.kind, self.index, self.slots, span(self.slots), self.deps


def reader_source(
    shapes: Sequence[tuple[ir.DecodeStep, ...]], rows: Sequence[Row], results: Sequence[tuple[str, int]]
) -> str:
    """Python source defining `decode(raw) -> {name: value}`: `shapes` are the distinct decode IRs
    (without fragments and expressions), `rows` every function to decode, dependencies first;
    `results` (name, var) what it returns. The caller binds `_f<index>` and `struct`. A row of a shape
    whose decoder returns only at its end has the decoder's lines in place of the call, as a generated
    driver's _values has (mdl.targets.python.per_function.inline_lines)."""
    env = environment()
    ops = env.get_template("python/templates/ops.j2").module
    bodies = [ops.decode_body(steps, [], []).rstrip() for steps in shapes]  # type: ignore[attr-defined]
    inline = [
        inline_lines(bodies[row.index], "raw", row.slots, f"v{row.var}")
        if row.kind == "shape" and not row.deps
        else None
        for row in rows
    ]
    return env.get_template("python/templates/reader.py.j2").render(
        shapes=shapes,
        rows=[(*row.as_tuple(), lines) for row, lines in zip(rows, inline, strict=True)],
        results=results,
    )
