"""Modbus Schema Toolkit YAML -> MDL 1.0 (description, blocks, fields, tests).

Fields become functions named by their id; where an id repeats in several blocks, those
functions are named "<block>.<id>". Expressions name fields of their own block by id.

The YAML is read from the parser's events without recursion: aliases are refused (Toolkit files
need none, and expanding them turns a few hundred bytes into gigabytes) and so is nesting deeper
than MAX_YAML_DEPTH, each with the file, line and column. A file larger than MAX_FILE_BYTES is parsed
up to there only and then refused (the YAML parser takes some seconds a megabyte), so time and memory
stay linear in the file and bounded (docs/user-guide.md, "Limits of the Toolkit import").
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import yaml
from yaml.events import (
    AliasEvent,
    CollectionEndEvent,
    DocumentStartEvent,
    Event,
    MappingStartEvent,
    ScalarEvent,
    SequenceStartEvent,
)

from mdl.diagnostics import TextSpan, TextStyle, error, record_span
from mdl.fileio import decode_text, read_head, too_large
from mdl.lang.expr.ops import OpKind
from mdl.model import Device, Function, Scenario, ScenarioInput
from mdl.model.addressing import AddressError, parse_address
from mdl.model.layout import MAX_ADDRESS, MAX_REGISTERS

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.resolve import ResolvedDevice, ResolvedFunction

# Toolkit files nest 7 levels (tests > test > blocks > block > expected > field > values); deeper
# input is refused while it is read, before the YAML scanner's look-ahead grows with the depth.
MAX_YAML_DEPTH = 32
MAX_FILE_BYTES = 2 * 1024 * 1024  # a hundred times the largest reference file (20 kB)
_LOOK_AHEAD = 4096  # characters: a YAML error this close to where a larger file was cut may be the cut's


class _Node:
    """A YAML value with its line and column (1-based)."""

    def __init__(self, line: int, col: int):
        self.line, self.col = line, col


class _Text(_Node):
    def __init__(self, value: str, line: int, col: int, raw: str = "", style: TextStyle = "plain"):
        super().__init__(line, col)
        self.value = value
        self.raw, self.style = raw, style  # the scalar as written, for positions inside it

    def span(self, label: str | None = None) -> TextSpan:
        return TextSpan(self.line, self.col, self.raw, self.style, label)


class _List(_Node):
    def __init__(self, line: int, col: int):
        super().__init__(line, col)
        self.value: list[_Node] = []


class _Map(_Node):
    def __init__(self, line: int, col: int):
        super().__init__(line, col)
        self.value: dict[str, _Node] = {}
        self.key: _Text | None = None  # while reading: a key waiting for its value


N = TypeVar("N", bound=_Node)
KIND_NAMES: dict[type[_Node], str] = {_Text: "a text", _List: "a list", _Map: "a mapping"}


def _position(event: Event) -> tuple[int, int]:
    mark = event.start_mark
    return (mark.line + 1, mark.column + 1) if mark else (1, 1)


_STYLES: dict[str | None, TextStyle] = {"'": "single", '"': "double"}


def _node(event: Event, path: StrPath, text: str) -> _Node:
    """The node an event opens; an alias is refused (see above)."""
    line, col = _position(event)
    if isinstance(event, AliasEvent):
        raise error("YAML aliases are not supported", path, line, col)
    if isinstance(event, ScalarEvent):
        start, end = event.start_mark, event.end_mark
        written = event.style in ("'", '"', None)  # a block scalar (| >): positions at its start
        raw = text[start.index : end.index] if written and start is not None and end is not None else ""
        return _Text(event.value, line, col, raw, _STYLES.get(event.style, "plain"))
    if isinstance(event, SequenceStartEvent):
        return _List(line, col)
    assert isinstance(event, MappingStartEvent)  # the last kind of event that opens a node
    return _Map(line, col)


def _attach(parent: _Node, node: _Node, path: StrPath) -> None:
    if isinstance(parent, _List):
        parent.value.append(node)
    elif not isinstance(parent, _Map):
        raise AssertionError("only collections are open")
    elif parent.key is not None:
        parent.value[parent.key.value] = node
        parent.key = None
    elif isinstance(node, _Text):
        parent.key = node
    else:
        raise error("a mapping key must be a plain text", path, node.line, node.col)


def _compose(text: str, path: StrPath) -> _Node | None:
    """The document of a YAML text as nodes, built from the parser's events without recursion."""
    root: _Node | None = None
    open_nodes: list[_Node] = []
    documents = 0
    for event in yaml.parse(text, Loader=yaml.BaseLoader):  # every scalar stays text: "0001" is not 1
        if isinstance(event, DocumentStartEvent):
            documents += 1
            if documents > 1:
                raise error("a Toolkit file holds one YAML document", path, *_position(event))
        elif isinstance(event, CollectionEndEvent):
            open_nodes.pop()
        elif isinstance(event, (AliasEvent, ScalarEvent, SequenceStartEvent, MappingStartEvent)):
            node = _node(event, path, text)
            if open_nodes:
                _attach(open_nodes[-1], node, path)
            else:
                root = node
            if isinstance(node, (_List, _Map)):
                open_nodes.append(node)
                if len(open_nodes) > MAX_YAML_DEPTH:
                    raise error(f"YAML nested more than {MAX_YAML_DEPTH} levels deep", path, node.line, node.col)
    return root


