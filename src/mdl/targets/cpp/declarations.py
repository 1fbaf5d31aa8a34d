"""The per-function parts of a C++ driver's header (<stem>.h), printed with Python strings: the
members of <Class>Values and the read_<name> and write_<name> each class declares. A loop of Jinja
over 10,000 functions cost some 2.5 times these (templates/device.h.j2 keeps the file's skeleton)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mdl.targets.cpp.emit import CppFunction


def value_param(t: str) -> str:
    """The parameter of a write of a value of type t, up to its name: a text by const reference."""
    return "const std::string &" if t == "std::string" else t + " "


def values_members(functions: Iterable[CppFunction]) -> str:
    """The members of <Class>Values, each readable function's value with its comment, as lines."""
    return "".join([f"    /** {f.about} */\n    {f.rt} {f.ident}{{}};\n" for f in functions if f.readable])


def function_members(functions: Iterable[CppFunction]) -> str:
    """The declarations of the read_<name> and write_<name> of functions, each after a blank line
    and its comment; a function that reads or writes through a shared read_<k>_ or write_<j>_ has
    its one call defined inline. Without the trailing line break (the template places it)."""
    out: list[str] = []
    for f in functions:
        if f.readable:
            if f.reader is not None:
                table, start = f.runs[0][:2]
                out.append(
                    f"\n    /** Read {f.about} */\n    [[nodiscard]] int read_{f.ident}({f.rt} *out) "
                    f"{{ return read_{f.reader}_({table}, {start}, out); }}\n"
                )
            else:
                out.append(f"\n    /** Read {f.about} */\n    [[nodiscard]] int read_{f.ident}({f.rt} *out);\n")
        if f.writable:
            param = value_param(f.t)
            if f.writer is not None:
                table, start = f.runs[0][:2]
                out.append(
                    f"\n    /** Write {f.about} */\n    [[nodiscard]] int write_{f.ident}({param}value) "
                    f"{{ return write_{f.writer}_({table}, {start}, value); }}\n"
                )
            else:
                out.append(f"\n    /** Write {f.about} */\n    [[nodiscard]] int write_{f.ident}({param}value);\n")
    return "".join(out).rstrip()
