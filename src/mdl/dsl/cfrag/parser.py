"""Parse and type-check a fragment: statements `target op= expression;` over r1..rn and arg.

The result is a list of typed trees (mdl.dsl.cfrag.tree), compound assignments written out and
checked as `target = target op value`. Besides the subset's grammar and types, the checker
refuses what a C compiler would reject or warn about: constant expressions that overflow a signed
type or have no value (`2147483647 + 1`, `(int)1e10`), division by a constant zero, shifts by a
constant count outside the type (`r1 << 40`), floating literals out of range (`1e400`, `1e-400`),
a constant assignment to a register outside -32768..65535 (`r1 = 70000`), and nesting deeper
than MAX_DEPTH.
"""

from __future__ import annotations

import math
import re
from typing import NamedTuple

from mdl.dsl.cfrag.lexer import FragmentError, Token, tokenize
from mdl.dsl.cfrag.pyemit import emit, evaluate, store
from mdl.dsl.cfrag.tree import (
    CASTS,
    COMPARISONS,
    FLOATS,
    INT_TYPES,
    CNode,
    NumNode,
    Statement,
    VarNode,
    arith_type,
    int_range,
    int_type_of,
    round_to_float,
)

__all__ = ["CASTS", "INT_TYPES", "MAX_DEPTH", "Statement", "arith_type", "int_type_of", "parse"]

MAX_DEPTH = 40  # levels of an expression tree: parentheses, operators, casts
ASSIGN_OPS = ("=", "+=", "-=", "*=", "/=", "%=", "<<=", ">>=", "&=", "|=", "^=")
BINARY_PREC = [
    ("||",),
    ("&&",),
    ("|",),
    ("^",),
    ("&",),
    ("==", "!="),
    ("<", ">", "<=", ">="),
    ("<<", ">>"),
    ("+", "-"),
    ("*", "/", "%"),
]
INTEGER_ONLY = ("<<", ">>", "%", "&", "|", "^")
_REG = re.compile(r"r([1-9][0-9]*)", re.ASCII)
_INT_LITERAL = re.compile(r"(0[xX][0-9a-fA-F]+|[0-9]+)([uU]?(?:ll|LL|[lL])?|(?:ll|LL|[lL])[uU])", re.ASCII)
_FLOAT_LITERAL = re.compile(r"((?:[0-9]+\.[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[0-9]+[eE][+-]?[0-9]+)([fF]?)", re.ASCII)
Value = int | float


class Expr(NamedTuple):
    """A node while parsing: its tree, its depth, and its value where it is a constant expression."""

    node: CNode
    depth: int
    const: Value | None


def _short(text: str) -> str:
    """A token as a message shows it: at most 30 characters."""
    return text if len(text) <= 30 else text[:27] + "..."


def _float_literal(tok: Token, digits: str, single: bool) -> NumNode:
    from decimal import Decimal  # here and Fraction: the exact value of a float literal, few fragments have one
    from fractions import Fraction

    exact = Decimal(digits)
    kind = "float" if single else "double"
    if exact == 0:
        return ("num", kind, 0.0)
    if exact.adjusted() > 308:
        raise FragmentError(f"floating literal '{_short(tok.text)}' is out of range for {kind}", tok.col)
    if exact.adjusted() < -400:
        raise FragmentError(f"floating literal '{_short(tok.text)}' is too small: it would be 0", tok.col)
    value = round_to_float(Fraction(exact)) if single else float(exact)
    if math.isinf(value):
        raise FragmentError(f"floating literal '{_short(tok.text)}' is out of range for {kind}", tok.col)
    if value == 0:
        raise FragmentError(f"floating literal '{_short(tok.text)}' is too small: it would be 0", tok.col)
    return ("num", kind, value)


def literal(tok: Token) -> NumNode:
    """A number token as C types and reads it (C99 on LP64); FragmentError if C would refuse it."""
    text = tok.text
    if m := _FLOAT_LITERAL.fullmatch(text):
        return _float_literal(tok, m.group(1), bool(m.group(2)))
    m = _INT_LITERAL.fullmatch(text)
    if m is None:
        raise FragmentError(f"malformed number '{_short(text)}'", tok.col)
    digits, suffix = m.group(1), m.group(2).lower()
    is_hex = digits[:2].lower() == "0x"
    if not is_hex and len(digits) > 1 and digits.startswith("0"):
        raise FragmentError(f"octal literal '{_short(text)}' is not supported", tok.col)
    if len((digits[2:] if is_hex else digits).lstrip("0")) > (16 if is_hex else 20):  # before int() reads it
        raise FragmentError(f"integer literal '{_short(text)}' is too large", tok.col)
    value = int(digits, 16 if is_hex else 10)
    unsigned, long_ = "u" in suffix, "l" in suffix
    candidates: list[str] = []
    if not long_:
        candidates += ["unsigned"] if unsigned else (["int", "unsigned"] if is_hex else ["int"])
    candidates += ["ulong"] if unsigned else (["long", "ulong"] if is_hex else ["long"])
    for t in candidates:
        if value <= int_range(t)[1]:
            return ("num", t, value)
    raise FragmentError(f"integer literal '{_short(text)}' is too large", tok.col)


