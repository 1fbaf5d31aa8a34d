"""Every example line in `mdl --help` and each command's `--help` runs from a checkout, in order."""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner
from conftest import ROOT, Sim, run_mdl, skip_or_fail

from mdl.cli import main

# the order a user would follow: what one example writes, a later one reads
ORDER = ["csv2xml", "validate", "gen", "import", "export", "test", "sim", "read", "write", "discover"]


def _examples(help_text: str) -> list[list[str]]:
    return [shlex.split(line.strip().rstrip("&"))[1:] for line in help_text.splitlines()
            if line.strip().startswith("mdl ")]


def _help(*args: str) -> str:
    result = CliRunner().invoke(main, [*args, "--help"], terminal_width=200)
    assert result.exit_code == 0, result.output
    return result.output


def test_every_command_has_an_example():
    assert isinstance(main, click.Group)
    assert sorted(main.commands) == sorted(ORDER)
    for name in ORDER:
        assert _examples(_help(name)), f"mdl {name} --help has no example"
    assert {args[0] for args in _examples(_help())} >= {"csv2xml", "validate", "gen", "sim", "read"}


def test_examples_run_from_a_checkout(tmp_path, monkeypatch):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    sims: dict[str, Sim] = {}
    try:
        for name in ORDER:
            for args in _examples(_help(name)):
                if name == "sim":  # serve it on a free port instead of the one printed
                    i = args.index("--port")
                    sims[args[i + 1]] = Sim(args[1], *args[2:i], *args[i + 2:])
                    continue
                if "--port" in args:
                    i = args.index("--port") + 1
                    args[i] = str(sims[args[i]].port)
                proc = run_mdl(*args, input="\n" * 40, cwd=tmp_path)
                assert proc.returncode == 0, (args, proc.stdout, proc.stderr)
    finally:
        for sim in sims.values():
            sim.stop()


@pytest.mark.parametrize("args", [args for args in _examples(_help()) if args[0] != "sim"], ids=" ".join)
def test_overview_examples_name_real_files(args):
    assert (ROOT / args[1]).exists(), args


def test_the_shell_completion_mdl_help_gives_completes_commands():
    """The line `mdl --help` gives for bash is a working completion script, and completion answers."""
    assert 'eval "$(_MDL_COMPLETE=bash_source mdl)"' in _help()
    mdl = Path(sys.executable).parent / "mdl"  # the console script: completion goes by the program's name
    if not mdl.exists():
        skip_or_fail(f"no console script {mdl} (mdl is not installed in this Python's environment)")
    script = subprocess.run([mdl], env={**os.environ, "_MDL_COMPLETE": "bash_source"}, capture_output=True,
                            text=True, timeout=60)
    assert script.returncode == 0 and "complete -o nosort -F _mdl_completion" in script.stdout, script.stdout
    answer = subprocess.run([mdl], env={**os.environ, "_MDL_COMPLETE": "bash_complete", "COMP_WORDS": "mdl va",
                                            "COMP_CWORD": "1"}, capture_output=True, text=True, timeout=60)
    assert answer.stdout.split() == ["plain,validate"], answer.stdout
