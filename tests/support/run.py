"""`mdl` run as a user runs it: in process (click's runner) or as a process of its own, and the check
that a refusal is clean."""

from __future__ import annotations

import faulthandler
import os
import subprocess
import sys
import tempfile
from pathlib import Path


def mdl_cmd(*args) -> list[str]:
    return [sys.executable, "-m", "mdl", *map(str, args)]


# Commands run_mdl runs as a process of their own: a server waits for signals, and the rest are cheaper
# in process (a process costs ~0.3 s of imports). MDL_TESTS_SUBPROCESS=1 runs every command as a process.
OWN_PROCESS = {"sim"}


def run_mdl(*args, input=None, cwd=None, timeout=60) -> subprocess.CompletedProcess:
    """`mdl ARGS` as a user runs it: exit status, stdout, stderr (text). In process (`cli`) unless the
    command serves or MDL_TESTS_SUBPROCESS=1; either way a run past `timeout` fails the test."""
    if str(args[0]) not in OWN_PROCESS and os.environ.get("MDL_TESTS_SUBPROCESS") != "1":
        return cli(*args, input=input, cwd=cwd, timeout=timeout)
    return subprocess.run(
        mdl_cmd(*args),
        input=input,
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )


# where an in-process run that hangs writes every thread's traceback before it ends the worker (pytest's
# capture dies with the process; under xdist, as scripts/test runs, the crashed worker's test fails by name)
HANG_REPORT = Path(tempfile.gettempdir()) / f"mdl-test-hang-{os.getpid()}.txt"
_hang_report = None


def _hang_file():
    global _hang_report
    if _hang_report is None:
        _hang_report = open(HANG_REPORT, "w")  # noqa: SIM115 - open for the life of the worker
    return _hang_report


def cli(*args, input=None, cwd=None, timeout: float = 60) -> subprocess.CompletedProcess:
    """`mdl ARGS` run in-process by click's CliRunner, as run_mdl reports it: returncode, stdout, stderr.

    Much faster than a subprocess; for commands that neither serve nor need signals. An exception the CLI
    does not turn into an exit status is raised, never mistaken for exit 1. A run past `timeout` (a hang)
    ends the worker, which fails the test, with every thread's traceback in HANG_REPORT (faulthandler).
    What a run may set for its process (the collector's thresholds, pymodbus's log level) is put back."""
    import gc
    import logging
    import warnings

    from click.testing import CliRunner

    from mdl.cli import main

    argv = [str(arg) for arg in args]
    before = os.getcwd()
    thresholds, pymodbus_level = gc.get_threshold(), logging.getLogger("pymodbus").level  # what a run may set
    faulthandler.dump_traceback_later(timeout, exit=True, file=_hang_file())
    try:
        if cwd is not None:
            os.chdir(cwd)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # as PYTHONWARNINGS=ignore does for a process
            result = CliRunner().invoke(main, argv, input=input, prog_name="mdl")
    finally:
        faulthandler.cancel_dump_traceback_later()
        gc.set_threshold(*thresholds)
        logging.getLogger("pymodbus").setLevel(pymodbus_level)
        os.chdir(before)
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return subprocess.CompletedProcess(["mdl", *argv], result.exit_code, result.stdout, result.stderr)


def assert_clean_error(proc, code: int, *fragments: str) -> None:
    """Exit status as the spec says, a message naming what is wrong, never a traceback."""
    assert proc.returncode == code, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr, proc.stderr
    for fragment in fragments:
        assert fragment in proc.stderr, (fragment, proc.stderr)
