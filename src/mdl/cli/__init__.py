"""The `mdl` command (SPEC section 1), the only importer of click: a module per group of commands
(convert, gen, validate, live, survey, scenarios, examples; imported when their command is
asked for: app.COMMANDS), the options they share (options.py) and the one
printer of their diagnostics (printer.py). Each command parses its options, calls the library, prints
what it says and maps an error to the exit status."""

from mdl.cli.app import main, run  # each command's module registers it when first asked for (app.COMMANDS)

__all__ = ["main", "run"]
