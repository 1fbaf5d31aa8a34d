"""Parse and type-check a fragment: statements `target op= expression;` over r1..rn and arg.

The result is a list of typed trees. Types follow C on x86-64 (LP64): int and unsigned are 32
bits, long and unsigned long 64; small casts convert and then promote to int.
Nodes: ("num", type, value) ("var", type, name) ("cast", type, target, node)
("unary", type, op, node) ("bin", type, op, left, right, optype) ("cond", type, c, a, b).
"""

from __future__ import annotations

import re
import struct
from typing import Literal, TypeAlias

from mdl.cfrag.lexer import FragmentError, Token, tokenize

IntType: TypeAlias = tuple[int, bool]  # (bits, signed)
CastTarget: TypeAlias = IntType | Literal["float", "double"]

# typed trees; the second item is the expression type: int, unsigned, long, ulong, float or double
NumNode: TypeAlias = tuple[Literal["num"], str, int | float]
VarNode: TypeAlias = tuple[Literal["var"], str, str]
CastNode: TypeAlias = tuple[Literal["cast"], str, CastTarget, "CNode"]
UnaryNode: TypeAlias = tuple[Literal["unary"], str, str, "CNode"]
BinNode: TypeAlias = tuple[Literal["bin"], str, str, "CNode", "CNode", str | None]  # last: operand type
CondNode: TypeAlias = tuple[Literal["cond"], str, "CNode", "CNode", "CNode"]
CNode: TypeAlias = NumNode | VarNode | CastNode | UnaryNode | BinNode | CondNode
Statement: TypeAlias = tuple[str, str, CNode]  # (target, assignment operator, value)

# cast name -> (bits, signed) for integers, or "float"/"double"
CASTS: dict[str, CastTarget] = {
    "int8_t": (8, True), "uint8_t": (8, False), "int16_t": (16, True), "uint16_t": (16, False),
    "int32_t": (32, True), "uint32_t": (32, False), "int64_t": (64, True), "uint64_t": (64, False),
    "int": (32, True), "unsigned": (32, False), "float": "float", "double": "double",
}
# integer expression types: name -> (bits, signed)
INT_TYPES: dict[str, IntType] = {"int": (32, True), "unsigned": (32, False), "long": (64, True), "ulong": (64, False)}
ASSIGN_OPS = ("=", "+=", "-=", "*=", "/=", "%=", "<<=", ">>=", "&=", "|=", "^=")
BINARY_PREC = [
    ("||",), ("&&",), ("|",), ("^",), ("&",), ("==", "!="), ("<", ">", "<=", ">="), ("<<", ">>"),
    ("+", "-"), ("*", "/", "%"),
]
_REG = re.compile(r"r([1-9][0-9]*)")


def int_type_of(bits: int, signed: bool) -> str:
    """The type a value of a cast has once promoted in an expression."""
    if bits < 32:
        return "int"
    if bits == 32:
        return "int" if signed else "unsigned"
    return "long" if signed else "ulong"


def arith_type(a: str, b: str) -> str:
    if "double" in (a, b):
        return "double"
    if "float" in (a, b):
        return "float"
    (ab, asg), (bb, bsg) = INT_TYPES[a], INT_TYPES[b]
    if asg == bsg:
        return a if ab >= bb else b
    (sb, st), (ub, ut) = ((ab, a), (bb, b)) if asg else ((bb, b), (ab, a))
    if ub >= sb:
        return ut
    return st  # a 64-bit signed type holds every 32-bit unsigned value


def _literal(tok: Token) -> NumNode:
    text = tok.text
    low = text.lower()
    is_hex = low.startswith("0x")
    is_float = not is_hex and any(c in low for c in ".e") or (not is_hex and low.endswith("f"))
    if is_float:
        if low.endswith("l") or "u" in low:
            raise FragmentError(f"float suffix in '{text}' is not supported (use f or none)", tok.col)
        single = low.endswith("f")
        value = float(low.rstrip("f"))
        if single:  # a float literal is rounded to single precision where it stands
            value = struct.unpack("<f", struct.pack("<f", value))[0]
        return ("num", "float" if single else "double", value)
    digits = low.rstrip("ul")
    suffix = low[len(digits):]
    if suffix not in ("", "u", "l", "ul", "lu", "ll", "ull", "llu"):
        raise FragmentError(f"malformed suffix in '{text}'", tok.col)
    if not is_hex and len(digits) > 1 and digits.startswith("0"):
        raise FragmentError(f"octal literal '{text}' is not supported", tok.col)
    value = int(digits, 16 if is_hex else 10)
    unsigned, long_ = "u" in suffix, "l" in suffix
    candidates: list[str] = []
    if not long_:
        candidates += ["unsigned"] if unsigned else (["int", "unsigned"] if is_hex else ["int"])
    candidates += ["ulong"] if unsigned else (["long", "ulong"] if is_hex else ["long"])
    for t in candidates:
        bits, signed = INT_TYPES[t]
        if value < (1 << (bits - 1 if signed else bits)):
            return ("num", t, value)
    raise FragmentError(f"integer literal '{text}' is too large", tok.col)


