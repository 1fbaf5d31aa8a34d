"""Shared fixtures: run the CLI as a user does, and serve devices with `mdl sim` on free ports."""

from __future__ import annotations

import codecs
import faulthandler
import os
import selectors
import shutil
import signal
import subprocess
import sys
import tempfile
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


# What a test costs, by file (docs/testing.md): `scripts/test --fast` leaves out compile, engines and fuzz.
# A file not listed is `unit` (pure Python, in process or one `mdl` run), or `device` when its test serves
# or dials a simulated device (the sim_factory or serial_line fixture).
TIERS = {
    "compile": {  # generated C and C++ built with g++, clang++, gcc (and clang-tidy), run against mdl sim
        "test_c_all_header.py",
        "test_c_driver.py",
        "test_c_expression_sizes.py",
        "test_c_hostile.py",
        "test_c_serial.py",
        "test_cpp_driver.py",
        "test_cpp_expression_params.py",
        "test_cpp_hostile.py",
        "test_cpp_serial.py",
        "test_hostile_gen.py",
        "test_perf_shared_code.py",
        "test_write_multiple.py",
        "test_generated_python_lint.py",
        "test_wheel.py",
        "test_bits_scale_native.py",
        "test_read_all_parts.py",
    },
    # hostile inputs whose proof costs seconds each: processes under a memory cap, bombs, floods of
    # connections, timeouts that must pass (the cheap hostile tests stay in unit and device)
    "hostile": {
        "test_limits.py",
        "test_hostile_discover.py",
        "test_hostile_tables.py",
        "test_hostile_wise_toolkit.py",
        "test_hostile_services.py",
    },
    "engines": {  # engines in cached venvs
        "test_export_homeassistant.py",
        "test_export_volttron.py",
        "test_bits_scale_exports.py",
        "test_sunspec_client.py",  # pysunspec2's own client, the SunSpec engine (installed with mdl)
    },
}
TIER_NAMES = ("unit", "device", "hostile", "compile", "engines", "fuzz")


def tier_of(item) -> str:
    """The test's tier: its own marker (`@pytest.mark.engines` on one test of a cheaper file), else its
    file's (tests/fuzz/ and TIERS), else `fuzz` for a hypothesis property test, `device` for one that serves
    or dials a simulated device, `unit` for the rest."""
    for tier in TIER_NAMES:
        if item.get_closest_marker(tier) is not None:
            return tier
    path = Path(str(item.fspath))
    if FUZZ in path.parents or path.name.endswith("_fuzz.py"):
        return "fuzz"
    for tier, files in TIERS.items():
        if path.name in files:
            return tier
    if getattr(getattr(item, "obj", None), "is_hypothesis_test", False):
        return "fuzz"  # a property test (hypothesis's @given), wherever it stands: many examples, not one
    if {"sim_factory", "serial_line"} & set(getattr(item, "fixturenames", ())):
        return "device"
    return "unit"


@pytest.fixture(autouse=True)
def _tier_in_environment(request, monkeypatch):
    """The running test's tier, where the helpers that compile or install an engine look (require_tier)."""
    monkeypatch.setenv(TIER_VARIABLE, tier_of(request.node))


TIER_VARIABLE = "MDL_TEST_TIER"


def require_tier(tier: str, what: str) -> None:
    """Fail a test of another tier that reaches `what` (a compiler, an engine): tiers stay what they cost,
    and `scripts/test --fast` never compiles or installs. Outside a test (a script building the engines
    ahead of time) there is no tier to keep."""
    current = os.environ.get(TIER_VARIABLE)
    if current is not None and current != tier:
        pytest.fail(
            f"{what} is for the {tier} tier, and this test is in the {current} tier: list its file in "
            f"TIERS[{tier!r}] (tests/conftest.py)",
            pytrace=False,
        )


def pytest_configure(config):
    config.addinivalue_line("markers", "conformance(folder): needs CONFORMANCE/folder (ORNL's or the Toolkit's files)")
    config.addinivalue_line("markers", "exhaustive: slow, many-case variants; run with --exhaustive (CI=true does)")
    for tier in TIER_NAMES:
        config.addinivalue_line("markers", f"{tier}: the {tier} tier (set by tests/conftest.py from the file)")


def pytest_addoption(parser):
    parser.addoption(
        "--exhaustive", action="store_true", help="also run the tests marked exhaustive (always on when CI=true)"
    )


def _exhaustive(config) -> bool:
    return bool(config.getoption("--exhaustive")) or in_ci()


def pytest_report_header(config):
    return None if _exhaustive(config) else "exhaustive variants deselected: add --exhaustive (CI runs them)"


FUZZ = Path(__file__).resolve().parent / "fuzz"


def pytest_collection_modifyitems(config, items):
    for item in items:
        tier = tier_of(item)
        if item.get_closest_marker(tier) is None:
            item.add_marker(getattr(pytest.mark, tier))
        if tier == "fuzz":  # the fuzzers are exhaustive variants by nature: CI runs them, a quick run need not
            item.add_marker(pytest.mark.exhaustive)
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
            skip_or_fail(
                f"conformance data {folder} is absent: set MDL_CONFORMANCE_DIR to the folder holding "
                f"{mark.args[0]}/, or check out shared/ beside the repository"
            )


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


