"""The `mdl` command (SPEC section 1), the only importer of click: a module per group of commands
(convert, gen, validate, live, survey, scenarios, examples; imported when their command is
asked for: app.COMMANDS), the options they share (options.py) and the one
printer of their diagnostics (printer.py). Each command parses its options, calls the library, prints
what it says and maps an error to the exit status."""

import gc

# A model of 10,000 functions is some 10^6 small objects that live until the command ends: with
# Python's default thresholds (700, 10, 10) the collector walks all of them again and again while
# they are built (a third of `mdl gen`'s time in resolve). Collections stay on, just rarer (`mdl gen`
# pauses them: app.collector_paused). Set here, before click and the commands' modules are imported (their
# classes and functions, which live until the command ends, are some 2 % of a one-shot `mdl read`'s work
# under the default thresholds), and again for each command the group runs (app.Group.invoke: the tests
# run commands in one process).
GC_THRESHOLDS = (100_000, 50, 100)
gc.set_threshold(*GC_THRESHOLDS)

from mdl.cli.app import main, run  # noqa: E402  # each command's module registers it when first asked for (app.COMMANDS)

__all__ = ["main", "run"]