def load_yaml(path: StrPath) -> _Map:
    """The file's root mapping. A file larger than MAX_FILE_BYTES is parsed up to there only: an error found
    before (bad nesting, an alias, malformed YAML) is reported where it is, as it would be in the whole file;
    otherwise the file is refused for its size."""
    data = read_head(path, MAX_FILE_BYTES)
    larger = len(data) > MAX_FILE_BYTES
    if larger:
        cut = MAX_FILE_BYTES
        while cut and data[cut] & 0xC0 == 0x80:  # not inside a UTF-8 character
            cut -= 1
        data = data[:cut]
    text = decode_text(data, path)
    try:
        root = _compose(text, path)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        if larger and (mark is None or mark.index >= len(text) - _LOOK_AHEAD):
            raise too_large(path, MAX_FILE_BYTES) from None
        raise error(
            f"malformed YAML: {getattr(exc, 'problem', None) or exc}",
            path,
            mark.line + 1 if mark else None,
            mark.column + 1 if mark else None,
        ) from None
    if larger:
        raise too_large(path, MAX_FILE_BYTES)
    if not isinstance(root, _Map):
        raise error("not a Modbus Schema Toolkit file (expected a mapping with description and blocks)", path, 1)
    return root


def _opt(node: _Node, key: str, path: StrPath, kind: type[N]) -> N | None:
    """node[key] if node is a mapping that has it, else None; an error if it is not a `kind`."""
    item = node.value.get(key) if isinstance(node, _Map) else None
    if item is None:
        return None
    if not isinstance(item, kind):
        raise error(f"'{key}' must be {KIND_NAMES[kind]}", path, item.line, item.col)
    return item


def _need(node: _Node, key: str, path: StrPath, kind: type[N]) -> N:
    item = _opt(node, key, path, kind)
    if item is None:
        raise error(f"missing '{key}'", path, node.line, node.col)
    return item


