"""`mdl validate` and `mdl profiles`."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mdl.cli.app import main
from mdl.cli.options import INPUT, SCHEMAS, fail_on_warning_option, stdin_once, warning_refusal
from mdl.cli.printer import say
from mdl.diagnostics import EXIT_INVALID


@main.command()
@click.argument("files", nargs=-1, required=True, type=INPUT)
@click.option(
    "--schema",
    "version",
    type=SCHEMAS,
    default="1.0",
    show_default=True,
    help="Schema to validate against; 1.0 accepts every 0.9b document.",
)
@click.option(
    "--profile",
    metavar="NAME|FILE.yaml",
    help="Also say which of the profile's roles the device provides (exit 1 if a required one is missing).",
)
@fail_on_warning_option
def validate(files: tuple[Path, ...], version: str, profile: str | None) -> None:
    """Validate MDL files (- for stdin) against the XSD and the semantic rules.

    \b
    Example:
      mdl validate examples/temco_tstat/temco_tstat.xml examples/discovery/em100.xml
      mdl validate examples/temco_tstat/temco_tstat.xml --schema 1.0
      mdl validate examples/profiles/meter_a.xml --profile meter
    """
    from mdl.formats.mdl import validate_file

    stdin_once(files)
    chosen = None
    if profile is not None:
        from mdl.profiles.load import load_profile

        chosen = load_profile(profile)
    bad = False
    for path in files:
        device, diagnostics = validate_file(path, version)  # the XSD, then the resolve step
        refusal = warning_refusal(diagnostics, path)
        for diag in [*diagnostics, *([refusal] if refusal else [])]:
            say(diag)
        if device is None or any(d.severity == "error" for d in diagnostics) or refusal:
            bad = True
            continue
        used = device.extensions()
        if device.schema_version == "1.0":
            click.echo(f"{path}: valid MDL 1.0 (extensions: {', '.join(used) or 'none'})")
        else:
            click.echo(f"{path}: valid MDL 0.9b")
        if chosen is not None:
            from mdl.profiles.fit import fit
            from mdl.profiles.report import fit_diagnostics, fit_lines
            from mdl.resolver import resolve

            fitted = fit(chosen, resolve(device, str(path)))
            for line in fit_lines(str(path), fitted):
                click.echo(line)
            for diag in fit_diagnostics(str(path), fitted, {f.name: f for f in device.functions}):
                say(diag)
            bad = bad or not fitted.ok
    sys.exit(EXIT_INVALID if bad else 0)


@main.command()
@click.argument("name", required=False, metavar="[NAME|FILE.yaml]")
@click.option(
    "--format", "fmt", type=click.Choice(["table", "json"], case_sensitive=False), default="table", show_default=True
)
def profiles(name: str | None, fmt: str) -> None:
    """List the profiles mdl ships, or show one profile's roles (a shipped NAME or your own FILE.yaml).

    \b
    Examples:
      mdl profiles
      mdl profiles meter
      mdl profiles meter --format json
    """
    from mdl.profiles.load import load_profile
    from mdl.profiles.report import listing, roles_json, roles_table

    if name is None:
        if fmt == "json":
            import json

            from mdl.profiles.load import shipped

            click.echo(json.dumps(shipped()))
            return
        for line in listing():
            click.echo(line)
        return
    chosen = load_profile(name)
    if fmt == "json":
        click.echo(roles_json(chosen))
    else:
        for line in roles_table(chosen):
            click.echo(line)
