"""The Modbus Schema Toolkit expression language (seed 002, SPEC section 7).

parser.py turns text into a tree (errors carry the column); lower.py type-checks it and lowers
it to a list of simple operations (the expression step of the value IR); pyemit.py prints them as
straight-line Python, which `mdl read` and `mdl test` run and Python drivers carry; each C-family
target prints them itself (mdl.targets.cpp.expressions, mdl.targets.c.expressions).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mdl.dsl.expr.nodes import ExprError

__all__ = ["ExprError"]


def __getattr__(name: str) -> Any:
    # ExprError from nodes.py when first asked for: importing mdl.dsl.expr.fields (the runtime does, for
    # python_function) then builds none of the expression tree's classes
    if name == "ExprError":
        from mdl.dsl.expr.nodes import ExprError

        return ExprError
    raise AttributeError(f"module 'mdl.dsl.expr' has no attribute {name!r}")
