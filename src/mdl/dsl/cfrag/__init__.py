"""The C fragment subset (SPEC section 2.4, docs/fragments.md): check, translate, run.

One token stream (lexer) feeds one typed parser; its statements are what every target prints:
the Python translation (pyemit, run here by `compile_read`/`compile_write` and copied into
generated Python drivers) and the C99/C++17 functions (cemit) generated C and C++ drivers call.

    fragment = compile_fragment(code, nregs, reading=True)    # FragmentError (with .col) if refused
    fragment.python_lines()                                   # Python: r1..rn, arg bound before them
    c = fragment.c("c++")                                     # a CFragment
    c.function("frag_read_temperature")                       # int NAME(const uint16_t *r, double *out)
    helpers_source([c, ...], "c++")                           # the mdl_frag_ helpers they call
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import TYPE_CHECKING, Any

from mdl.dsl.cfrag.lexer import FragmentError
from mdl.dsl.cfrag.parser import MAX_DEPTH, Statement, parse
from mdl.dsl.cfrag.pyemit import FALLIBLE, HELPERS_SOURCE, helpers_namespace, statement
from mdl.records import record

if TYPE_CHECKING:
    from mdl.dsl.cfrag.cemit import INCLUDES, CFragment, Dialect, helpers_source

_C_EMITTER = ("INCLUDES", "CFragment", "helpers_source")  # from cemit when first asked for (the C targets)


def __getattr__(name: str) -> Any:
    # the C emitter is imported only by what prints C or C++: `mdl read` of a fragment runs the Python one
    if name in _C_EMITTER:
        from mdl.dsl.cfrag import cemit

        value = getattr(cemit, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mdl.dsl.cfrag' has no attribute {name!r}")


__all__ = [
    "FALLIBLE",
    "HELPERS_SOURCE",
    "INCLUDES",
    "MAX_DEPTH",
    "CFragment",
    "Dialect",
    "Fragment",
    "FragmentError",
    "check",
    "compile_fragment",
    "compile_read",
    "compile_write",
    "helpers_source",
    "python_body",
]

ReadFragment = Callable[[list[int]], float]  # registers r1..rn -> arg
WriteFragment = Callable[[float], list[int]]  # arg -> registers r1..rn


@record
class Fragment:
    """A checked fragment: its statements (compound assignments written out), for a function of
    `nregs` registers, read (registers -> arg) or written (arg -> registers)."""

    statements: tuple[Statement, ...]
    nregs: int
    reading: bool

    def python_lines(self) -> list[str]:
        """Python lines computing the fragment; r1..rn and arg must be bound before them.
        They raise ZeroDivisionError or FloatingPointError where C's errno is EDOM, OverflowError
        where it is ERANGE (docs/fragments.md)."""
        return [statement(*stmt) for stmt in self.statements]

    def c(self, dialect: Dialect) -> CFragment:
        """The fragment as a C99 or C++17 function (see CFragment)."""
        from mdl.dsl.cfrag.cemit import CFragment

        return CFragment(self.statements, self.nregs, self.reading, dialect)


@cache
def compile_fragment(code: str, nregs: int, reading: bool) -> Fragment:
    """The checked fragment, or FragmentError naming the offending token and its column."""
    return Fragment(tuple(parse(code, nregs)), nregs, reading)


def check(code: str, nregs: int) -> list[Statement]:
    """Parsed statements, or FragmentError naming the offending token."""
    return list(compile_fragment(code, nregs, True).statements)


def python_body(code: str, nregs: int) -> list[str]:
    """Python lines computing the fragment; r1..rn and arg must be bound before them."""
    return compile_fragment(code, nregs, True).python_lines()


@cache
def _compile(code: str, nregs: int, reading: bool) -> Callable[..., Any]:
    """The fragment as a Python function: a ReadFragment when reading, else a WriteFragment."""
    regs = [f"r{i + 1}" for i in range(nregs)]
    if reading:
        head = ["def _fragment(r):", f"    {', '.join(regs)}, = r", "    arg = 0.0"]
        tail = ["    return arg"]
    else:
        head = ["def _fragment(arg):", f"    {', '.join(regs)}, = [0] * {nregs}"]
        tail = [f"    return [{', '.join(regs)}]"]
    src = "\n".join(head + ["    " + line for line in python_body(code, nregs)] + tail)
    ns = dict(helpers_namespace())
    exec(compile(src, "<mdl fragment>", "exec"), ns)
    fragment: Callable[..., Any] = ns["_fragment"]
    return fragment


def compile_read(code: str, nregs: int) -> ReadFragment:
    """registers -> arg, with the semantics of docs/fragments.md (ArithmeticError where C fails)."""
    return _compile(code, nregs, True)


def compile_write(code: str, nregs: int) -> WriteFragment:
    """arg -> registers, with the semantics of docs/fragments.md (ArithmeticError where C fails)."""
    return _compile(code, nregs, False)
