"""Tokens of the C fragment subset (SPEC section 2.4)."""

from __future__ import annotations

import re
from dataclasses import dataclass


class FragmentError(ValueError):
    def __init__(self, message: str, col: int | None = None):
        super().__init__(message)
        self.col = col


@dataclass(frozen=True)
class Token:
    kind: str  # num | ident | op | end
    text: str
    col: int


PUNCT = sorted(
    """<<= >>= ++ -- += -= *= /= %= &= |= ^= << >> <= >= == != && || + - * / % & | ^ ~ ! ? : ( ) ; = < >""".split(),
    key=len,
    reverse=True,
)
_NUMBER = re.compile(
    r"(0[xX][0-9a-fA-F]+[uUlL]*)|((?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?[fFuUlL]*)"
)
_IDENT = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")
_PLAIN_COMMENT = re.compile(r"[A-Za-z0-9 \t\r\n.,:!?%+\-*/<>()'\[\]]*")


def tokenize(src: str) -> list[Token]:
    tokens: list[Token] = []
    i = 0
    while i < len(src):
        ch = src[i]
        if ch in " \t\r\n":
            i += 1
            continue
        if src.startswith("/*", i) or src.startswith("//", i):
            end = src.find("*/", i + 2) if src[i + 1] == "*" else src.find("\n", i)
            if src[i + 1] == "*" and end < 0:
                raise FragmentError("unterminated comment", i + 1)
            end = len(src) if end < 0 else end
            body = src[i + 2 : end]
            if not _PLAIN_COMMENT.fullmatch(body):
                raise FragmentError("a comment that may hide code ('" + body.strip()[:30] + "')", i + 1)
            i = end + (2 if src[i + 1] == "*" else 0)
            continue
        m = _NUMBER.match(src, i)
        if m and (ch.isdigit() or (ch == "." and i + 1 < len(src) and src[i + 1].isdigit())):
            tokens.append(Token("num", m.group(0), i + 1))
            i = m.end()
            if i < len(src) and (src[i].isalnum() or src[i] in "_."):
                raise FragmentError(f"malformed number '{m.group(0)}{src[i]}'", i + 1)
            continue
        m = _IDENT.match(src, i)
        if m:
            tokens.append(Token("ident", m.group(0), i + 1))
            i = m.end()
            continue
        for p in PUNCT:
            if src.startswith(p, i):
                tokens.append(Token("op", p, i + 1))
                i += len(p)
                break
        else:
            shown = ch if ch.isprintable() else f"\\x{ord(ch):02x}"
            raise FragmentError(f"character '{shown}' is not allowed", i + 1)
    tokens.append(Token("end", "", len(src) + 1))
    return tokens