def _constant(node: CNode, col: int) -> Value:
    """The value of a constant expression; FragmentError where it has none."""
    try:
        value: Value = evaluate(emit(node))
    except ArithmeticError as exc:
        raise FragmentError(f"the constant expression {exc}", col) from None
    return value


def _signed_overflow(op: str, t: str, a: Value, b: Value | None) -> str | None:
    """What is wrong with a constant signed operation that C leaves undefined (and compilers warn
    about): its exact result leaves the type, or it shifts a negative value left. None if nothing."""
    if t not in ("int", "long") or not isinstance(a, int) or isinstance(b, float):
        return None
    bits = INT_TYPES[t][0]
    exact: int | None = None
    if b is None:
        exact = -a if op == "-" else None
    elif op in ("+", "-", "*"):
        exact = a + b if op == "+" else a - b if op == "-" else a * b
    elif op in ("/", "%"):
        exact = -a if b == -1 else None  # the most negative value divided by -1
    elif op == "<<" and 0 <= b < bits:
        if a < 0:
            return f"shifts the negative value {a} left"
        if a << b >> bits:
            return f"overflows {t} ({a} << {b} needs more than {bits} bits)"
    low, high = int_range(t)
    if exact is not None and not low <= exact <= high:
        return f"overflows {t} ({exact})"
    return None


