"""`mdl csv2xml --interactive`: the user picks each function's row from a numbered list (a
`convert.Chooser`; the conversion itself never asks)."""

from __future__ import annotations

import click

from mdl.formats.table.match import Candidate, Index, best
from mdl.formats.table.rows import ParsedRow

OPTIONS = 9  # rows offered per function


def choose_rows(functions: dict[str, list[str]], index: Index, rows: list[ParsedRow]) -> dict[str, Candidate]:
    """Each function's row as the user picks it on stderr (0 skips the function); a row is picked once."""
    chosen: dict[str, Candidate] = {}
    used: set[int] = set(range(len(rows), index.rows))  # the skipped rows: not to be chosen
    for name, phrases in functions.items():
        options = best(name, phrases, index, used, OPTIONS)
        click.echo(f"\nfunction '{name}': which row?", err=True)
        for n, c in enumerate(options, 1):
            pr = rows[c.row_index]
            text = " ".join(pr.function.description.split())[:70]
            click.echo(f"  {n}. [{c.score}] line {pr.row.line}: {text}", err=True)
        click.echo("  0. skip this function", err=True)
        pick = click.prompt("choice", type=click.IntRange(0, len(options)), default=1 if options else 0, err=True)
        if pick:
            chosen[name] = options[pick - 1]
            used.add(options[pick - 1].row_index)
    return chosen
