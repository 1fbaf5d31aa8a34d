"""The C fragment subset of SPEC section 2.4: check, translate to Python, run."""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

from mdl.cfrag.lexer import FragmentError
from mdl.cfrag.parser import Statement, parse
from mdl.cfrag.pyemit import statement

HELPERS_SOURCE = (Path(__file__).parent / "pyhelpers.py").read_text(encoding="utf-8")

__all__ = ["FragmentError", "check", "python_body", "compile_read", "compile_write", "HELPERS_SOURCE"]

ReadFragment = Callable[[list[int]], float]  # registers r1..rn -> arg
WriteFragment = Callable[[float], list[int]]  # arg -> registers r1..rn


def check(code: str, nregs: int) -> list[Statement]:
    """Parsed statements, or FragmentError naming the offending token."""
    return parse(code, nregs)


def python_body(code: str, nregs: int) -> list[str]:
    """Python lines computing the fragment; r1..rn and arg must be bound before them."""
    return [statement(*stmt) for stmt in parse(code, nregs)]


def _namespace() -> dict[str, Any]:
    ns: dict[str, Any] = {}
    exec(compile(HELPERS_SOURCE, "<mdl fragment helpers>", "exec"), ns)
    return ns


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
    ns = _namespace()
    exec(compile(src, "<mdl fragment>", "exec"), ns)
    fragment: Callable[..., Any] = ns["_fragment"]
    return fragment


def compile_read(code: str, nregs: int) -> ReadFragment:
    return _compile(code, nregs, True)


def compile_write(code: str, nregs: int) -> WriteFragment:
    return _compile(code, nregs, False)
