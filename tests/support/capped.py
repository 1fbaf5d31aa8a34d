"""A command run as a user runs it, in a process capped at 1 GB of address space and 20 s of CPU: a tiny hostile
input must not exhaust memory, stack or time."""

from __future__ import annotations

import os
import resource
import subprocess

from support.run import mdl_cmd

MEMORY_CAP = 1 << 30


TIME_CAP = 20


def _cap_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))


def run_capped(*args: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        mdl_cmd(*args),
        capture_output=True,
        text=True,
        timeout=TIME_CAP,
        preexec_fn=_cap_memory,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
