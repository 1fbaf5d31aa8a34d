"""The Modbus Schema Toolkit expression language (seed 002, SPEC section 7).

parser.py turns text into a tree (errors carry the column); lower.py type-checks it and lowers
it to a list of simple operations; pyemit.py and cppemit.py print those operations as
straight-line Python and C++. `mdl read` and `mdl test` run the Python translation.
"""

from mdl.lang.expr.nodes import ExprError

__all__ = ["ExprError"]