class _Parser:
    def __init__(self, src: str, nregs: int):
        self.toks = tokenize(src)
        self.i = 0
        self.nregs = nregs
        self.nesting = 0

    def peek(self, k: int = 0) -> Token:
        return self.toks[min(self.i + k, len(self.toks) - 1)]

    def take(self) -> Token:
        tok = self.toks[self.i]
        self.i += 1
        return tok

    def is_op(self, *texts: str) -> bool:
        tok = self.peek()
        return tok.kind == "op" and tok.text in texts

    def expect(self, text: str) -> Token:
        tok = self.peek()
        if tok.text != text or tok.kind != "op":
            raise FragmentError(f"expected '{text}' but found {self.describe(tok)}", tok.col)
        return self.take()

    @staticmethod
    def describe(tok: Token) -> str:
        return "the end" if tok.kind == "end" else f"'{_short(tok.text)}'"

    def variable(self, tok: Token) -> VarNode:
        if tok.text == "arg":
            return ("var", "double", "arg")
        m = _REG.fullmatch(tok.text)
        if m:
            if int(m.group(1)) > self.nregs:
                raise FragmentError(f"'{_short(tok.text)}' is past the function's {self.nregs} register(s)", tok.col)
            return ("var", "int", tok.text)
        if tok.text in CASTS:
            raise FragmentError(f"type '{tok.text}' is allowed only in a cast", tok.col)
        raise FragmentError(f"unknown identifier '{_short(tok.text)}'", tok.col)

    def statements(self) -> list[Statement]:
        out: list[Statement] = []
        while self.peek().kind != "end":
            if self.is_op(";"):
                self.take()
                continue
            out.append(self.statement())
            nxt = self.peek()
            if nxt.kind != "end" and not self.is_op(";"):
                raise FragmentError(f"expected ';' but found {self.describe(nxt)}", nxt.col)
        if not out:
            raise FragmentError("the fragment has no statement", 1)
        return out

    def statement(self) -> Statement:
        tok = self.peek()
        if tok.kind != "ident":
            raise FragmentError(f"a statement must assign to arg or rN, found {self.describe(tok)}", tok.col)
        target = self.variable(self.take())
        op = self.peek()
        if op.kind != "op" or op.text not in ASSIGN_OPS:
            raise FragmentError(
                f"expected an assignment after {self.describe(tok)} but found {self.describe(op)}", op.col
            )
        self.take()
        value = self.expr()
        if op.text != "=":  # `t op= v` is `t = t op v`, checked as such
            value = self.binary_node(Token("op", op.text[:-1], op.col), Expr(target, 1, None), value)
        if value.const is not None:
            try:
                evaluate(store(tok.text, value.node))
            except ArithmeticError as exc:
                raise FragmentError(f"the constant assignment {exc}", op.col) from None
        return (tok.text, "=", value.node)

    def nest(self, col: int) -> None:
        self.nesting += 1
        if self.nesting > MAX_DEPTH:
            raise FragmentError(f"the expression is nested more than {MAX_DEPTH} levels deep", col)

    def make(self, node: CNode, col: int, *operands: Expr) -> Expr:
        """An Expr for `node` built from `operands`: its depth checked, its value if it is constant."""
        depth = 1 + max((e.depth for e in operands), default=0)
        if depth > MAX_DEPTH:
            raise FragmentError(f"the expression is nested more than {MAX_DEPTH} levels deep", col)
        const = _constant(node, col) if operands and all(e.const is not None for e in operands) else None
        return Expr(node, depth, const)

    def expr(self) -> Expr:
        cond = self.binary(0)
        if not self.is_op("?"):
            return cond
        q = self.take()
        self.nest(q.col)
        a = self.expr()
        self.expect(":")
        b = self.expr()
        self.nesting -= 1
        return self.make(("cond", arith_type(a.node[1], b.node[1]), cond.node, a.node, b.node), q.col, cond, a, b)

    def binary(self, level: int) -> Expr:
        if level == len(BINARY_PREC):
            return self.unary()
        left = self.binary(level + 1)
        while self.is_op(*BINARY_PREC[level]):
            op = self.take()
            right = self.binary(level + 1)
            left = self.binary_node(op, left, right)
        return left

    def binary_node(self, op: Token, left: Expr, right: Expr) -> Expr:
        o, lt, rt = op.text, left.node[1], right.node[1]
        if o in INTEGER_ONLY and (lt in FLOATS or rt in FLOATS):
            raise FragmentError(f"'{o}' needs integer operands", op.col)
        if o in ("&&", "||"):
            node: CNode = ("bin", "int", o, left.node, right.node, None)
        elif o in ("<<", ">>"):
            node = ("bin", lt, o, left.node, right.node, lt)
            if right.const is not None and not 0 <= right.const < INT_TYPES[lt][0]:
                bits = INT_TYPES[lt][0]
                raise FragmentError(
                    f"shift count {right.const} is outside 0..{bits - 1} for a {bits}-bit operand", op.col
                )
        else:
            optype = arith_type(lt, rt)
            node = ("bin", "int" if o in COMPARISONS else optype, o, left.node, right.node, optype)
            if o in ("/", "%") and optype not in FLOATS and right.const == 0:
                raise FragmentError(f"'{o}' divides by the constant zero", op.col)
        if left.const is not None and right.const is not None:
            problem = _signed_overflow(o, node[1], left.const, right.const)
            if problem is not None:
                raise FragmentError(f"the constant expression {problem}", op.col)
        return self.make(node, op.col, left, right)

    def unary(self) -> Expr:
        tok = self.peek()
        if tok.kind == "op" and tok.text in ("-", "+", "~", "!"):
            self.take()
            self.nest(tok.col)
            inner = self.unary()
            self.nesting -= 1
            t = inner.node[1]
            if tok.text == "!":
                return self.make(("unary", "int", "!", inner.node), tok.col, inner)
            if tok.text == "~" and t in FLOATS:
                raise FragmentError("'~' needs an integer operand", tok.col)
            if tok.text == "-" and inner.const is not None:
                problem = _signed_overflow("-", t, inner.const, None)
                if problem is not None:
                    raise FragmentError(f"the constant expression {problem}", tok.col)
            return self.make(("unary", t, tok.text, inner.node), tok.col, inner)
        if tok.text == "(" and self.peek(1).kind == "ident" and self.peek(1).text in CASTS and self.peek(2).text == ")":
            self.take()
            target = CASTS[self.take().text]
            self.take()
            self.nest(tok.col)
            inner = self.unary()
            self.nesting -= 1
            rtype = target if isinstance(target, str) else int_type_of(*target)
            return self.make(("cast", rtype, target, inner.node), tok.col, inner)
        return self.primary()

    def primary(self) -> Expr:
        tok = self.take()
        if tok.kind == "num":
            node = literal(tok)
            return Expr(node, 1, node[2])
        if tok.kind == "ident":
            if self.is_op("("):
                raise FragmentError(f"call to '{_short(tok.text)}' is not allowed", tok.col)
            return Expr(self.variable(tok), 1, None)
        if tok.kind == "op" and tok.text == "(":
            self.nest(tok.col)
            inner = self.expr()
            self.expect(")")
            self.nesting -= 1
            return inner
        raise FragmentError(f"unexpected {self.describe(tok)}", tok.col)


def parse(src: str, nregs: int) -> list[Statement]:
    """Statements of a fragment, each (target, "=", typed tree); FragmentError if outside the subset."""
    return _Parser(src, nregs).statements()
