"""Type-check an expression tree and lower it to straight-line operations.

Types: long (64-bit signed), double, string, bool, list (of strings, from bitset), regs (register
values, only as function arguments). Every value may be null: a "not implemented" value, a
missing register, or a null operand make an operation null; concat prints a null as ''.

An operation is Op(tmp, kind, type, args, data) (mdl.dsl.expr.ops: what each kind computes); args
name earlier temps or parameters.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mdl.dsl.expr.nodes import Binary, Bool, Call, Constant, ExprError, Node, Num, Ref, Registers, Str, Swap, Unary
from mdl.dsl.expr.ops import Op, OpData, OpKind
from mdl.model import BIT_TABLES
from mdl.model.layout import MAX_BITS, MAX_REGISTERS

if TYPE_CHECKING:
    from typing_extensions import Unpack

REGISTER_COUNT = {
    "int16": 1,
    "uint16": 1,
    "int32": 2,
    "uint32": 2,
    "int64": 4,
    "uint64": 4,
    "ieee754_32": 2,
    "ieee754_64": 4,
    "ipv4addr": 2,
    "ipv6addr": 8,
}
RESULT = {
    "int16": "long",
    "uint16": "long",
    "int32": "long",
    "uint32": "long",
    "int64": "long",
    "uint64": "long",
    "ieee754_32": "double",
    "ieee754_64": "double",
    "utf8": "string",
    "hexstring": "string",
    "eui48": "string",
    "ipv4addr": "string",
    "ipv6addr": "string",
    "enum": "string",
    "bitset": "list",
    "bitsetbit": "bool",
}


@dataclass
class Lowered:
    ops: list[Op]
    result: str  # the temp (or parameter) holding the value
    type: str
    table: str | None
    addresses: list[int]  # the function's own registers, ascending
    refs: list[str]  # referenced field ids, in parameter order
    # the parameters (indexes) naming a plain UINT64 function: a long is 64 bits, so the expression
    # sees such a value as its 64 bits, two's complement (above 2^63 - 1, negative) in every target
    wide: tuple[int, ...] = ()
    # what the operations depend on (Scan.shape, the parameters' types, the register limit): two
    # expressions of one shape have equal operations, so a target prints them once (with `wide`)
    shape: Hashable = None


@dataclass
class Scan:
    """One walk of a tree: its register sets (table, addresses, col), the fields it names in parameter
    order (first use first), and its shape: the tree with each address as its distance from the first
    one and each field as its parameter number. Trees of one shape lower to
    the same operations (the registers an operation reads are indexes into the sorted addresses, the
    same for addresses at the same distances; a field is its parameter), for the same field types."""

    registers: list[tuple[str, list[int], int]]
    refs: list[str]
    shape: Hashable


def scan(node: Node) -> Scan:
    registers: list[tuple[str, list[int], int]] = []
    refs: list[str] = []
    numbers: dict[str, int] = {}

    def walk(node: Node) -> Hashable:  # the kinds most trees hold first
        if isinstance(node, Binary):
            return node.op, walk(node.left), walk(node.right)
        if isinstance(node, Ref):
            number = numbers.get(node.name)
            if number is None:
                number = numbers[node.name] = len(refs)
                refs.append(node.name)
            return "p", number
        if isinstance(node, Call):
            return (
                node.name,
                tuple([walk(arg) for arg in node.args]),
                tuple(map(tuple, node.not_implemented)) if node.not_implemented else (),
                tuple(node.mapping.items()) if node.mapping else (),
                node.bit,
                node.labels,
            )
        if isinstance(node, Registers):
            registers.append((node.table, node.addresses, node.col))
            base = registers[0][1][0]
            return "r", node.table, tuple([a - base for a in node.addresses])
        if isinstance(node, Num):
            value = node.value  # a float by its repr: 0.0 and -0.0 are equal, and 1 and 1.0
            return ("f", repr(value)) if isinstance(value, float) else ("i", value)
        if isinstance(node, (Str, Bool)):
            return type(node).__name__, node.value
        if isinstance(node, Constant):
            return "k", tuple(node.words)
        if isinstance(node, Unary):
            return "Unary", node.op, walk(node.arg)
        assert isinstance(node, Swap), node  # the one kind of node left
        return "Swap", node.kind, walk(node.arg)

    shape = walk(node)
    return Scan(registers, refs, shape)


class Lowerer:
    def __init__(self, ref_types: dict[str, str], max_registers: int = MAX_REGISTERS):
        self.ref_types = ref_types
        self.ops: list[Op] = []
        self.max_registers = max_registers

    def tmp(self) -> str:
        return f"t{len(self.ops)}"

    def emit(self, kind: OpKind, type_: str, args: Iterable[str] = (), **data: Unpack[OpData]) -> tuple[str, str]:
        op = Op(f"t{len(self.ops)}", kind, type_, list(args), data)  # self.tmp(), written out
        self.ops.append(op)
        return op.tmp, type_

    def lower(self, node: Node, scanned: Scan) -> Lowered:
        """The operations of the tree; `scanned` is scan(node)."""
        found = scanned.registers
        tables = {t for t, _, _ in found}
        if len(tables) > 1:
            first = found[0][0]
            col = next(c for t, _, c in found if t != first)
            raise ExprError(f"the expression mixes register tables ({', '.join(sorted(tables))})", col)
        self.table = found[0][0] if found else None
        self.addresses = sorted({a for _, addrs, _ in found for a in addrs})
        limit = MAX_BITS if self.table in BIT_TABLES else self.max_registers
        if len(self.addresses) > limit:
            needs = f"the expression needs {len(self.addresses)} registers"
            raise ExprError(f"{needs}; one request reads at most {limit}", 1)
        self.refs = scanned.refs
        result, type_ = self.value(node)
        if type_ == "regs":
            raise ExprError("registers need a function such as int16(...) or utf8(...)", node.col)
        return Lowered(self.ops, result, type_, self.table, self.addresses, self.refs)

    # -- values
    def value(self, node: Node) -> tuple[str, str]:
        if isinstance(node, Num):
            return self.emit(OpKind.LIT, "double" if isinstance(node.value, float) else "long", value=node.value)
        if isinstance(node, Str):
            return self.emit(OpKind.LIT, "string", value=node.value)
        if isinstance(node, Bool):
            return self.emit(OpKind.LIT, "bool", value=node.value)
        if isinstance(node, Ref):
            return f"p{self.refs.index(node.name)}", self.ref_types[node.name]
        if isinstance(node, (Registers, Constant, Swap)):
            return self.regs(node)
        if isinstance(node, Unary):
            arg, t = self.number(node.arg)
            return self.emit(OpKind.NEG, t, [arg])
        if isinstance(node, Binary):
            return self.binary(node)
        assert isinstance(node, Call), node  # the one kind of node left
        return self.call(node)

    def number(self, node: Node) -> tuple[str, str]:
        tmp, t = self.value(node)
        if t not in ("long", "double"):
            raise ExprError(f"arithmetic needs numbers, but this is a {'text' if t == 'string' else t}", node.col)
        return tmp, t

    def binary(self, node: Binary) -> tuple[str, str]:
        a, ta = self.number(node.left)
        b, tb = self.number(node.right)
        if node.op in ("/", "^") or "double" in (ta, tb):
            if ta == "long":
                a, ta = self.emit(OpKind.TODOUBLE, "double", [a])
            if tb == "long":
                b, tb = self.emit(OpKind.TODOUBLE, "double", [b])
        kind = {"/": OpKind.DIV, "^": OpKind.POW}.get(node.op, OpKind.ARITH)
        return self.emit(kind, "double" if kind is not OpKind.ARITH else ta, [a, b], op=node.op)

    def regs(self, node: Node, bits_ok: bool = False) -> tuple[str, str]:
        if isinstance(node, Registers):
            if node.table in BIT_TABLES and not bits_ok:
                raise ExprError("coils and discrete inputs are read with boolean(...)", node.col)
            if node.table not in BIT_TABLES and bits_ok:
                raise ExprError("boolean(...) reads a coil or discrete input (c:N, di:N)", node.col)
            idx = [self.addresses.index(a) for a in node.addresses]
            return self.emit(OpKind.REGS, "regs", count=len(idx), index=idx)
        if isinstance(node, Constant):
            return self.emit(OpKind.CONST, "regs", count=len(node.words), words=node.words)
        if isinstance(node, Swap):
            inner, _ = self.regs(node.arg)
            return self.emit(OpKind[node.kind.upper()], "regs", [inner], count=self.ops[-1].data["count"])
        raise ExprError('expected registers (hr:N#count, "0x1234", swapbytes(...))', node.col)

    def call(self, node: Call) -> tuple[str, str]:
        name = node.name
        if name == "concat":
            parts = []
            for arg in node.args:
                tmp, t = self.value(arg)
                if t == "regs":
                    raise ExprError("registers need a function such as utf8(...) inside concat", arg.col)
                parts.append((tmp, t))
            return self.emit(OpKind.CONCAT, "string", [p for p, _ in parts], types=[t for _, t in parts])
        if name == "boolean":
            arg = node.args[0]
            if isinstance(arg, Registers):
                if len(arg.addresses) != 1:
                    raise ExprError("boolean(...) reads exactly one coil or discrete input", arg.col)
                regs, _ = self.regs(arg, bits_ok=True)
                value, _ = self.emit(OpKind.BIT, "bool", [regs])
            else:
                value, t = self.value(arg)
                if t != "bool":
                    raise ExprError(f"boolean(...) needs a boolean or a discrete, not a {t}", arg.col)
            if node.labels is None:
                return value, "bool"
            return self.emit(OpKind.LABEL, "string", [value], labels=node.labels)
        regs, _ = self.regs(node.args[0])
        count = self.ops[-1].data["count"]
        want = REGISTER_COUNT.get(name)
        if want is not None and count != want:
            raise ExprError(f"{name} needs {want} register{'s' if want > 1 else ''}, got {count}", node.args[0].col)
        if name == "eui48" and count not in (3, 4):
            raise ExprError(f"eui48 needs 3 or 4 registers, got {count}", node.args[0].col)
        if name == "enum" and count > 4:
            raise ExprError(f"enum reads at most 4 registers (64 bits), got {count}", node.args[0].col)
        for group in node.not_implemented:
            if len(group) != count:
                raise ExprError(
                    f"a 'not implemented' value of {len(group)} register(s) for {count} register(s)", node.col
                )
        if name == "bitsetbit":
            if node.bit is None or not 0 <= node.bit < 16 * count:
                raise ExprError(f"bitsetbit needs a bit number from 0 to {16 * count - 1}", node.col)
        elif node.bit is not None:
            raise ExprError(f"{name} takes no bit number", node.col)
        if node.mapping and name not in ("enum", "bitset"):
            raise ExprError(f"{name} takes no mapping", node.col)
        ni = [list(g) for g in node.not_implemented]
        return self.emit(
            OpKind[name.upper()], RESULT[name], [regs], ni=ni, count=count, mapping=dict(node.mapping), bit=node.bit
        )


def lower(
    node: Node,
    ref_types: dict[str, str],
    max_registers: int = MAX_REGISTERS,
    done: dict[Hashable, Lowered] | None = None,
    scanned: Scan | None = None,
) -> Lowered:
    """The operations of the tree, given the types of the fields it names. With `done` (shape ->
    an expression lowered before), an expression of a shape lowered before takes its operations
    (the same list, never changed after lowering) and only its own registers and fields are worked
    out; an expression that fails is lowered again each time, so that its error names its column.
    `scanned` is scan(node), where the caller has it."""
    if scanned is None:
        scanned = scan(node)
    shape = (scanned.shape, tuple([ref_types[r] for r in scanned.refs]), max_registers)
    before = done.get(shape) if done is not None else None
    if before is None:
        lowered = Lowerer(ref_types, max_registers).lower(node, scanned)
        lowered.shape = shape
        if done is not None:
            done[shape] = lowered
        return lowered
    found = scanned.registers
    table = found[0][0] if found else None
    addresses = sorted({a for _, addrs, _ in found for a in addrs})
    return Lowered(before.ops, before.result, before.type, table, addresses, scanned.refs, shape=shape)
