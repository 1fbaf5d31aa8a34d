"""The quality gates CI holds the code to: ruff's checks and its formatting on src/, tests/, scripts/ and
bench/, mypy on src/ (configured in pyproject.toml), zero findings."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import pytest

from support.common import ROOT, skip_or_fail


def _tool(module: str) -> None:
    if importlib.util.find_spec(module) is None:
        skip_or_fail(f"{module} is not installed (pip install -e '.[test]')")


@pytest.mark.parametrize(
    "command",
    [
        ["ruff", "check", "src", "tests", "scripts", "bench"],
        ["ruff", "format", "--check", "src", "tests", "scripts", "bench"],
        ["mypy"],
    ],
    ids=["ruff", "ruff-format", "mypy"],
)
def test_src_has_no_findings(command):
    _tool(command[0])
    proc = subprocess.run([sys.executable, "-m", *command], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
