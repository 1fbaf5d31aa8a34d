"""Shared fixtures: run the CLI as a user does, and serve devices with `mdl sim` on free ports."""

from __future__ import annotations

import os
import selectors
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _conformance_root() -> Path:
    """Conformance data from elsewhere: $MDL_CONFORMANCE_DIR, else ../shared/conformance beside the checkout."""
    configured = os.environ.get("MDL_CONFORMANCE_DIR")
    return Path(configured).resolve() if configured else ROOT.parent / "shared" / "conformance"


CONFORMANCE = _conformance_root()
ORNL = CONFORMANCE / "ornl"
REFERENCE = CONFORMANCE / "modbus-schema-reference"
EXAMPLE = ROOT / "examples" / "temco_tstat"
DATA = Path(__file__).resolve().parent / "data"

MDL_NS = "http://www.ornl.gov/ModbusXMLSchema"


def in_ci() -> bool:
    return os.environ.get("CI") == "true"


def skip_or_fail(reason: str) -> None:
    """A missing optional tool or data set skips its test with the reason; under CI=true it is a failure."""
    if in_ci():
        pytest.fail(f"{reason} (required when CI=true)", pytrace=False)
    pytest.skip(reason)


def pytest_configure(config):
    config.addinivalue_line("markers", "conformance(folder): needs CONFORMANCE/folder (ORNL's or the Toolkit's files)")
    config.addinivalue_line("markers", "exhaustive: slow, many-case variants; run with --exhaustive (CI=true does)")


def pytest_addoption(parser):
    parser.addoption("--exhaustive", action="store_true",
                     help="also run the tests marked exhaustive (always on when CI=true)")


def _exhaustive(config) -> bool:
    return bool(config.getoption("--exhaustive")) or in_ci()


def pytest_report_header(config):
    return None if _exhaustive(config) else "exhaustive variants deselected: add --exhaustive (CI runs them)"


def pytest_collection_modifyitems(config, items):
    if _exhaustive(config):
        return
    kept = [item for item in items if item.get_closest_marker("exhaustive") is None]
    if len(kept) != len(items):
        config.hook.pytest_deselected(items=[item for item in items if item not in kept])
        items[:] = kept


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    for mark in item.iter_markers("conformance"):
        folder = CONFORMANCE / mark.args[0]
        if not folder.is_dir():
            skip_or_fail(f"conformance data {folder} is absent: set MDL_CONFORMANCE_DIR to the folder holding "
                         f"{mark.args[0]}/, or check out shared/ beside the repository")


def mdl_cmd(*args) -> list[str]:
    return [sys.executable, "-m", "mdl", *map(str, args)]


def run_mdl(*args, input=None, cwd=None, timeout=60) -> subprocess.CompletedProcess:
    return subprocess.run(mdl_cmd(*args), input=input, capture_output=True, text=True, cwd=cwd,
                          timeout=timeout, env={**os.environ, "PYTHONWARNINGS": "ignore"})


def cli(*args, input=None) -> subprocess.CompletedProcess:
    """`mdl ARGS` run in-process by click's CliRunner, as run_mdl reports it: returncode, stdout, stderr.

    Much faster than a subprocess; for commands that neither serve nor need signals or a real stdin.
    An exception the CLI does not turn into an exit status is raised, never mistaken for exit 1."""
    from click.testing import CliRunner

    from mdl.cli import main

    argv = [str(arg) for arg in args]
    result = CliRunner().invoke(main, argv, input=input)
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return subprocess.CompletedProcess(["mdl", *argv], result.exit_code, result.stdout, result.stderr)


def assert_clean_error(proc, code: int, *fragments: str) -> None:
    """Exit status as the spec says, a message naming what is wrong, never a traceback."""
    assert proc.returncode == code, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr, proc.stderr
    for fragment in fragments:
        assert fragment in proc.stderr, (fragment, proc.stderr)


def device_xml(functions: str, name: str = "Test Device", version: str | None = "1.0") -> str:
    attr = f' version="{version}"' if version else ""
    return (f'<?xml version="1.0" encoding="US-ASCII"?>\n<device xmlns="{MDL_NS}"{attr}>\n'
            f"  <name>{name}</name>\n  <description>test</description>\n{functions}</device>\n")


def fn_xml(name: str, addresses, **fields) -> str:
    """A <function> with the given fields in schema order."""
    order = ["length", "count", "format", "block_label", "multiplier", "units", "read_function_code",
             "write_function_code", "register_type", "byte_order", "word_order", "offset", "access",
             "minimum", "maximum", "not_implemented", "values"]
    body = f"    <name>{name}</name>\n    <description>{name}</description>\n    <addresses>{addresses}</addresses>\n"
    for key in order:
        if key in fields:
            value = fields[key]
            if key == "values":
                inner = "".join(f'<value key="{k}">{v}</value>' for k, v in value.items())
                body += f"    <values>{inner}</values>\n"
            else:
                body += f"    <{key}>{value}</{key}>\n"
    return f"  <function>\n{body}  </function>\n"


class Sim:
    """A running `mdl sim` of one device file, or of a list of them (one ready line each, at self.units);
    stops it with SIGTERM and checks it stopped cleanly."""

    def __init__(self, path, *extra, timeout: float = 30):
        paths = list(path) if isinstance(path, (list, tuple)) else [path]
        self.proc = subprocess.Popen(mdl_cmd("sim", *paths, "--port", "0", *extra), stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        sel = selectors.DefaultSelector()
        sel.register(self.proc.stdout, selectors.EVENT_READ)
        deadline = time.monotonic() + timeout
        line = ""
        while time.monotonic() < deadline:
            if sel.select(timeout=0.5):
                line = self.proc.stdout.readline()
                break
            if self.proc.poll() is not None:
                break
        sel.close()
        lines = [line]
        if line.startswith("mdl sim: serving"):  # the others are written at once with the first
            lines += [self.proc.stdout.readline() for _ in paths[1:]]
        if not all(line.startswith("mdl sim: serving") for line in lines):
            self.proc.kill()
            out, err = self.proc.communicate()
            raise RuntimeError(f"mdl sim did not start: {lines!r} {out!r} {err!r}")
        self.ready_lines = [line.rstrip("\n") for line in lines]
        self.ready_line = self.ready_lines[0]
        self.port = int(line.rsplit(":", 1)[1].split()[0])
        self.units = [int(line.rsplit(" unit ", 1)[1]) for line in self.ready_lines]
        self.host = "127.0.0.1"

    def stop(self, sig=signal.SIGTERM) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise AssertionError("mdl sim did not stop on a signal") from None
        self.stderr = self.proc.stderr.read()
        self.proc.stdout.close()
        self.proc.stderr.close()
        return self.proc.returncode


@pytest.fixture
def sim_factory():
    started: list[Sim] = []

    def start(path, *extra) -> Sim:
        sim = Sim(path, *extra)
        started.append(sim)
        return sim

    yield start
    for sim in started:
        sim.stop()


@pytest.fixture
def write_device(tmp_path):
    def write(functions: str, name: str = "Test Device", version: str | None = "1.0", filename="device.xml") -> Path:
        path = tmp_path / filename
        path.write_text(device_xml(functions, name, version), encoding="ascii")
        return path

    return write


def import_generated(path: Path, module_name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(module_name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
