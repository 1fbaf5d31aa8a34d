"""Identifiers from names (SPEC section 3)."""

from __future__ import annotations

import keyword
import re
import unicodedata

CPP_KEYWORDS = frozenset(
    """alignas alignof and and_eq asm auto bitand bitor bool break case catch char char8_t char16_t
    char32_t class compl concept const consteval constexpr constinit const_cast continue co_await
    co_return co_yield decltype default delete do double dynamic_cast else enum explicit export
    extern false float for friend goto if inline int long mutable namespace new noexcept not not_eq
    nullptr operator or or_eq private protected public register reinterpret_cast requires return
    short signed sizeof static static_assert static_cast struct switch template this thread_local
    throw true try typedef typeid typename union unsigned using virtual void volatile wchar_t while
    xor xor_eq""".split()
)
PY_KEYWORDS = frozenset(keyword.kwlist) | frozenset(keyword.softkwlist)
# lowercase macros of the C/C++ standard headers, and names the generated classes use themselves
RESERVED = frozenset("""errno assert stdin stdout stderr offsetof setjmp va_arg va_start va_end va_copy
    unix linux all""".split())


def identifier(name: str) -> str:
    folded = unicodedata.normalize("NFKD", name).encode("ascii", "ignore").decode("ascii")
    ident = re.sub(r"[^a-z0-9]+", "_", folded.lower()).strip("_")
    if not ident:
        ident = "unnamed"
    if ident[0].isdigit():
        ident = "f_" + ident
    if ident in CPP_KEYWORDS or ident in PY_KEYWORDS or ident in RESERVED:
        ident += "_"
    return ident


def unique_identifiers(names) -> list[str]:
    """Identifiers for names in order; a collision with an earlier one gets _2, _3, ..."""
    seen: set[str] = set()
    out = []
    for name in names:
        base = identifier(name)
        ident, n = base, 1
        while ident in seen:
            n += 1
            ident = f"{base}_{n}"
        seen.add(ident)
        out.append(ident)
    return out


def camel(ident: str) -> str:
    cls = "".join(part[:1].upper() + part[1:] for part in ident.split("_") if part)
    return cls if cls and not cls[0].isdigit() else "Device" + cls
