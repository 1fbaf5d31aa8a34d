"""The C fragment subset of SPEC section 2.4: check, translate to Python, run."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from mdl.cfrag.lexer import FragmentError
from mdl.cfrag.parser import parse
from mdl.cfrag.pyemit import statement
from mdl.layout import layout
from mdl.model import Function

HELPERS_SOURCE = (Path(__file__).parent / "pyhelpers.py").read_text(encoding="utf-8")

__all__ = ["FragmentError", "check", "python_body", "compile_read", "compile_write", "HELPERS_SOURCE"]


def check(code: str, nregs: int):
    """Parsed statements, or FragmentError naming the offending token."""
    return parse(code, nregs)


def python_body(code: str, nregs: int) -> list[str]:
    """Python lines computing the fragment; r1..rn and arg must be bound before them."""
    return [statement(*stmt) for stmt in parse(code, nregs)]


def _namespace() -> dict:
    ns: dict = {}
    exec(compile(HELPERS_SOURCE, "<mdl fragment helpers>", "exec"), ns)
    return ns


@lru_cache(maxsize=None)
def _compile(code: str, nregs: int, reading: bool):
    regs = [f"r{i + 1}" for i in range(nregs)]
    if reading:
        head = ["def _fragment(r):", f"    {', '.join(regs)}, = r", "    arg = 0.0"]
        tail = ["    return arg"]
    else:
        head = ["def _fragment(arg):", f"    {', '.join(regs)}, = [0] * {nregs}"]
        tail = [f"    return [{', '.join(regs)}]"]
    src = "\n".join(head + ["    " + line for line in python_body(code, nregs)] + tail)
    ns = _namespace()
    exec(compile(src, "<mdl fragment>", "exec"), ns)
    return ns["_fragment"]


def compile_read(fn: Function):
    return _compile(fn.read_function_code, len(layout(fn).addresses), True)


def compile_write(fn: Function):
    func = _compile(fn.write_function_code, len(layout(fn).addresses), False)
    return lambda arg, _n: func(arg)
