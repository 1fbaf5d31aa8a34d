"""YAML read as nodes that know their line and column, for the formats written in YAML (the Modbus
Schema Toolkit's files, mdl's profiles): every scalar stays text (`0001` is not 1), so each format
decides what its values mean and every error names where it is.

The YAML is read from the parser's events without recursion: aliases are refused (no format here
needs them, and expanding them turns a few hundred bytes into gigabytes) and so is nesting deeper
than MAX_YAML_DEPTH, each with the file, line and column. A file larger than MAX_FILE_BYTES is parsed
up to there only and then refused (the YAML parser takes some seconds a megabyte), so time and memory
stay linear in the file and bounded (docs/user-guide.md, "Limits of the Toolkit import").
"""

from __future__ import annotations

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

from mdl.diagnostics import TextSpan, TextStyle, error
from mdl.fileio import decode_text, read_head, too_large

if TYPE_CHECKING:
    from _typeshed import StrPath

# Toolkit files nest 7 levels (tests > test > blocks > block > expected > field > values); deeper
# input is refused while it is read, before the YAML scanner's look-ahead grows with the depth.
MAX_YAML_DEPTH = 32
MAX_FILE_BYTES = 2 * 1024 * 1024  # a hundred times the largest reference file (20 kB)
_LOOK_AHEAD = 4096  # characters: a YAML error this close to where a larger file was cut may be the cut's


class Node:
    """A YAML value with its line and column (1-based)."""

    def __init__(self, line: int, col: int):
        self.line, self.col = line, col


class Text(Node):
    def __init__(self, value: str, line: int, col: int, raw: str = "", style: TextStyle = "plain"):
        super().__init__(line, col)
        self.value = value
        self.raw, self.style = raw, style  # the scalar as written, for positions inside it

    def span(self, label: str | None = None) -> TextSpan:
        return TextSpan(self.line, self.col, self.raw, self.style, label)


class List(Node):
    def __init__(self, line: int, col: int):
        super().__init__(line, col)
        self.value: list[Node] = []


class Map(Node):
    def __init__(self, line: int, col: int):
        super().__init__(line, col)
        self.value: dict[str, Node] = {}
        self.key: Text | None = None  # while reading: a key waiting for its value


N = TypeVar("N", bound=Node)
KIND_NAMES: dict[type[Node], str] = {Text: "a text", List: "a list", Map: "a mapping"}


def _position(event: Event) -> tuple[int, int]:
    mark = event.start_mark
    return (mark.line + 1, mark.column + 1) if mark else (1, 1)


_STYLES: dict[str | None, TextStyle] = {"'": "single", '"': "double"}


def _node(event: Event, path: StrPath, text: str) -> Node:
    """The node an event opens; an alias is refused (see above)."""
    line, col = _position(event)
    if isinstance(event, AliasEvent):
        raise error("YAML aliases are not supported", path, line, col)
    if isinstance(event, ScalarEvent):
        start, end = event.start_mark, event.end_mark
        written = event.style in ("'", '"', None)  # a block scalar (| >): positions at its start
        raw = text[start.index : end.index] if written and start is not None and end is not None else ""
        return Text(event.value, line, col, raw, _STYLES.get(event.style, "plain"))
    if isinstance(event, SequenceStartEvent):
        return List(line, col)
    assert isinstance(event, MappingStartEvent)  # the last kind of event that opens a node
    return Map(line, col)


def _attach(parent: Node, node: Node, path: StrPath) -> None:
    if isinstance(parent, List):
        parent.value.append(node)
    elif not isinstance(parent, Map):
        raise AssertionError("only collections are open")
    elif parent.key is not None:
        parent.value[parent.key.value] = node
        parent.key = None
    elif isinstance(node, Text):
        if node.value in parent.value:  # YAML's keys are unique; a reader keeping the last would hide one
            raise error(f"key '{node.value[:40]}' appears twice in this mapping", path, node.line, node.col)
        parent.key = node
    else:
        raise error("a mapping key must be a plain text", path, node.line, node.col)


def _compose(text: str, path: StrPath) -> Node | None:
    """The document of a YAML text as nodes, built from the parser's events without recursion."""
    root: Node | None = None
    open_nodes: list[Node] = []
    documents = 0
    for event in yaml.parse(text, Loader=yaml.BaseLoader):  # every scalar stays text: "0001" is not 1
        if isinstance(event, DocumentStartEvent):
            documents += 1
            if documents > 1:
                raise error("the file must hold one YAML document", path, *_position(event))
        elif isinstance(event, CollectionEndEvent):
            open_nodes.pop()
        elif isinstance(event, (AliasEvent, ScalarEvent, SequenceStartEvent, MappingStartEvent)):
            node = _node(event, path, text)
            if open_nodes:
                _attach(open_nodes[-1], node, path)
            else:
                root = node
            if isinstance(node, (List, Map)):
                open_nodes.append(node)
                if len(open_nodes) > MAX_YAML_DEPTH:
                    raise error(f"YAML nested more than {MAX_YAML_DEPTH} levels deep", path, node.line, node.col)
    return root


def load_yaml(path: StrPath, what: str) -> Map:
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
    if not isinstance(root, Map):
        raise error(f"not {what} (expected a mapping at its top)", path, 1)
    return root


def opt(node: Node, key: str, path: StrPath, kind: type[N]) -> N | None:
    """node[key] if node is a mapping that has it, else None; an error if it is not a `kind`."""
    item = node.value.get(key) if isinstance(node, Map) else None
    if item is None:
        return None
    if not isinstance(item, kind):
        raise error(f"'{key}' must be {KIND_NAMES[kind]}", path, item.line, item.col)
    return item


def need(node: Node, key: str, path: StrPath, kind: type[N]) -> N:
    item = opt(node, key, path, kind)
    if item is None:
        raise error(f"missing '{key}'", path, node.line, node.col)
    return item
