"""The `mdl` group: every command gets -q/--quiet; an MdlError becomes its diagnostics and exit status;
the collector and pymodbus's logger set for a command-line run."""

from __future__ import annotations

import contextlib
import gc
import importlib
import logging
import sys
from collections.abc import Iterator
from typing import Any

import click

from mdl import __version__
from mdl.cli import GC_THRESHOLDS
from mdl.cli.options import quiet_option
from mdl.cli.printer import fail
from mdl.diagnostics import MdlError


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


# each command's module, imported when the command is asked for (a one-shot `mdl read` imports neither the
# converters nor the exporters; `mdl --help` imports them all, for their one-line help)
COMMANDS = {
    "csv2xml": "mdl.cli.convert",
    "import": "mdl.cli.convert",
    "export": "mdl.cli.convert",
    "gen": "mdl.cli.gen",
    "validate": "mdl.cli.validate",
    "profiles": "mdl.cli.validate",
    "test": "mdl.cli.scenarios",
    "sim": "mdl.cli.live",
    "read": "mdl.cli.live",
    "write": "mdl.cli.live",
    "serve": "mdl.cli.live",
    "discover": "mdl.cli.survey",
    "probe": "mdl.cli.survey",
    "capture": "mdl.cli.survey",
    "examples": "mdl.cli.examples",
}


class Group(click.Group):
    def add_command(self, cmd: click.Command, name: str | None = None) -> None:
        if not any(param.name == "quiet" for param in cmd.params):
            cmd.params.append(quiet_option())
        super().add_command(cmd, name)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(self.commands) | set(COMMANDS))

    def every_command(self) -> dict[str, click.Command]:
        """Each command by name, every module imported (help, completion and the tests' checks)."""
        ctx = click.Context(self)
        return {name: cmd for name in self.list_commands(ctx) if (cmd := self.get_command(ctx, name)) is not None}

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self.commands and cmd_name in COMMANDS:
            importlib.import_module(COMMANDS[cmd_name])  # its module registers it on `main`
        return self.commands.get(cmd_name)

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
