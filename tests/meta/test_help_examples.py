"""Every example line in `mdl --help` and each command's `--help` runs, in a fresh folder, in order.

The convention is docs/testing.md's ("Documented examples"): a line starting with `mdl ` runs (a sim in
the background, on a free port), `$ mdl ...` is shown only; tests/meta/test_doc_examples.py's Runner runs them.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from mdl.cli import main
from support.common import ROOT, skip_or_fail
from support.doc_examples import Command, Runner, command, scratch

ORDER = [
    *("csv2xml", "validate", "profiles", "gen", "import", "export", "test"),
    *("sim", "read", "write", "discover", "probe", "capture", "serve", "examples"),
]
SERVED = ["sim", "read", "write", "discover", "probe", "capture"]  # they use the sims mdl sim --help starts


def _examples(help_text: str) -> list[list[str]]:
    return [
        shlex.split(line.strip().rstrip("&"))[1:] for line in help_text.splitlines() if line.strip().startswith("mdl ")
    ]


def _help(*args: str) -> str:
    result = CliRunner().invoke(main, [*args, "--help"], terminal_width=200)
    assert result.exit_code == 0, result.output
    return result.output


def test_every_command_has_an_example():
    assert isinstance(main, click.Group)
    assert sorted(main.every_command()) == sorted(ORDER)
    for name in ORDER:
        assert _examples(_help(name)), f"mdl {name} --help has no example"
    assert {args[0] for args in _examples(_help())} >= {"csv2xml", "validate", "gen", "sim", "read"}


def _commands(*names: str) -> list[Command]:
    """The runnable example lines of `mdl NAME --help`, in order, for each name (none: `mdl --help`)."""
    found = []
    for name in names or ("",):
        where = f"mdl {name} --help".replace("  ", " ")
        found += [
            cmd
            for line in _help(*filter(None, [name])).splitlines()
            if line.strip().startswith("mdl ") and (cmd := command(line, where)) is not None
        ]
    return found


def _run(commands: list[Command], folder) -> int:
    with Runner(scratch(folder)) as runner:
        for cmd in commands:
            runner.run(cmd)
    return runner.ran


@pytest.mark.commands  # serves devices: the commands tier
def test_overview_examples_run(tmp_path):
    assert _run(_commands(), tmp_path) == len(_examples(_help())) >= 5


@pytest.mark.parametrize("name", [name for name in ORDER if name not in SERVED])
def test_each_commands_examples_run_on_their_own(name, tmp_path):
    assert _run(_commands(name), tmp_path) >= 1


@pytest.mark.commands  # serves devices: the commands tier
def test_the_served_examples_run(tmp_path):
    """mdl sim --help's sims (TCP, RTU over TCP, a pseudo terminal), then read, write and discover them."""
    commands = _commands(*SERVED)
    assert any("/dev/pts/" in cmd.code for cmd in commands)
    assert _run(commands, tmp_path) == len(commands)


@pytest.mark.parametrize("args", [args for args in _examples(_help()) if args[0] != "sim"], ids=" ".join)
def test_overview_examples_name_real_files(args):
    assert (ROOT / args[1]).exists(), args


def test_the_shell_completion_mdl_help_gives_completes_commands():
    """The line `mdl --help` gives for bash is a working completion script, and completion answers."""
    assert 'eval "$(_MDL_COMPLETE=bash_source mdl)"' in _help()
    mdl = Path(sys.executable).parent / "mdl"  # the console script: completion goes by the program's name
    if not mdl.exists():
        skip_or_fail(f"no console script {mdl} (mdl is not installed in this Python's environment)")
    script = subprocess.run(
        [mdl], env={**os.environ, "_MDL_COMPLETE": "bash_source"}, capture_output=True, text=True, timeout=60
    )
    assert script.returncode == 0 and "complete -o nosort -F _mdl_completion" in script.stdout, script.stdout
    answer = subprocess.run(
        [mdl],
        env={**os.environ, "_MDL_COMPLETE": "bash_complete", "COMP_WORDS": "mdl va", "COMP_CWORD": "1"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert answer.stdout.split() == ["plain,validate"], answer.stdout
