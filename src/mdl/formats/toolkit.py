"""Modbus Schema Toolkit YAML -> MDL 1.0 (description, blocks, fields, tests).

Fields become functions named by their id; where an id repeats in several blocks, those
functions are named "<block>.<id>". Expressions name fields of their own block by id.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from mdl.addressing import AddressError, parse_address
from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.expr.fields import compile_device
from mdl.fileio import read_text
from mdl.model import Device, Function, Scenario, ScenarioInput


class _Node:
    """A YAML value with its line and column (1-based)."""

    def __init__(self, value, line: int, col: int, quoted: bool = False):
        self.value, self.line, self.col, self.quoted = value, line, col, quoted


def _convert(node) -> _Node:
    line, col = node.start_mark.line + 1, node.start_mark.column + 1
    if isinstance(node, yaml.MappingNode):
        return _Node({k.value: _convert(v) for k, v in node.value}, line, col)
    if isinstance(node, yaml.SequenceNode):
        return _Node([_convert(v) for v in node.value], line, col)
    return _Node(node.value, line, col, node.style in ("'", '"'))


def load_yaml(path) -> _Node:
    text = read_text(path)
    try:
        root = yaml.compose(text, Loader=yaml.BaseLoader)  # every scalar stays text: "0001" is not 1
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise error(f"malformed YAML: {getattr(exc, 'problem', None) or exc}", path,
                    mark.line + 1 if mark else None, mark.column + 1 if mark else None) from None
    if root is None or not isinstance(root, yaml.MappingNode):
        raise error("not a Modbus Schema Toolkit file (expected a mapping with description and blocks)", path, 1)
    return _convert(root)


def _get(node: _Node, key: str, path, kind=str, required=True):
    item = node.value.get(key) if isinstance(node.value, dict) else None
    if item is None:
        if required:
            raise error(f"missing '{key}'", path, node.line, node.col)
        return None
    want = {str: str, list: list, dict: dict}[kind]
    if not isinstance(item.value, want):
        raise error(f"'{key}' must be {'a text' if kind is str else 'a list' if kind is list else 'a mapping'}",
                    path, item.line, item.col)
    return item


def import_schema(path) -> Device:
    path = Path(path)
    root = load_yaml(path)
    desc = _get(root, "description", path, required=False)
    device = Device(path.stem, desc.value if desc else f"Imported from {path.name}", version="1.0", source=str(path))
    maxregs = _get(root, "maxRegistersPerModbusRequest", path, required=False)
    if maxregs is not None:
        if not maxregs.value.isdigit() or not 1 <= int(maxregs.value) <= 125:
            raise error("maxRegistersPerModbusRequest must be a whole number from 1 to 125", path, maxregs.line, maxregs.col)
        device.max_registers = int(maxregs.value)
    blocks = _get(root, "blocks", path, list)
    fields: list[tuple[str, _Node, _Node]] = []
    for block in blocks.value:
        block_id = _get(block, "id", path).value
        for fld in _get(block, "fields", path, list).value:
            fields.append((block_id, fld, _get(fld, "id", path)))
    counts: dict[str, int] = {}
    for _, _, fid in fields:
        counts[fid.value] = counts.get(fid.value, 0) + 1
    positions: dict[str, _Node] = {}
    names: dict[tuple[str, str], str] = {}
    for block_id, fld, fid in fields:
        name = fid.value if counts[fid.value] == 1 else f"{block_id}.{fid.value}"
        if (block_id, fid.value) in names:
            raise error(f"field '{fid.value}' appears twice in block '{block_id}'", path, fid.line, fid.col)
        names[(block_id, fid.value)] = name
        expr = _get(fld, "expression", path)
        description = _get(fld, "description", path, required=False)
        unit = _get(fld, "unit", path, required=False)
        fn = Function(name, description.value if description else fid.value, [], block_labels=[block_id],
                      units=unit.value if unit else None, expression=expr.value, line=fid.line,
                      expression_line=expr.line)
        for key, attr in (("immutable", "immutable"), ("system", "system")):
            flag = _get(fld, key, path, required=False)
            if flag is not None:
                if flag.value.lower() not in ("true", "false"):
                    raise error(f"'{key}' must be true or false", path, flag.line, flag.col)
                setattr(fn, attr, flag.value.lower() == "true")
        group = _get(fld, "fetchGroup", path, required=False)
        if group is not None:
            fn.fetch_group = group.value
        positions[name] = expr
        device.functions.append(fn)
    problems = compile_device(device)
    if problems:
        raise MdlError([Diagnostic(str(path), positions[p.function.name].line, p.col,
                                   f"field '{p.function.field_id}' of block '{p.function.block}': {p.message}")
                        for p in problems])
    for fn in device.functions:
        lowered = fn.compiled.lowered
        fn.addresses = list(lowered.addresses)
        if lowered.table and lowered.table != "holding":
            fn.register_type = lowered.table
    tests = _get(root, "tests", path, list, required=False)
    for test in tests.value if tests else []:
        device.tests.append(_scenario(test, names, path))
    return device


def _scenario(test: _Node, names, path) -> Scenario:
    sc = Scenario(_get(test, "id", path).value, line=test.line)
    desc = _get(test, "description", path, required=False)
    sc.description = desc.value if desc else None
    for item in _get(test, "input", path, list, required=False).value if "input" in test.value else []:
        # the Toolkit's files spell these firstAddress/rawValues, later ones firstRegisterAddress/registers
        first = _get(item, "firstRegisterAddress" if "firstRegisterAddress" in item.value else "firstAddress", path)
        try:
            table, address = parse_address(first.value)
        except AddressError as exc:
            raise error(str(exc), path, first.line, first.col) from None
        raw = _get(item, "registers" if "registers" in item.value else "rawValues", path)
        words = raw.value.split()
        for w in words:
            ok = (len(w) == 4 and (all(c in "0123456789abcdefABCDEF" for c in w) or w == "----" or w.lower() == "xxxx")) \
                or (table in ("coil", "discrete") and set(w.lower()) <= {"0", "1", "-", "x"})
            if not ok:
                raise error(f"raw value '{w}' is not 4 hex digits, '----' or 'xxxx'"
                            + (" (or bits 0, 1, -, x)" if table in ("coil", "discrete") else ""), path, raw.line, raw.col)
        sc.inputs.append(ScenarioInput(table, address, words))
    for block in _get(test, "blocks", path, list, required=False).value if "blocks" in test.value else []:
        block_id = _get(block, "id", path).value
        expected = _get(block, "expected", path, dict)
        for field_id, values in expected.value.items():
            name = names.get((block_id, field_id))
            if name is None:
                raise error(f"test '{sc.id}': block '{block_id}' has no field '{field_id}'", path, values.line, values.col)
            items = values.value if isinstance(values.value, list) else [values]
            sc.expected[name] = [v.value for v in items] or None
    return sc