def device_xml(functions: str, name: str = "Test Device", version: str | None = "1.0") -> str:
    attr = f' version="{version}"' if version else ""
    return (
        f'<?xml version="1.0" encoding="US-ASCII"?>\n<device xmlns="{MDL_NS}"{attr}>\n'
        f"  <name>{name}</name>\n  <description>test</description>\n{functions}</device>\n"
    )


def fn_xml(name: str, addresses, **fields) -> str:
    """A <function> with the given fields in schema order."""
    from mdl.model import EXTENSION_FIELDS  # the 1.0 elements, in schema order, as the writer uses them

    order = (
        *("length", "count", "format", "block_label", "multiplier", "units"),
        *("read_function_code", "write_function_code"),
        *EXTENSION_FIELDS,
    )
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


def _read_lines(stream, wanted, proc, timeout: float) -> list[str]:
    """Whole lines of `stream` until `wanted(lines)` holds, the process ends, or `timeout` seconds pass.
    Read from the file descriptor (unbuffered): a line never waits in a buffer select() cannot see."""
    fd = stream.fileno()
    decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
    deadline = time.monotonic() + timeout
    text, lines = "", []
    with selectors.DefaultSelector() as sel:
        sel.register(fd, selectors.EVENT_READ)
        while not wanted(lines) and time.monotonic() < deadline:
            if sel.select(timeout=0.5):
                data = os.read(fd, 4096)
                if not data:
                    break
                text += decoder.decode(data)
                *complete, text = text.split("\n")
                lines += [line + "\n" for line in complete]
            elif proc.poll() is not None:
                break
    return lines


class Sim:
    """A running `mdl sim` of one device file, or of a list of them (one ready line each, at self.units);
    stops it with SIGTERM and checks it stopped cleanly.

    On a free TCP port by default, or on `port` (self.host, self.port); with `serial=DEVICE` on that serial device
    (self.device; the ready lines say `on DEVICE`). self.connection: the CLI options that reach it
    (on a serial line, `--serial` of the sim's own end: a client needs the other end of the line)."""

    def __init__(self, path, *extra, timeout: float = 30, serial: str | None = None, port: int = 0):
        paths = list(path) if isinstance(path, (list, tuple)) else [path]
        where = ["--serial", serial] if serial else ["--port", str(port)]
        self.proc = subprocess.Popen(
            mdl_cmd("sim", *paths, *where, *extra), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        lines = _read_lines(self.proc.stdout, lambda got: len(got) >= len(paths), self.proc, timeout)
        if len(lines) < len(paths) or not all(line.startswith("mdl sim: serving") for line in lines):
            self.proc.kill()
            out, err = self.proc.communicate()
            raise RuntimeError(f"mdl sim did not start: {lines!r} {out!r} {err!r}")
        self.ready_lines = [line.rstrip("\n") for line in lines]
        self.ready_line = self.ready_lines[0]
        self.units = [int(line.rsplit(" unit ", 1)[1]) for line in self.ready_lines]
        served = self.ready_line.rsplit(" unit ", 1)[0].rsplit(" on ", 1)[1]
        self.device, self.host, self.port = serial, None, None
        if serial:
            assert served == serial, (served, serial)
            self.connection = ["--serial", serial]
        else:
            host, port = served.rsplit(":", 1)
            self.host, self.port = host, int(port)
            self.connection = ["--host", self.host, "--port", str(self.port)]

    def stop(self, sig=signal.SIGTERM) -> int:
        if self.proc.stdout.closed:  # stopped before
            return self.proc.returncode
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


class SerialLine:
    """Two serial devices wired to each other: a pseudo terminal pair made by
    `socat -d -d pty,raw,echo=0 pty,raw,echo=0`, whose names socat prints on stderr (self.ends).
    Without socat the test is skipped with the reason, or fails when CI=true."""

    def __init__(self, timeout: float = 10):
        if shutil.which("socat") is None:
            skip_or_fail(
                "socat is not installed: the serial tests wire two pseudo terminals with it (apt-get install socat)"
            )
        self.proc = subprocess.Popen(
            ["socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        lines = _read_lines(
            self.proc.stderr,
            lambda got: (
                sum(" PTY is " in line for line in got) == 2 or any("starting data transfer" in line for line in got)
            ),
            self.proc,
            timeout,
        )
        self.ends = [line.split(" PTY is ", 1)[1].strip() for line in lines if " PTY is " in line]
        if len(self.ends) != 2:
            self.close()
            raise RuntimeError(f"socat made no pseudo terminal pair: {lines!r}")

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stderr.close()


@pytest.fixture
def sim_factory():
    """start(path, *extra, serial=None, port=0) -> a running Sim, stopped when the test ends."""
    started: list[Sim] = []

    def start(path, *extra, serial: str | None = None, port: int = 0) -> Sim:
        sim = Sim(path, *extra, serial=serial, port=port)
        started.append(sim)
        return sim

    try:
        yield start
    finally:
        failures = []
        for sim in started:  # each is stopped (killed if need be) even when another did not stop cleanly
            try:
                sim.stop()
            except AssertionError as exc:
                failures.append(exc)
        if failures:
            raise failures[0]


@pytest.fixture
def serial_line():
    """A SerialLine (socat pseudo terminal pair), closed when the test ends; use it before the sims that
    open its ends (fixtures end in reverse order: the sims stop first)."""
    line = SerialLine()
    try:
        yield line
    finally:
        line.close()


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
