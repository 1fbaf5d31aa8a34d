"""Expression trees. Every node records the 1-based column where it starts."""

from __future__ import annotations

from dataclasses import dataclass, field


class ExprError(ValueError):
    def __init__(self, message: str, col: int | None = None):
        super().__init__(message)
        self.col = col


@dataclass
class Node:
    col: int


@dataclass
class Num(Node):
    value: int | float


@dataclass
class Str(Node):
    value: str


@dataclass
class Bool(Node):
    value: bool


@dataclass
class Ref(Node):
    name: str  # a field id of the same block


@dataclass
class Registers(Node):
    table: str
    addresses: list[int]  # in the order written: that order is the byte order


@dataclass
class Constant(Node):
    words: list[int]  # "0x1234 0x5678"


@dataclass
class Swap(Node):
    kind: str  # swapbytes | swapendian
    arg: Node


@dataclass
class Call(Node):
    name: str
    args: list[Node] = field(default_factory=list)
    not_implemented: list[list[int]] = field(default_factory=list)
    mapping: dict[int, str] = field(default_factory=dict)
    bit: int | None = None
    labels: tuple[str, str] | None = None  # boolean(x; 'false text'; 'true text')


@dataclass
class Unary(Node):
    op: str
    arg: Node


@dataclass
class Binary(Node):
    op: str
    left: Node
    right: Node
