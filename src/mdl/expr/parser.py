"""Parse an expression. Field references may contain spaces ('Boolean Value'): they are matched
against the field ids of the block, longest first.

Precedence, loosest first: + -, then * / and implicit multiplication `5(3)`, then unary minus,
then ^ (right-associative, binding tightest), then primaries.
"""

from __future__ import annotations

import re

from mdl.addressing import AddressError, match_address
from mdl.expr.nodes import Binary, Bool, Call, Constant, ExprError, Node, Num, Ref, Registers, Str, Swap, Unary

REGISTER_FUNCTIONS = ("int16", "uint16", "int32", "uint32", "int64", "uint64", "ieee754_32", "ieee754_64",
                      "utf8", "hexstring", "eui48", "ipv4addr", "ipv6addr", "enum", "bitset", "bitsetbit")
FUNCTIONS = REGISTER_FUNCTIONS + ("concat", "boolean", "swapbytes", "swapendian")
_NUMBER = re.compile(r"\d+(\.\d+)?([eE][-+]?\d+)?")
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_HEXWORD = re.compile(r"0[xX]([0-9A-Fa-f]{1,4})(?![0-9A-Za-z])")


class Parser:
    def __init__(self, text: str, fields=()):
        self.text = text
        self.pos = 0
        self.fields = sorted(set(fields), key=len, reverse=True)

    # -- helpers
    def error(self, message: str, pos: int | None = None) -> ExprError:
        return ExprError(message, (self.pos if pos is None else pos) + 1)

    def ws(self) -> None:
        while self.pos < len(self.text) and self.text[self.pos].isspace():
            self.pos += 1

    def peek(self) -> str:
        self.ws()
        return self.text[self.pos] if self.pos < len(self.text) else ""

    def expect(self, ch: str) -> None:
        if self.peek() != ch:
            found = repr(self.text[self.pos]) if self.pos < len(self.text) else "the end"
            raise self.error(f"expected '{ch}' but found {found}")
        self.pos += 1

    # -- grammar
    def parse(self) -> Node:
        if not self.text.strip():
            raise self.error("the expression is empty", 0)
        node = self.additive()
        if self.peek():
            raise self.error(f"unexpected '{self.text[self.pos]}'")
        return node

    def additive(self) -> Node:
        left = self.multiplicative()
        while self.peek() in ("+", "-") and self.peek():
            start = self.pos
            op = self.text[self.pos]
            self.pos += 1
            left = Binary(start + 1, op, left, self.multiplicative())
        return left

    def multiplicative(self) -> Node:
        left = self.unary()
        while True:
            ch = self.peek()
            if ch in ("*", "/") and ch:
                start = self.pos
                self.pos += 1
                left = Binary(start + 1, ch, left, self.unary())
            elif ch == "(":  # implicit multiplication: 5(3), (5.5)(3.3)
                left = Binary(self.pos + 1, "*", left, self.power())
            else:
                return left

    def unary(self) -> Node:
        ch = self.peek()
        if ch in ("-", "+") and ch:
            start = self.pos
            self.pos += 1
            arg = self.unary()
            return arg if ch == "+" else Unary(start + 1, "-", arg)
        return self.power()

    def power(self) -> Node:
        base = self.primary()
        if self.peek() == "^":
            start = self.pos
            self.pos += 1
            return Binary(start + 1, "^", base, self.unary())
        return base

    def primary(self) -> Node:
        ch = self.peek()
        start = self.pos
        if not ch:
            raise self.error("the expression ends too early")
        if ch == "(":
            self.pos += 1
            node = self.additive()
            self.expect(")")
            return node
        if ch.isdigit() or (ch == "." and self.text[self.pos + 1: self.pos + 2].isdigit()):
            m = _NUMBER.match(self.text, self.pos)
            if not m:
                raise self.error("malformed number")
            self.pos = m.end()
            text = m.group(0)
            if self.pos < len(self.text) and (self.text[self.pos].isalpha() or self.text[self.pos] in ":#"):
                raise self.error("registers are only allowed inside a function such as int16(...)", start)
            return Num(start + 1, float(text) if (m.group(1) or m.group(2)) else int(text))
        if ch == "'":
            return Str(start + 1, self.string())
        if ch == '"':
            raise self.error("a register constant \"0x...\" is only allowed inside a function such as int16(...)")
        m = _IDENT.match(self.text, self.pos)
        if m:
            word = m.group(0)
            after = self.pos + len(word)
            rest = self.text[after:].lstrip()
            if word.lower() in FUNCTIONS and rest.startswith("("):
                self.pos = after
                return self.call(word.lower(), start)
            for field_id in self.fields:
                end = self.pos + len(field_id)
                if self.text.startswith(field_id, self.pos) and not (
                        end < len(self.text) and (self.text[end].isalnum() or self.text[end] == "_")):
                    self.pos = end
                    return Ref(start + 1, field_id)
            if word.lower() in ("true", "false"):
                self.pos = after
                return Bool(start + 1, word.lower() == "true")
            if rest.startswith(":"):
                raise self.error("registers are only allowed inside a function such as int16(...)", start)
            if rest.startswith("(") :
                raise self.error(f"unknown function '{word}'", start)
            raise self.error(f"unknown field '{word}'", start)
        raise self.error(f"unexpected '{ch}'")

    def string(self) -> str:
        self.expect("'")
        end = self.text.find("'", self.pos)
        if end < 0:
            raise self.error("unterminated string", self.pos - 1)
        value = self.text[self.pos:end]
        self.pos = end + 1
        return value

    # -- registers
    def address(self):
        self.ws()
        try:
            found = match_address(self.text, self.pos)
        except AddressError as exc:
            raise self.error(str(exc)) from None
        if not found:
            raise self.error("expected a register address (hr:N, ir:N, c:N, di:N, 4xN, 40001, 400001)")
        table, address, end = found
        if address > 65535:
            raise self.error(f"address {address} is over 65535")
        start = self.pos
        self.pos = end
        return table, address, start

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
            for m in re.finditer(r"\S+", self.text[self.pos:end]):
                if not _HEXWORD.fullmatch(m.group(0)):
                    raise self.error(f"'{m.group(0)}' is not a register value like 0x1234", self.pos + m.start())
                words.append(int(m.group(0), 16))
            if not words:
                raise self.error("empty register constant", start)
            self.pos = end + 1
            return Constant(start + 1, words)
        m = _IDENT.match(self.text, self.pos)
        if m and m.group(0).lower() in ("swapbytes", "swapendian"):
            self.pos = m.end()
            self.expect("(")
            inner = self.registers()
            self.expect(")")
            return Swap(start + 1, m.group(0).lower(), inner)
        table = None
        addresses: list[int] = []
        while True:
            t, first, where = self.address()
            run = [first]
            if self.peek() == "#":
                self.pos += 1
                self.ws()
                m = re.compile(r"\d+").match(self.text, self.pos)
                if not m or int(m.group(0)) < 1:
                    raise self.error("expected a register count after '#'")
                self.pos = m.end()
                run = list(range(first, first + int(m.group(0))))
            elif self.text.startswith("..", self.pos):
                self.pos += 2
                t2, last, where2 = self.address()
                if t2 != t:
                    raise self.error("a register range mixes register tables", where2)
                if last < first:
                    raise self.error("a register range ends before it starts", where2)
                run = list(range(first, last + 1))
            if table and t != table:
                raise self.error("the registers mix register tables", where)
            table = t
            addresses += run
            if self.peek() != ",":
                break
            self.pos += 1
        if len(set(addresses)) != len(addresses):
            raise self.error("a register is listed twice", start)
        if sorted(addresses) != list(range(min(addresses), min(addresses) + len(addresses))):
            raise self.error("the registers must be consecutive, without gaps", start)
        if any(a > 65535 for a in addresses):
            raise self.error("a register address is over 65535", start)
        return Registers(start + 1, table, addresses)

    def call(self, name: str, start: int) -> Node:
        self.expect("(")
        node = Call(start + 1, name)
        if name == "concat":
            node.args.append(self.additive())
            while self.peek() == ",":
                self.pos += 1
                node.args.append(self.additive())
            self.expect(")")
            return node
        if name in ("swapbytes", "swapendian"):
            raise self.error(f"{name}(...) gives registers: use it inside a function such as int16(...)", start)
        if name == "boolean":
            save = self.pos
            try:
                node.args.append(self.registers())
            except ExprError:
                self.pos = save
                node.args.append(self.additive())
            if self.peek() == ";":
                self.pos += 1
                false_text = self.string_arg()
                self.expect(";")
                node.labels = (false_text, self.string_arg())
            self.expect(")")
            return node
        node.args.append(self.registers())
        while self.peek() == ";":
            self.pos += 1
            self.ws()
            part_start = self.pos
            hex_key = re.compile(r"0[xX][0-9A-Fa-f]+\s*->").match(self.text, self.pos)
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
            m = re.compile(r"-?0[xX][0-9A-Fa-f]+|-?\d+").match(self.text, self.pos)
            if not m:
                raise self.error("expected a 'not implemented' value (0x...), a mapping (N -> 'text') or a bit number")
            self.pos = m.end()
            if self.peek() == "-" and self.text.startswith("->", self.pos):
                self.pos += 2
                key = int(m.group(0), 0)
                if key in node.mapping:
                    raise self.error(f"value {key} is mapped twice", part_start)
                node.mapping[key] = self.string_arg()
            else:
                node.bit = int(m.group(0), 0)
        self.expect(")")
        return node

    def string_arg(self) -> str:
        if self.peek() != "'":
            raise self.error("expected a text in single quotes")
        return self.string()


def parse(text: str, fields=()) -> Node:
    return Parser(text, fields).parse()
