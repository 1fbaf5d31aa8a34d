"""The one printer of the commands: diagnostics and notes on stderr (notes not under -q), `wrote
FILE`, and an MdlError as its diagnostics and exit status."""

from __future__ import annotations

import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import click

from mdl.cli.options import is_quiet, warning_refusal
from mdl.diagnostics import Diagnostic, MdlError
from mdl.fileio import STDIO_ARG

if TYPE_CHECKING:
    from mdl.resolver import ResolvedDevice


def say(diag: Diagnostic | str) -> None:
    """A diagnostic on stderr, or a note's own text; notes not under -q/--quiet."""
    if (isinstance(diag, str) or diag.severity == "note") and is_quiet():
        return
    click.echo(str(diag), err=True)


def wrote(path: Path | str) -> None:
    """`wrote FILE` on stderr, as every command that writes a file says (SPEC 1); not under -q."""
    say(f"wrote {path}")


def fail(exc: MdlError) -> NoReturn:
    for diag in exc.diagnostics:
        click.echo(str(diag), err=True)
    sys.exit(exc.exit_code)


def report_warnings(warnings: Iterable[Diagnostic], file: Path) -> None:
    """Print each warning once; with --fail-on-warning, any of them ends the command (exit 1)."""
    warnings = list(warnings)
    for diag in warnings:
        say(diag)
    refusal = warning_refusal(warnings, file)
    if refusal is not None:
        raise MdlError(refusal)


def resolved_file(path: Path, fmt: str | None = None) -> ResolvedDevice:
    """The description in `path` through the resolve step, its warnings printed (every command that
    reads one calls this once per file): MdlError with every error otherwise."""
    from mdl.formats.loading import load_resolved

    resolved = load_resolved(path, fmt)
    report_warnings(resolved.warnings, path)
    return resolved


def emit_text(text: str, output: Path | None) -> None:
    """`text` to standard output (no -o, or -o -) or to the file, written whole or not at all."""
    from mdl.fileio import write_atomic

    if output is None or str(output) == STDIO_ARG:
        click.echo(text, nl=False)
    else:
        write_atomic(output, text)
        wrote(output)