class _Parser:
    def __init__(self, src: str, nregs: int):
        self.toks = tokenize(src)
        self.i = 0
        self.nregs = nregs

    def peek(self, k: int = 0) -> Token:
        return self.toks[min(self.i + k, len(self.toks) - 1)]

    def take(self) -> Token:
        tok = self.toks[self.i]
        self.i += 1
        return tok

    def expect(self, text: str) -> Token:
        tok = self.peek()
        if tok.text != text or tok.kind == "end":
            raise FragmentError(f"expected '{text}' but found {self.describe(tok)}", tok.col)
        return self.take()

    @staticmethod
    def describe(tok: Token) -> str:
        return "the end" if tok.kind == "end" else f"'{tok.text}'"

    def variable(self, tok: Token) -> VarNode:
        if tok.text == "arg":
            return ("var", "double", "arg")
        m = _REG.fullmatch(tok.text)
        if m:
            if int(m.group(1)) > self.nregs:
                raise FragmentError(
                    f"'{tok.text}' is past the function's {self.nregs} register(s)", tok.col
                )
            return ("var", "int", tok.text)
        if tok.text in CASTS:
            raise FragmentError(f"type '{tok.text}' is allowed only in a cast", tok.col)
        raise FragmentError(f"unknown identifier '{tok.text}'", tok.col)

    def statements(self) -> list[Statement]:
        out: list[Statement] = []
        while self.peek().kind != "end":
            if self.peek().text == ";":
                self.take()
                continue
            tok = self.peek()
            if tok.kind != "ident":
                raise FragmentError(f"a statement must assign to arg or rN, found {self.describe(tok)}", tok.col)
            target = self.variable(self.take())
            op = self.peek()
            if op.text not in ASSIGN_OPS or op.kind != "op":
                raise FragmentError(f"expected an assignment after '{tok.text}' but found {self.describe(op)}", op.col)
            self.take()
            value = self.expr()
            nxt = self.peek()
            if nxt.kind != "end" and nxt.text != ";":
                raise FragmentError(f"expected ';' but found {self.describe(nxt)}", nxt.col)
            out.append((target[2], op.text, value))
        if not out:
            raise FragmentError("the fragment has no statement", 1)
        return out

    def expr(self) -> CNode:
        cond = self.binary(0)
        if self.peek().text == "?" and self.peek().kind == "op":
            self.take()
            a = self.expr()
            self.expect(":")
            b = self.expr()
            return ("cond", arith_type(a[1], b[1]), cond, a, b)
        return cond

    def binary(self, level: int) -> CNode:
        if level == len(BINARY_PREC):
            return self.unary()
        left = self.binary(level + 1)
        while self.peek().kind == "op" and self.peek().text in BINARY_PREC[level]:
            op = self.take()
            right = self.binary(level + 1)
            left = self.make_binary(op, left, right)
        return left

    @staticmethod
    def make_binary(op: Token, left: CNode, right: CNode) -> BinNode:
        o = op.text
        if o in ("&&", "||"):
            return ("bin", "int", o, left, right, None)
        if o in ("<<", ">>", "%", "&", "|", "^"):
            for side in (left, right):
                if side[1] in ("float", "double"):
                    raise FragmentError(f"'{o}' needs integer operands", op.col)
        if o in ("<<", ">>"):
            return ("bin", left[1], o, left, right, left[1])
        optype = arith_type(left[1], right[1])
        result = "int" if o in ("==", "!=", "<", ">", "<=", ">=") else optype
        return ("bin", result, o, left, right, optype)

    def unary(self) -> CNode:
        tok = self.peek()
        if tok.kind == "op" and tok.text in ("-", "+", "~", "!"):
            self.take()
            node = self.unary()
            if tok.text == "!":
                return ("unary", "int", "!", node)
            if tok.text == "~" and node[1] in ("float", "double"):
                raise FragmentError("'~' needs an integer operand", tok.col)
            return ("unary", node[1], tok.text, node)
        if tok.text == "(" and self.peek(1).kind == "ident" and self.peek(1).text in CASTS:
            if self.peek(2).text == ")":
                self.take()
                name = self.take().text
                self.take()
                node = self.unary()
                target = CASTS[name]
                rtype = target if isinstance(target, str) else int_type_of(*target)
                return ("cast", rtype, target, node)
        return self.primary()

    def primary(self) -> CNode:
        tok = self.take()
        if tok.kind == "num":
            return _literal(tok)
        if tok.kind == "ident":
            if self.peek().text == "(":
                raise FragmentError(f"call to '{tok.text}' is not allowed", tok.col)
            return self.variable(tok)
        if tok.text == "(":
            node = self.expr()
            self.expect(")")
            return node
        raise FragmentError(f"unexpected {self.describe(tok)}", tok.col)


def parse(src: str, nregs: int) -> list[Statement]:
    """Statements of a fragment, each (target, op, typed tree); FragmentError if outside the subset."""
    reasons = {"#": "preprocessor lines", "\\": "backslashes", '"': "string literals",
               "'": "character literals", "{": "braces", "}": "braces"}
    for pos, ch in enumerate(src):
        if ch in reasons and not _inside_comment(src, pos):
            raise FragmentError(f"'{ch}' is not allowed ({reasons[ch]} are not part of the subset)", pos + 1)
    return _Parser(src, nregs).statements()


def _inside_comment(src: str, pos: int) -> bool:
    start = src.rfind("/*", 0, pos)
    return start >= 0 and src.find("*/", start) > pos
