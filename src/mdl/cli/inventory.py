"""`--inventory FILE` of `mdl validate` and `mdl read` (SPEC 15; docs/fleet.md, "Inventory"): the
inventory read and checked by mdl.device.fleet.inventory, its descriptions loaded as every command loads
one (their warnings printed once per file), and what `mdl validate --inventory` prints."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from mdl.cli.options import warning_refusal
from mdl.cli.printer import resolved_file, say
from mdl.diagnostics import MdlError

if TYPE_CHECKING:
    from mdl.device.fleet.inventory import Member


def load_members(path: Path) -> list[Member]:
    """The inventory's devices, each with its description loaded; its warnings said (with
    --fail-on-warning, they end the command). MdlError (exit 1) with every error at once otherwise."""
    from mdl.device.fleet.inventory import load_inventory

    members, warnings = load_inventory(path, resolved_file)
    for diag in warnings:
        say(diag)
    refusal = warning_refusal(warnings, path)
    if refusal is not None:
        raise MdlError(refusal)
    return members


def validate_inventory(path: Path) -> int:
    """`mdl validate --inventory FILE`: a line per device and the verdict (exit 0), or every error (exit 1)."""
    members = load_members(path)
    for member in members:
        click.echo(device_line(member))
    click.echo(f"{path}: valid inventory of {len(members)} device{'s' * (len(members) != 1)}")
    return 0


def device_line(member: Member) -> str:
    """`ID: NAME (DESCRIPTION) on CONNECTION unit U, every S s[, profile P][, tags k=v;...]`."""
    entry = member.entry
    extra = f", profile {entry.profile}" if entry.profile else ""
    if entry.tags:
        extra += ", tags " + ";".join(f"{key}={value}" for key, value in entry.tags.items())
    return (
        f"{entry.id}: {member.resolved.device.name} ({entry.written['description']}) on {entry.connection} "
        f"unit {entry.unit}, every {entry.interval:g} s{extra}"
    )
