"""`mdl examples [DIR]`: the bundled examples, which every `--help` example names (`examples/...`),
copied into DIR (default: ./examples), so that an installed mdl (pipx, a wheel) runs its own help as
written from the folder that holds them."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import click

from mdl.cli.app import main
from mdl.cli.printer import wrote
from mdl.diagnostics import error
from mdl.resources import resource_dir


@main.command()
@click.argument("directory", type=click.Path(file_okay=False, path_type=Path), default="examples", required=False)
def examples(directory: Path) -> None:
    """Copy the examples that every --help names into DIRECTORY (default: ./examples, where the --help
    examples look for them). A DIRECTORY that exists is left as it is (an error, exit 1).

    \b
    Example:
      mdl examples copied-examples
      $ mdl examples && mdl sim examples/temco_tstat/temco_tstat.xml --port 5020
    """
    source = resource_dir("examples")
    if directory.exists() or directory.is_symlink():
        raise error(f"{directory} exists already: nothing is copied over it (give a new DIRECTORY)")
    parent = directory.parent
    if not parent.is_dir():
        raise error(f"{parent}: no such directory")
    # copied beside its place and renamed into it: an interrupted copy leaves no half of it
    with tempfile.TemporaryDirectory(dir=parent, prefix=".mdl-examples-") as tmp:
        staged = Path(tmp) / "examples"
        shutil.copytree(source, staged, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        count = sum(1 for p in staged.rglob("*") if p.is_file())
        staged.rename(directory)
    wrote(f"{directory} ({count} files)")