def import_schema(path: StrPath) -> Device:
    """`read_schema`, resolved (MdlError with every error), with each field's registers written into
    the model (`addresses`, `register_type`) as an MDL document needs them."""
    from mdl.resolve import resolve

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
    every check is mdl.resolve's), the positions of their texts recorded."""
    path = Path(path)
    root = load_yaml(path)
    desc = _opt(root, "description", path, _Text)
    device = Device(path.stem, desc.value if desc else f"Imported from {path.name}", version="1.0", source=str(path))
    maxregs = _opt(root, "maxRegistersPerModbusRequest", path, _Text)
    if maxregs is not None:
        if not re.fullmatch(r"[0-9]{1,3}", maxregs.value) or not 1 <= int(maxregs.value) <= MAX_REGISTERS:
            raise error(
                f"maxRegistersPerModbusRequest must be a whole number from 1 to {MAX_REGISTERS}",
                path,
                maxregs.line,
                maxregs.col,
            )
        device.max_registers = int(maxregs.value)
    fields: list[tuple[str, _Node, _Text]] = []
    for block in _need(root, "blocks", path, _List).value:
        block_id = _need(block, "id", path, _Text).value
        for fld in _need(block, "fields", path, _List).value:
            fields.append((block_id, fld, _need(fld, "id", path, _Text)))
    counts: dict[str, int] = {}
    for _, _, fid in fields:
        counts[fid.value] = counts.get(fid.value, 0) + 1
    names: dict[tuple[str, str], str] = {}
    for block_id, fld, fid in fields:
        name = fid.value if counts[fid.value] == 1 else f"{block_id}.{fid.value}"
        if (block_id, fid.value) in names:
            raise error(f"field '{fid.value}' appears twice in block '{block_id}'", path, fid.line, fid.col)
        names[(block_id, fid.value)] = name
        expr = _need(fld, "expression", path, _Text)
        fn = _function(name, block_id, fld, fid, expr, path)
        record_span(fn, "", TextSpan(fid.line, fid.col))
        record_span(fn, "expression", expr.span(f"field '{fid.value}' of block '{block_id}'"))
        device.functions.append(fn)
    tests = _opt(root, "tests", path, _List)
    for test in tests.value if tests else []:
        sc = _scenario(test, names, path)
        record_span(sc, "", TextSpan(test.line, test.col))
        device.tests.append(sc)
    return device


def _function(name: str, block_id: str, fld: _Node, fid: _Text, expr: _Text, path: Path) -> Function:
    description = _opt(fld, "description", path, _Text)
    unit = _opt(fld, "unit", path, _Text)
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
        flag = _opt(fld, key, path, _Text)
        if flag is not None:
            if flag.value.lower() not in ("true", "false"):
                raise error(f"'{key}' must be true or false", path, flag.line, flag.col)
            setattr(fn, key, flag.value.lower() == "true")
    group = _opt(fld, "fetchGroup", path, _Text)
    if group is not None:
        fn.fetch_group = group.value
    return fn


def _scenario(test: _Node, names: dict[tuple[str, str], str], path: Path) -> Scenario:
    sc = Scenario(_need(test, "id", path, _Text).value, line=test.line)
    desc = _opt(test, "description", path, _Text)
    sc.description = desc.value if desc else None
    inputs = _opt(test, "input", path, _List)
    for item in inputs.value if inputs else []:
        sc.inputs.append(_scenario_input(item, path))
    blocks = _opt(test, "blocks", path, _List)
    for block in blocks.value if blocks else []:
        block_id = _need(block, "id", path, _Text).value
        for field_id, values in _need(block, "expected", path, _Map).value.items():
            name = names.get((block_id, field_id))
            if name is None:
                raise error(
                    f"test '{sc.id}': block '{block_id}' has no field '{field_id}'", path, values.line, values.col
                )
            sc.expected[name] = _expected(values, sc.id, path) or None
    return sc


def _expected(values: _Node, test_id: str, path: Path) -> list[str]:
    """An expected value, or a list of them (a bitset's names; [] for null)."""
    items = values.value if isinstance(values, _List) else [values]
    texts = []
    for item in items:
        if not isinstance(item, _Text):
            raise error(f"test '{test_id}': an expected value must be a text or a number", path, item.line, item.col)
        texts.append(item.value)
    return texts


def _scenario_input(item: _Node, path: Path) -> ScenarioInput:
    # the Toolkit's files spell these firstAddress/rawValues, later ones firstRegisterAddress/registers
    given = item.value if isinstance(item, _Map) else {}
    first = _need(item, "firstRegisterAddress" if "firstRegisterAddress" in given else "firstAddress", path, _Text)
    try:
        table, address = parse_address(first.value)
    except AddressError as exc:
        raise error(str(exc), path, first.line, first.col) from None
    raw = _need(item, "registers" if "registers" in given else "rawValues", path, _Text)
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
