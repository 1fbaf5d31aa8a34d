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
@click.argument("files", nargs=-1, type=INPUT)
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
@click.option(
    "--inventory",
    type=INPUT,
    metavar="FLEET.yaml|FLEET.csv",
    help="Instead of FILES: check a fleet's inventory (docs/fleet.md, Inventory), every mistake at its FILE:LINE.",
)
@fail_on_warning_option
def validate(files: tuple[Path, ...], version: str, profile: str | None, inventory: Path | None) -> None:
    """Validate MDL files (- for stdin) against the XSD and the semantic rules; or a fleet's inventory
    (--inventory): its ids, descriptions, profiles, connections and lines, a line per device (exit 0) or
    every mistake as FILE:LINE: error: ... (exit 1).

    \b
    Example:
      mdl validate examples/temco_tstat/temco_tstat.xml examples/discovery/em100.xml
      mdl validate examples/temco_tstat/temco_tstat.xml --schema 1.0
      mdl validate examples/profiles/meter_a.xml --profile meter
      mdl validate --inventory examples/fleet/site.yml
      mdl validate --inventory examples/fleet/site.csv
    """
    from mdl.formats.mdl import validate_file

    if inventory is not None:
        from click.core import ParameterSource

        from mdl.cli.inventory import validate_inventory

        given = click.get_current_context().get_parameter_source("version") is not ParameterSource.DEFAULT
        if files or profile is not None or given:
            raise click.UsageError("--inventory checks the inventory's devices: leave out FILES, --profile, --schema")
        sys.exit(validate_inventory(inventory))
    if not files:
        raise click.UsageError("missing FILES: give the files to validate (- for stdin), or --inventory FILE")
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
@click.option(
    "--as",
    "as_",
    type=click.Choice(["tm"], case_sensitive=False),
    help="tm: the profile as a W3C WoT Thing Model (JSON-LD), which `mdl export --to wot --profile NAME` links.",
)
def profiles(name: str | None, fmt: str, as_: str | None) -> None:
    """List the profiles mdl ships, or show one profile's roles (a shipped NAME or your own FILE.yaml).

    \b
    Examples:
      mdl profiles
      mdl profiles meter
      mdl profiles meter --format json
      mdl profiles meter --as tm
    """
    from mdl.profiles.load import load_profile
    from mdl.profiles.report import listing, roles_json, roles_table

    if as_ is not None:
        if name is None:
            raise click.UsageError("--as tm writes one profile's Thing Model: give its NAME or FILE.yaml")
        if click.get_current_context().get_parameter_source("fmt") is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError("--as tm writes the Thing Model (JSON-LD): it takes no --format")
        from mdl.exports.wot_tm import profile_thing_model

        click.echo(profile_thing_model(load_profile(name)), nl=False)
        return
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
