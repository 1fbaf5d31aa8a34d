"""Parse an expression. Field references may contain spaces ('Boolean Value'): they are matched
against the field ids of the block, longest first.

Precedence, loosest first: + -, then * / and implicit multiplication `5(3)`, then unary minus,
then ^ (right-associative, binding tightest), then primaries.

Every nesting (parentheses, calls, unary minus, ^, swaps) and every operator of a chain (`1+1+1`)
makes the tree one level deeper; past MAX_DEPTH levels the expression is refused, so neither this
recursive-descent parser nor the passes over its tree run out of stack. Register sets are sized
before they are built (mdl.model.addressing).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable

from mdl.dsl.expr.nodes import Binary, Bool, Call, Constant, ExprError, Node, Num, Ref, Registers, Str, Swap, Unary
from mdl.model.addressing import AddressError, address_range, address_run, match_address, whole_number
from mdl.model.layout import MAX_ADDRESS

REGISTER_FUNCTIONS = (
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
    "ieee754_32",
    "ieee754_64",
    "utf8",
    "hexstring",
    "eui48",
    "ipv4addr",
    "ipv6addr",
    "enum",
    "bitset",
    "bitsetbit",
)
FUNCTIONS = REGISTER_FUNCTIONS + ("concat", "boolean", "swapbytes", "swapendian")
_FUNCTION_SET = frozenset(FUNCTIONS)
_NUMBER = re.compile(r"[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?")
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_HEXWORD = re.compile(r"0[xX]([0-9A-Fa-f]{1,4})(?![0-9A-Za-z])")
_HEX_KEY = re.compile(r"0[xX][0-9A-Fa-f]+\s*->")
_INTEGER = re.compile(r"(-?)(?:0[xX]([0-9A-Fa-f]+)|([0-9]+))")
_COUNT = re.compile(r"[0-9]+")
_SPACE = re.compile(r"\s*")
MAX_DEPTH = 64  # levels of nesting; Toolkit expressions use a handful
LONG_MAX = 2**63 - 1


class FieldIndex:
    """A block's field ids by their leading identifier, longest first: a field matches where the
    expression's identifier is its leading one (built once per block, not once per expression)."""

    def __init__(self, fields: Iterable[str]):
        self.by_lead: dict[str, list[str]] = {}
        for field_id in sorted(set(fields), key=len, reverse=True):
            m = _IDENT.match(field_id)
            if m:  # one that starts otherwise ('%RH') can never be named where an identifier starts
                self.by_lead.setdefault(m.group(0), []).append(field_id)


