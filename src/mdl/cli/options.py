"""The options several commands share, in one place: input files (`-` is standard input), the
unit, -q/--quiet (every command), --fail-on-warning, and the CONNECTION options (SPEC 9)."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from mdl.diagnostics import Diagnostic
from mdl.fileio import STDIO_ARG, input_path, is_stdin

if TYPE_CHECKING:
    pass


SCHEMAS = click.Choice(["0.9b", "1.0"], case_sensitive=False)


STDOUT = Path(STDIO_ARG)


class InputFile(click.Path):
    """An input file; `-` is standard input, named `<stdin>` in messages. click checks nothing (no
    `exists`, no `readable`): the reader says what is wrong as `FILE: error: ...`, exit 1 (SPEC 1),
    a missing file and an unreadable one alike."""

    def __init__(self) -> None:
        super().__init__(path_type=Path, allow_dash=True, readable=False)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Path:
        return input_path(os.fsdecode(super().convert(value, param, ctx)))


INPUT = InputFile()


class InputOrTarget(click.Path):
    """An input file (INPUT), or a FILE@CONNECTION target of `mdl read` (kept as text: mdl.device.fleet parses it)."""

    def __init__(self) -> None:
        super().__init__(path_type=Path, allow_dash=True, readable=False)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Path | str:
        from mdl.device.fleet import looks_like_target

        if isinstance(value, str) and looks_like_target(value):
            return value
        return INPUT.convert(value, param, ctx)


def stdin_once(paths: Iterable[Path]) -> None:
    if sum(1 for path in paths if is_stdin(path)) > 1:
        raise click.UsageError("standard input (-) can be read only once")


QUIET = "mdl.quiet"


def _remember_quiet(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[QUIET] = ctx.meta.get(QUIET, False) or value


QUIET_HELP = "Print no notes, summary or progress: only warnings and errors."


def quiet_option() -> click.Option:
    """-q/--quiet, which Group gives every command (SPEC 1): notes, `wrote FILE` and progress go."""
    return click.Option(["-q", "--quiet"], is_flag=True, expose_value=False, callback=_remember_quiet, help=QUIET_HELP)


def is_quiet() -> bool:
    ctx = click.get_current_context(silent=True)
    return ctx is not None and bool(ctx.meta.get(QUIET) or ctx.params.get("quiet"))


FAIL_ON_WARNING = "mdl.fail_on_warning"


def _remember_fail_on_warning(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[FAIL_ON_WARNING] = value


fail_on_warning_option = click.option(
    "--fail-on-warning",
    is_flag=True,
    expose_value=False,
    callback=_remember_fail_on_warning,
    help="Exit 1, before doing anything, if reading the input gives any warning (they print either way).",
)


def warning_refusal(warnings: Iterable[Diagnostic], file: Path) -> Diagnostic | None:
    """With --fail-on-warning, the error that warnings about `file` make; else None."""
    n = sum(1 for d in warnings if d.severity == "warning")
    if n and click.get_current_context().meta.get(FAIL_ON_WARNING):
        return Diagnostic(str(file), None, None, f"{n} warning{'s' * (n != 1)} and --fail-on-warning")
    return None


unit_option = click.option(
    "--unit", type=click.IntRange(0, 255), default=1, show_default=True, help="Unit (device) id to talk to."
)
