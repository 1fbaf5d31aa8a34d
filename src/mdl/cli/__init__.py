"""The `mdl` command (SPEC section 1), the only importer of click: a module per group of commands
(convert, gen, validate, live, survey, scenarios, examples), the options they share (options.py) and the one
printer of their diagnostics (printer.py). Each command parses its options, calls the library, prints
what it says and maps an error to the exit status."""

from mdl.cli import convert, examples, gen, live, scenarios, survey, validate  # noqa: F401  (each registers its commands)
from mdl.cli.app import main, run

__all__ = ["main", "run"]
