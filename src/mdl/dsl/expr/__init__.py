"""The Modbus Schema Toolkit expression language (seed 002, SPEC section 7).

parser.py turns text into a tree (errors carry the column); lower.py type-checks it and lowers
it to a list of simple operations (the expression step of the value IR); pyemit.py prints them as
straight-line Python, which `mdl read` and `mdl test` run and Python drivers carry; each C-family
target prints them itself (mdl.targets.cpp.expressions, mdl.targets.c.expressions).
"""

from mdl.dsl.expr.nodes import ExprError

__all__ = ["ExprError"]
