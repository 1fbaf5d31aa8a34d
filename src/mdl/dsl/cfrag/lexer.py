"""The token stream of the C fragment subset (SPEC section 2.4, docs/fragments.md).

Every consumer of a fragment (the checker, the Python translation, the C and C++ emitters) works
from this stream, never from the text: a comment is dropped here and cannot reach generated code.
Only ASCII is read. Whitespace is space, tab, LF and CR; a `//` comment ends at LF or CR (so at
CRLF too). Other characters C or Python might take as a line break or as space (VT, FF, NEL,
U+2028, U+2029, ...) are refused wherever they stand, comments included.
"""

from __future__ import annotations

import re

from mdl.records import record


class FragmentError(ValueError):
    """A fragment outside the subset; `col` is the 1-based offset of the offending character in the fragment."""

    def __init__(self, message: str, col: int | None = None):
        super().__init__(message)
        self.col = col


@record
class Token:
    kind: str  # num | ident | op | end
    text: str
    col: int


PUNCT = sorted(
    """<<= >>= ++ -- += -= *= /= %= &= |= ^= << >> <= >= == != && || + - * / % & | ^ ~ ! ? : ( ) ; = < >""".split(),
    key=len,
    reverse=True,
)
SPACE = " \t\n\r"
LINE_ENDS = "\n\r"
# a C preprocessing number: what a C compiler takes as one token, valid or not (`0x1e+1`, `1.2.3`)
_PP_NUMBER = re.compile(r"\.?[0-9](?:[eEpP][+-]|[0-9A-Za-z_.])*", re.ASCII)
_IDENT = re.compile(r"[A-Za-z_][A-Za-z_0-9]*", re.ASCII)
# what a comment may hold: words, numbers, and punctuation that cannot spell a statement
_PLAIN_COMMENT = re.compile(r"[A-Za-z0-9 \t\r\n.,:!?%+\-*/<>()'\[\]]*", re.ASCII)
_REFUSED = {
    "#": "preprocessor lines",
    "\\": "backslashes",
    '"': "string literals",
    "'": "character literals",
    "{": "braces",
    "}": "braces",
}


def shown(ch: str) -> str:
    """A character as an error message shows it: printable ASCII as is, anything else escaped."""
    if " " <= ch <= "~":
        return ch
    return ch.encode("unicode_escape").decode("ascii") if ord(ch) > 0xFF else f"\\x{ord(ch):02x}"


def _comment_end(src: str, i: int) -> int:
    """The offset just past the comment that starts at i."""
    if src[i + 1] == "*":
        end = src.find("*/", i + 2)
        if end < 0:
            raise FragmentError("unterminated comment", i + 1)
        body, after = src[i + 2 : end], end + 2
    else:
        ends = [pos for pos in (src.find(c, i + 2) for c in LINE_ENDS) if pos >= 0]
        after = min(ends, default=len(src))
        body = src[i + 2 : after]
    if not _PLAIN_COMMENT.fullmatch(body):
        bad = next(j for j, c in enumerate(body) if not _PLAIN_COMMENT.fullmatch(c))
        raise FragmentError(
            f"a comment may hold only words, numbers and plain punctuation, "
            f"not '{shown(body[bad])}' (it could hide code)",
            i + 3 + bad,
        )
    return after


def tokenize(src: str) -> list[Token]:
    """The tokens of `src`, comments dropped, ending with an `end` token; FragmentError at the first
    character outside the subset."""
    tokens: list[Token] = []
    i = 0
    while i < len(src):
        ch = src[i]
        if ch in SPACE:
            i += 1
        elif src.startswith(("/*", "//"), i):
            i = _comment_end(src, i)
        elif (m := _PP_NUMBER.match(src, i)) is not None:
            tokens.append(Token("num", m.group(0), i + 1))
            i = m.end()
        elif m := _IDENT.match(src, i):
            tokens.append(Token("ident", m.group(0), i + 1))
            i = m.end()
        else:
            op = next((p for p in PUNCT if src.startswith(p, i)), None)
            if op is None:
                reason = f" ({_REFUSED[ch]} are not part of the subset)" if ch in _REFUSED else ""
                raise FragmentError(f"character '{shown(ch)}' is not allowed{reason}", i + 1)
            tokens.append(Token("op", op, i + 1))
            i += len(op)
    tokens.append(Token("end", "", len(src) + 1))
    return tokens