class Parser:
    def __init__(self, text: str, fields: Iterable[str] | FieldIndex = ()):
        self.text = text
        self.pos = 0
        self.fields = fields if isinstance(fields, FieldIndex) else FieldIndex(fields)
        self.depth = 0
        self.listed = 0  # registers listed by all register sets so far

    # -- helpers
    def error(self, message: str, pos: int | None = None) -> ExprError:
        return ExprError(message, (self.pos if pos is None else pos) + 1)

    def ws(self) -> None:
        if self.pos < len(self.text) and self.text[self.pos].isspace():
            self.pos = self._space_end(self.pos)

    def _space_end(self, pos: int) -> int:
        end = _SPACE.match(self.text, pos)
        assert end is not None  # \s* matches everywhere
        return end.end()

    def peek(self) -> str:
        """The next character that is not a space ('' at the end), skipping the spaces before it (ws,
        written out: the parser's most frequent call)."""
        text, pos = self.text, self.pos
        if pos >= len(text):
            return ""
        ch = text[pos]
        if not ch.isspace():
            return ch
        self.pos = pos = self._space_end(pos)
        return text[pos] if pos < len(text) else ""

    def expect(self, ch: str) -> None:
        if self.peek() != ch:
            found = repr(self.text[self.pos]) if self.pos < len(self.text) else "the end"
            raise self.error(f"expected '{ch}' but found {found}")
        self.pos += 1

    def next_char(self, pos: int) -> str:
        """The first character at or after pos that is not a space ('' at the end)."""
        end = self._space_end(pos)
        return self.text[end : end + 1]

    def descend(self, pos: int | None = None) -> None:
        """One level deeper; refused past MAX_DEPTH. The caller restores self.depth when done."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise self.error(f"the expression nests more than {MAX_DEPTH} levels deep", pos)

    # -- grammar
    def parse(self) -> Node:
        if not self.text.strip():
            raise self.error("the expression is empty", 0)
        node = self.additive()
        if self.peek():
            raise self.error(f"unexpected '{self.text[self.pos]}'")
        return node

    def additive(self) -> Node:
        depth = self.depth
        left = self.multiplicative()
        op = self.peek()
        while op in ("+", "-"):
            start = self.pos
            self.descend()
            self.pos += 1
            left = Binary(start + 1, op, left, self.multiplicative())
            op = self.peek()
        self.depth = depth
        return left

    def multiplicative(self) -> Node:
        depth = self.depth
        left = self.unary()
        while True:
            ch = self.peek()
            if ch in ("*", "/") and ch:
                start = self.pos
                self.descend()
                self.pos += 1
                left = Binary(start + 1, ch, left, self.unary())
            elif ch == "(":  # implicit multiplication: 5(3), (5.5)(3.3)
                self.descend()
                left = Binary(self.pos + 1, "*", left, self.power())
            else:
                self.depth = depth
                return left

    def unary(self) -> Node:
        ch = self.peek()
        if ch in ("-", "+") and ch:
            start = self.pos
            self.descend()
            self.pos += 1
            arg = self.unary()
            self.depth -= 1
            return arg if ch == "+" else Unary(start + 1, "-", arg)
        return self.power()

    def power(self) -> Node:
        base = self.primary()
        if self.peek() == "^":
            start = self.pos
            self.descend()
            self.pos += 1
            exponent = self.unary()
            self.depth -= 1
            return Binary(start + 1, "^", base, exponent)
        return base

    def primary(self) -> Node:
        ch = self.peek()
        start = self.pos
        if not ch:
            raise self.error("the expression ends too early")
        if ch == "(":
            self.descend()
            self.pos += 1
            node = self.additive()
            self.expect(")")
            self.depth -= 1
            return node
        if "0" <= ch <= "9" or (ch == "." and _NUMBER.match(self.text, self.pos + 1)):  # _NUMBER's first digit
            return self.number()
        if ch == "'":
            return Str(start + 1, self.string())
        if ch == '"':
            raise self.error('a register constant "0x..." is only allowed inside a function such as int16(...)')
        m = _IDENT.match(self.text, self.pos)
        if m:
            word = m.group(0)
            after = self.pos + len(word)
            lower = word.lower()
            if lower in _FUNCTION_SET and self.next_char(after) == "(":
                self.pos = after
                return self.call(lower, start)
            # the identifier a field id begins with is the whole of `word` (field ids may hold
            # spaces: 'Boolean Value'), so only the fields it leads can match here
            for field_id in self.fields.by_lead.get(word, ()):
                end = self.pos + len(field_id)
                if self.text.startswith(field_id, self.pos) and not (
                    end < len(self.text) and (self.text[end].isalnum() or self.text[end] == "_")
                ):
                    self.pos = end
                    return Ref(start + 1, field_id)
            if lower in ("true", "false"):
                self.pos = after
                return Bool(start + 1, lower == "true")
            follows = self.next_char(after)
            if follows == ":":
                raise self.error("registers are only allowed inside a function such as int16(...)", start)
            if follows == "(":
                raise self.error(f"unknown function '{word}'", start)
            raise self.error(f"unknown field '{word}'", start)
        raise self.error(f"unexpected '{ch}'")

    def number(self) -> Num:
        start = self.pos
        m = _NUMBER.match(self.text, self.pos)
        if not m:
            raise self.error("malformed number")
        self.pos = m.end()
        if self.pos < len(self.text) and (self.text[self.pos].isalpha() or self.text[self.pos] in ":#"):
            raise self.error("registers are only allowed inside a function such as int16(...)", start)
        if m.group(1) or m.group(2):
            value = float(m.group(0))
            if math.isinf(value):
                raise self.error("this number is too large for a double", start)
            return Num(start + 1, value)
        digits = m.group(0).lstrip("0") or "0"
        if len(digits) > len(str(LONG_MAX)) or int(digits) > LONG_MAX:
            raise self.error("this integer does not fit in 64 bits (write a decimal point for a double)", start)
        return Num(start + 1, int(digits))

    def string(self) -> str:
        self.expect("'")
        end = self.text.find("'", self.pos)
        if end < 0:
            raise self.error("unterminated string", self.pos - 1)
        value = self.text[self.pos : end]
        self.pos = end + 1
        return value

    # -- registers
    def address(self) -> tuple[str, int, int]:
        """(table, wire address, position) of the address at the current position."""
        self.ws()
        try:
            found = match_address(self.text, self.pos)
        except AddressError as exc:
            raise self.error(str(exc)) from None
        if not found:
            raise self.error("expected a register address (hr:N, ir:N, c:N, di:N, 4xN, 40001, 400001)")
        table, address, end = found
        start = self.pos
        self.pos = end
        return table, address, start

    def run(self, table: str, first: int, where: int) -> range:
        """The addresses from `first` given by a following `#n` or `..b` (just `first` otherwise)."""
        try:
            if self.peek() == "#":
                self.pos += 1
                self.ws()
                m = _COUNT.match(self.text, self.pos)
                if not m:
                    raise self.error("expected a register count after '#'")
                self.pos = m.end()
                return address_run(first, whole_number(m.group(0), "register count"))
            if self.text.startswith("..", self.pos):
                self.pos += 2
                table2, last, where2 = self.address()
                if table2 != table:
                    raise self.error("a register range mixes register tables", where2)
                return address_range(first, last)
        except AddressError as exc:
            raise self.error(str(exc), where) from None
        return range(first, first + 1)

    def registers(self) -> Node:
        """A register argument: a register set, a constant "0x..", or swapbytes/swapendian(...)."""
        ch = self.peek()
        start = self.pos
        if ch == '"':
            self.pos += 1
            end = self.text.find('"', self.pos)
            if end < 0:
                raise self.error("unterminated register constant", start)
            words = []
            for word in re.finditer(r"\S+", self.text[self.pos : end]):
                if not _HEXWORD.fullmatch(word.group(0)):
                    raise self.error(f"'{word.group(0)}' is not a register value like 0x1234", self.pos + word.start())
                words.append(int(word.group(0), 16))
            if not words:
                raise self.error("empty register constant", start)
            self.pos = end + 1
            return Constant(start + 1, words)
        m = _IDENT.match(self.text, self.pos)
        if m and m.group(0).lower() in ("swapbytes", "swapendian"):
            self.descend()
            self.pos = m.end()
            self.expect("(")
            inner = self.registers()
            self.expect(")")
            self.depth -= 1
            return Swap(start + 1, m.group(0).lower(), inner)
        table: str | None = None
        addresses: list[int] = []
        while True:
            t, first, where = self.address()
            if table and t != table:
                raise self.error("the registers mix register tables", where)
            table = t
            run = self.run(t, first, where)
            self.listed += len(run)
            if self.listed > MAX_ADDRESS + 1:  # a register set lists each at most once, and sets rarely repeat
                raise self.error(f"the expression lists more than {MAX_ADDRESS + 1} registers", where)
            addresses += run
            if self.peek() != ",":
                break
            self.pos += 1
        assert table is not None  # the loop reads at least one address
        if len(set(addresses)) != len(addresses):
            raise self.error("a register is listed twice", start)
        if sorted(addresses) != list(range(min(addresses), min(addresses) + len(addresses))):
            raise self.error("the registers must be consecutive, without gaps", start)
        return Registers(start + 1, table, addresses)

    def call(self, name: str, start: int) -> Node:
        self.descend(start)
        self.expect("(")
        node = Call(start + 1, name)
        if name == "concat":
            node.args.append(self.additive())
            while self.peek() == ",":
                self.pos += 1
                node.args.append(self.additive())
        elif name in ("swapbytes", "swapendian"):
            raise self.error(f"{name}(...) gives registers: use it inside a function such as int16(...)", start)
        elif name == "boolean":
            self.boolean_args(node)
        else:
            node.args.append(self.registers())
            self.register_options(node)
        self.expect(")")
        self.depth -= 1
        return node

    def boolean_args(self, node: Call) -> None:
        save = self.pos, self.depth, self.listed
        try:
            node.args.append(self.registers())
        except ExprError:
            self.pos, self.depth, self.listed = save
            node.args.append(self.additive())
        if self.peek() == ";":
            self.pos += 1
            false_text = self.string_arg()
            self.expect(";")
            node.labels = (false_text, self.string_arg())

    def register_options(self, node: Call) -> None:
        """`; NI words`, `; N -> 'text'` and `; bit` after the registers of a function."""
        while self.peek() == ";":
            self.pos += 1
            self.ws()
            part_start = self.pos
            hex_key = _HEX_KEY.match(self.text, self.pos)
            if _HEXWORD.match(self.text, self.pos) and not hex_key:
                group = []
                while True:
                    self.ws()
                    m = _HEXWORD.match(self.text, self.pos)
                    if not m:
                        break
                    group.append(int(m.group(1), 16))
                    self.pos = m.end()
                node.not_implemented.append(group)
                continue
            value = self.integer()
            if self.peek() == "-" and self.text.startswith("->", self.pos):
                self.pos += 2
                if value in node.mapping:
                    raise self.error(f"value {value} is mapped twice", part_start)
                if not -LONG_MAX - 1 <= value <= LONG_MAX:  # every target compares int64 values
                    raise self.error(
                        f"mapped value {value} is outside int64 ({-LONG_MAX - 1}..{LONG_MAX})"
                        + (f": as 64 bits, write {value - 2**64}" if value > LONG_MAX else ""),
                        part_start,
                    )
                node.mapping[value] = self.string_arg()
            else:
                node.bit = value

    def integer(self) -> int:
        """A mapping key or bit number: decimal or 0x hex, optionally negative, within 64 bits."""
        m = _INTEGER.match(self.text, self.pos)
        if not m:
            raise self.error("expected a 'not implemented' value (0x...), a mapping (N -> 'text') or a bit number")
        base = 16 if m.group(2) else 10
        digits = (m.group(2) or m.group(3)).lstrip("0") or "0"
        if len(digits) > (16 if base == 16 else 20) or int(digits, base) >= 2**64:
            raise self.error("this value does not fit in 64 bits")
        self.pos = m.end()
        return -int(digits, base) if m.group(1) else int(digits, base)

    def string_arg(self) -> str:
        if self.peek() != "'":
            raise self.error("expected a text in single quotes")
        return self.string()


def parse(text: str, fields: Iterable[str] | FieldIndex = ()) -> Node:
    return Parser(text, fields).parse()
