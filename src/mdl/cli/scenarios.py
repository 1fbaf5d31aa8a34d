"""`mdl test`: the test scenarios embedded in a description."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mdl.cli.app import main
from mdl.cli.options import INPUT, fail_on_warning_option, stdin_once
from mdl.cli.printer import resolved_file
from mdl.diagnostics import EXIT_INVALID


@main.command(name="test")
@click.argument("files", nargs=-1, required=True, type=INPUT)
@fail_on_warning_option
def test_(files: tuple[Path, ...]) -> None:
    """Run the test scenarios embedded in MDL 1.0 or Toolkit YAML files.

    Prints each failure and a last line `N passed, M failed`; exit 1 if any failed.

    \b
    Example:
      mdl test examples/toolkit_heat_pump/heat_pump.yaml examples/toolkit_inverter/inverter.yaml
    """
    from mdl.device.evaluate import Evaluator
    from mdl.device.server.scenarios import run_scenario

    stdin_once(files)
    passed = failed = 0
    loaded = [(path, resolved_file(path)) for path in files]  # every file checked before any scenario runs
    for path, resolved in loaded:
        device = resolved.device
        evaluator = Evaluator(resolved)  # compiled once for all of the file's scenarios
        for sc in device.tests:
            failures = run_scenario(evaluator, sc)
            for failure in failures:
                click.echo(f"{path}: {failure}")
            if failures:
                failed += 1
            else:
                passed += 1
    click.echo(f"{passed} passed, {failed} failed")
    sys.exit(EXIT_INVALID if failed else 0)
