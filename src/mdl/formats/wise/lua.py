"""The Lua column of a WISE-Agent register line, where it is plain arithmetic on `modbus_val`.

The agent runs `function Convert(modbus_val) return <column> end` on the decoded register value and
then multiplies by the line's precision. Where the column is numbers, `modbus_val`, `+ - * /`, unary
minus and parentheses, and the result is `a * modbus_val + b` with `a` not 0, it is a scaling MDL
holds as multiplier and offset (`affine`). Anything else (calls, `^`, `%`, comparisons, a `--` comment,
a product of `modbus_val` with itself) is not: MDL cannot apply it, so the reader keeps its text at the end
of the function's description (`kept_in_description`), where the writer finds it again (`kept_lua`) and
writes it back into the Lua column. The writer writes scaling back in the same form.
"""

from __future__ import annotations

import math
import re

from mdl.formats.wise.sections import LUA_VARIABLE

MAX_LENGTH = 200  # longer columns are not plain arithmetic as far as the reader is concerned
MAX_DEPTH = 32  # parentheses and unary minus, nested

_TOKEN = re.compile(
    r"\s*(?:(?P<num>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)|(?P<var>[A-Za-z_][A-Za-z_0-9]*)"
    r"|(?P<op>[-+*/()]))"
)

Affine = tuple[float, float]  # (a, b): a * modbus_val + b

KEPT = "(WISE Lua conversion, not applied: "  # opens the description's note of a Lua column MDL cannot apply


def kept_in_description(description: str, lua: str) -> str:
    """The description with the Lua column's text kept at its end: `Temp (WISE Lua conversion, not applied:
    math.floor(modbus_val/10))`."""
    return f"{description} {KEPT}{lua})"


def kept_lua(description: str | None) -> str | None:
    """The Lua text `kept_in_description` put at the end of a description, exactly; None where there is none.
    It is what follows the note's opening, up to the description's final `)`. Where the opening is there more
    than once (in the name or the Lua text itself), which one the note starts at is not known: see `kept_twice`."""
    if not description or not description.endswith(")"):
        return None
    at = description.rfind(KEPT)
    if at < 0:
        return None
    return description[at + len(KEPT) : -1] or None


def kept_twice(description: str | None) -> bool:
    """Whether the description holds the note's opening more than once: then no Lua text is taken from it."""
    return description is not None and description.count(KEPT) > 1


class _NotPlain(Exception):
    pass


def affine(text: str) -> Affine | None:
    """(a, b) where the Lua expression `text` is a * modbus_val + b with a != 0, all finite; else None."""
    if len(text) > MAX_LENGTH or "--" in text:  # `--` starts a Lua comment
        return None
    tokens = _tokens(text)
    if tokens is None:
        return None
    try:
        parser = _Parser(tokens)
        a, b = parser.expr(0)
        if parser.pos != len(tokens):
            return None
    except _NotPlain:
        return None
    if a == 0 or not (math.isfinite(a) and math.isfinite(b)):
        return None
    return a, b


def _tokens(text: str) -> list[str] | None:
    out: list[str] = []
    pos = 0
    text = text.rstrip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            return None
        if m.group("var") is not None and m.group("var") != LUA_VARIABLE:
            return None
        out.append(m.group(m.lastgroup or "op"))
        pos = m.end()
    return out


class _Parser:
    def __init__(self, tokens: list[str]):
        self.tokens, self.pos = tokens, 0

    def peek(self) -> str | None:
        return self.tokens[self.pos] if self.pos < len(self.tokens) else None

    def take(self) -> str:
        tok = self.peek()
        if tok is None:
            raise _NotPlain
        self.pos += 1
        return tok

    def expr(self, depth: int) -> Affine:
        if depth > MAX_DEPTH:
            raise _NotPlain
        left = self.term(depth)
        while self.peek() in ("+", "-"):
            sign = 1.0 if self.take() == "+" else -1.0
            a, b = self.term(depth)
            left = (left[0] + sign * a, left[1] + sign * b)
        return left

    def term(self, depth: int) -> Affine:
        left = self.unary(depth)
        while self.peek() in ("*", "/"):
            op = self.take()
            right = self.unary(depth)
            if op == "*":
                if left[0] != 0 and right[0] != 0:
                    raise _NotPlain  # modbus_val * modbus_val
                left = (left[0] * right[1] + right[0] * left[1], left[1] * right[1])
            else:
                if right[0] != 0 or right[1] == 0:
                    raise _NotPlain  # dividing by modbus_val, or by 0
                left = (left[0] / right[1], left[1] / right[1])
        return left

    def unary(self, depth: int) -> Affine:
        if self.peek() == "-":
            self.take()
            if depth + 1 > MAX_DEPTH:
                raise _NotPlain
            a, b = self.unary(depth + 1)
            return -a, -b
        return self.primary(depth)

    def primary(self, depth: int) -> Affine:
        tok = self.take()
        if tok == "(":
            inner = self.expr(depth + 1)
            if self.take() != ")":
                raise _NotPlain
            return inner
        if tok == LUA_VARIABLE:
            return 1.0, 0.0
        if tok[0].isdigit() or tok[0] == ".":
            return 0.0, float(tok)
        raise _NotPlain
