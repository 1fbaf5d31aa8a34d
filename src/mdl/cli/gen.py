"""`mdl gen`: drivers from a description (SPEC 5)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mdl import targets
from mdl.cli.app import collector_paused, main
from mdl.cli.options import INPUT, fail_on_warning_option
from mdl.cli.printer import resolved_file, say, wrote
from mdl.diagnostics import EXIT_INVALID
from mdl.fileio import STDIO_ARG


@main.command()
@click.argument("file", type=INPUT)
@click.option(
    "--lang",
    type=click.Choice([*targets.names(), "all"], case_sensitive=False),
    default="all",
    show_default=True,
    help="A registered target (" + "; ".join(targets.summaries()) + "), or all of them.",
)
@click.option(
    "-o",
    "--output-dir",
    "outdir",
    type=click.Path(path_type=Path),
    default=Path("."),
    show_default=True,
    help="Directory for the generated files.",
)
@click.option("--check", is_flag=True, help="Write nothing; exit 1 if any output would change.")
@click.option(
    "--profile",
    metavar="NAME|FILE.yaml",
    help="Also generate the profile's interface, implemented by the driver (docs/profiles.md).",
)
@fail_on_warning_option
def gen(file: Path, lang: str, outdir: Path, check: bool, profile: str | None) -> None:
    """Generate drivers for the registered targets (--lang) from MDL (or Toolkit YAML).

    Files are written only when their content changes (Makefile friendly), and all of a run's files
    or none: a failed run leaves the old ones as they were.

    \b
    Example:
      mdl gen examples/temco_tstat/temco_tstat.xml --lang all -o drivers/
      mdl gen examples/profiles/meter_a.xml --lang python --profile meter -o drivers/
    """
    if str(outdir) == STDIO_ARG:
        raise click.BadParameter("mdl gen writes several files: give a directory, not -", param_hint="'-o'")
    with collector_paused():
        _gen(file, lang, outdir, check, profile)


def _gen(file: Path, lang: str, outdir: Path, check: bool, profile: str | None) -> None:
    from mdl.fileio import all_or_none
    from mdl.targets import generate

    resolved = resolved_file(file)
    for note in targets.notes(resolved, file):
        say(note)
    interface = None
    if profile is not None:
        from mdl.targets.profile import prepare

        interface, said, resolved = prepare(profile, resolved, str(file))
        for note in said:
            say(note)
    with all_or_none():
        changed = generate(resolved, file, lang, outdir, check, interface)
    for path in changed:
        if check:
            click.echo(f"would change {path}", err=True)
        else:
            wrote(path)
    if check and changed:
        sys.exit(EXIT_INVALID)
