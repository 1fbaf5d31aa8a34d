"""Modbus Schema Toolkit YAML -> MDL 1.0 (description, blocks, fields, tests).

Fields become functions named by their id; where an id repeats in several blocks, those
functions are named "<block>.<id>". Expressions name fields of their own block by id.

The YAML is read as nodes with their positions (mdl.exchange.yamlnodes: no aliases, bounded depth
and size; docs/user-guide.md, "Limits of the Toolkit import").
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

from mdl.diagnostics import TextSpan, error, record_span
from mdl.dsl.expr.ops import OpKind
from mdl.exchange.yamlnodes import List, Map, Node, Text, load_yaml, need, opt
from mdl.model import Device, Function, Scenario, ScenarioInput
from mdl.model.addressing import AddressError, parse_address
from mdl.model.layout import MAX_ADDRESS, MAX_REGISTERS

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.resolver import ResolvedDevice, ResolvedFunction


def import_schema(path: StrPath) -> Device:
    """`read_schema`, resolved (MdlError with every error), with each field's registers written into
    the model (`addresses`, `register_type`) as an MDL document needs them."""
    from mdl.resolver import resolve

    return with_registers(resolve(read_schema(path), str(Path(path))))


def with_registers(resolved: ResolvedDevice) -> Device:
    """The resolved device's model with every expression function's registers filled in from its
    compiled expression, as MDL's `addresses` (and `register_type`) hold them; a field that is one bit
    of its registers (`as_bits`) becomes a read-only `bits` function, which exports can carry."""
    device = resolved.device
    for rf in resolved.functions:
        fn = rf.fn
        if as_bits(rf):
            continue
        if fn.expression is not None and not fn.addresses:
            fn.addresses = list(rf.layout.addresses)
            if rf.layout.table != "holding" and fn.register_type is None:
                fn.register_type = rf.layout.table
    return device


_BITS_FORMATS = {1: "UINT16", 2: "UINT32", 4: "UINT64"}


def as_bits(rf: ResolvedFunction) -> bool:
    """Rewrite a field whose expression is `bitsetbit(REGS; N)` alone, REGS 1, 2 or 4 registers listed in
    ascending order, without "not implemented" values, as MDL's `bits` N of a UINT16/32/64 (bit 0 the lowest
    of the last register in both; docs/bits-and-scale.md), read-only as the field is; whether it was."""
    lowered = rf.compiled.lowered if rf.compiled is not None else None
    if lowered is None or rf.fn.expression is None or lowered.refs or len(lowered.ops) != 2:
        return False
    regs, bit = lowered.ops
    count = regs.data.get("count", 0)
    if (
        regs.kind is not OpKind.REGS
        or bit.kind is not OpKind.BITSETBIT
        or bit.args != [regs.tmp]
        or lowered.result != bit.tmp
        or bit.data.get("ni")
        or count not in _BITS_FORMATS
        or regs.data.get("index") != list(range(count))
        or rf.layout.addresses != tuple(lowered.addresses)
    ):
        return False
    fn = rf.fn
    fn.expression = None
    fn.addresses = list(rf.layout.addresses)
    fn.format = _BITS_FORMATS[count]
    fn.bits = str(bit.data.get("bit"))
    fn.access = "read"
    if rf.layout.table != "holding":
        fn.register_type = rf.layout.table
    return True


def read_schema(path: StrPath) -> Device:
    """The model of a Toolkit file: its fields as functions with expressions (not compiled: that and
    every check is mdl.resolver's), the positions of their texts recorded."""
    path = Path(path)
    root = load_yaml(path, "a Modbus Schema Toolkit file")
    desc = opt(root, "description", path, Text)
    device = Device(path.stem, desc.value if desc else f"Imported from {path.name}", version="1.0", source=str(path))
    maxregs = opt(root, "maxRegistersPerModbusRequest", path, Text)
    if maxregs is not None:
        if not re.fullmatch(r"[0-9]{1,3}", maxregs.value) or not 1 <= int(maxregs.value) <= MAX_REGISTERS:
            raise error(
                f"maxRegistersPerModbusRequest must be a whole number from 1 to {MAX_REGISTERS}",
                path,
                maxregs.line,
                maxregs.col,
            )
        device.max_registers = int(maxregs.value)
    fields: list[tuple[str, Node, Text]] = []
    for block in need(root, "blocks", path, List).value:
        block_id = need(block, "id", path, Text).value
        for fld in need(block, "fields", path, List).value:
            fields.append((block_id, fld, need(fld, "id", path, Text)))
    counts: dict[str, int] = {}
    for _, _, fid in fields:
        counts[fid.value] = counts.get(fid.value, 0) + 1
    names: dict[tuple[str, str], str] = {}
    for block_id, fld, fid in fields:
        name = fid.value if counts[fid.value] == 1 else f"{block_id}.{fid.value}"
        if (block_id, fid.value) in names:
            raise error(f"field '{fid.value}' appears twice in block '{block_id}'", path, fid.line, fid.col)
        names[(block_id, fid.value)] = name
        expr = need(fld, "expression", path, Text)
        fn = _function(name, block_id, fld, fid, expr, path)
        record_span(fn, "", TextSpan(fid.line, fid.col))
        record_span(fn, "expression", expr.span(f"field '{fid.value}' of block '{block_id}'"))
        device.functions.append(fn)
    tests = opt(root, "tests", path, List)
    for test in tests.value if tests else []:
        sc = _scenario(test, names, path)
        record_span(sc, "", TextSpan(test.line, test.col))
        device.tests.append(sc)
    return device


def _function(name: str, block_id: str, fld: Node, fid: Text, expr: Text, path: Path) -> Function:
    description = opt(fld, "description", path, Text)
    unit = opt(fld, "unit", path, Text)
    fn = Function(
        name,
        description.value if description else fid.value,
        [],
        block_labels=[block_id],
        units=unit.value if unit else None,
        expression=expr.value,
        line=fid.line,
        expression_line=expr.line,
    )
    for key in ("immutable", "system"):
        flag = opt(fld, key, path, Text)
        if flag is not None:
            if flag.value.lower() not in ("true", "false"):
                raise error(f"'{key}' must be true or false", path, flag.line, flag.col)
            setattr(fn, key, flag.value.lower() == "true")
    group = opt(fld, "fetchGroup", path, Text)
    if group is not None:
        fn.fetch_group = group.value
    return fn


def _scenario(test: Node, names: dict[tuple[str, str], str], path: Path) -> Scenario:
    sc = Scenario(need(test, "id", path, Text).value, line=test.line)
    desc = opt(test, "description", path, Text)
    sc.description = desc.value if desc else None
    inputs = opt(test, "input", path, List)
    for item in inputs.value if inputs else []:
        sc.inputs.append(_scenario_input(item, path))
    blocks = opt(test, "blocks", path, List)
    for block in blocks.value if blocks else []:
        block_id = need(block, "id", path, Text).value
        for field_id, values in need(block, "expected", path, Map).value.items():
            name = names.get((block_id, field_id))
            if name is None:
                raise error(
                    f"test '{sc.id}': block '{block_id}' has no field '{field_id}'", path, values.line, values.col
                )
            sc.expected[name] = _expected(values, sc.id, path) or None
    return sc


def _expected(values: Node, test_id: str, path: Path) -> list[str]:
    """An expected value, or a list of them (a bitset's names; [] for null)."""
    items = values.value if isinstance(values, List) else [values]
    texts = []
    for item in items:
        if not isinstance(item, Text):
            raise error(f"test '{test_id}': an expected value must be a text or a number", path, item.line, item.col)
        texts.append(item.value)
    return texts


def _scenario_input(item: Node, path: Path) -> ScenarioInput:
    # the Toolkit's files spell these firstAddress/rawValues, later ones firstRegisterAddress/registers
    given = item.value if isinstance(item, Map) else {}
    first = need(item, "firstRegisterAddress" if "firstRegisterAddress" in given else "firstAddress", path, Text)
    try:
        table, address = parse_address(first.value)
    except AddressError as exc:
        raise error(str(exc), path, first.line, first.col) from None
    raw = need(item, "registers" if "registers" in given else "rawValues", path, Text)
    bits = table in ("coil", "discrete")
    words = raw.value.split()
    for w in words:
        ok = (
            len(w) == 4 and (all(c in "0123456789abcdefABCDEF" for c in w) or w == "----" or w.lower() == "xxxx")
        ) or (bits and set(w.lower()) <= {"0", "1", "-", "x"})
        if not ok:
            raise error(
                f"raw value '{w}' is not 4 hex digits, '----' or 'xxxx'" + (" (or bits 0, 1, -, x)" if bits else ""),
                path,
                raw.line,
                raw.col,
            )
    last = address + (sum(len(w) for w in words) if bits else len(words)) - 1
    if last > MAX_ADDRESS:
        raise error(f"the raw values run past address {MAX_ADDRESS} (to {last})", path, raw.line, raw.col)
    return ScenarioInput(table, address, words)
