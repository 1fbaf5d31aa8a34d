"""The `mdl` group: every command gets -q/--quiet; an MdlError becomes its diagnostics and exit status;
the collector and pymodbus's logger set for a command-line run."""

from __future__ import annotations

import contextlib
import gc
import logging
import sys
from collections.abc import Iterator
from typing import Any

import click

from mdl import __version__
from mdl.cli.options import quiet_option
from mdl.cli.printer import fail
from mdl.diagnostics import MdlError

# A model of 10,000 functions is some 10^6 small objects that live until the command ends: with
# Python's default thresholds (700, 10, 10) the collector walks all of them again and again while
# they are built (a third of `mdl gen`'s time in resolve). Collections stay on, just rarer (`mdl gen`
# pauses them: collector_paused).
GC_THRESHOLDS = (100_000, 50, 100)


@contextlib.contextmanager
def collector_paused() -> Iterator[None]:
    """No cyclic garbage collection while `mdl gen` runs: what it builds lives until it ends, and each
    collection walked 100,000 young objects that were all still in use (5 to 8 collections, 7 % of
    generating 10,000 functions), while the cycles left unfreed add some 4 % to its peak memory. The
    collector's state is restored after (the tests run commands in one process)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class Group(click.Group):
    def add_command(self, cmd: click.Command, name: str | None = None) -> None:
        if not any(param.name == "quiet" for param in cmd.params):
            cmd.params.append(quiet_option())
        super().add_command(cmd, name)

    def invoke(self, ctx: click.Context) -> Any:
        gc.set_threshold(*GC_THRESHOLDS)
        # pymodbus logs every failed exchange itself; the commands say each failure once, their own way
        # (the library, mdl.api, leaves logging to its user)
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
        try:
            return super().invoke(ctx)
        except MdlError as exc:
            fail(exc)
        except KeyboardInterrupt:
            click.echo("mdl: interrupted", err=True)
            sys.exit(130)


def run() -> None:
    """The `mdl` program (the console script and `python -m mdl`): `main`, and then, whatever its
    outcome, the objects it leaves are frozen out of the collector. The interpreter's last
    collections would otherwise walk a large model's 10^6 objects once more only to free memory
    the process gives back as it exits (a fifth of `mdl gen --lang all` at 10,000 functions).
    Every file a command writes is closed before it returns; tests call `main` itself."""
    try:
        main()
    finally:
        gc.freeze()


@click.group(cls=Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="mdl")
def main() -> None:
    """mdl: vendor register tables -> MDL (Modbus Definition Language) -> drivers.

    \b
    Example, end to end:
      mdl csv2xml examples/temco_tstat/temco_tstat.ini
      mdl validate examples/temco_tstat/temco_tstat.xml
      mdl gen examples/temco_tstat/temco_tstat.xml --lang python -o out/
      mdl sim examples/temco_tstat/temco_tstat.xml --port 5020 &
      mdl read examples/temco_tstat/temco_tstat.xml --host 127.0.0.1 --port 5020

    The files under examples/ that every --help names come with mdl: `mdl examples` copies them here.

    \b
    Shell completion of commands, options and file names: add your shell's line to its startup file.
      bash (~/.bashrc):                    eval "$(_MDL_COMPLETE=bash_source mdl)"
      zsh (~/.zshrc):                      eval "$(_MDL_COMPLETE=zsh_source mdl)"
      fish (~/.config/fish/config.fish):   _MDL_COMPLETE=fish_source mdl | source
    """
