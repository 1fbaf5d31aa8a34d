"""`write_multiple` (SPEC 2.2): a function that says it is written with function 16 (registers) or 15
(a coil) even for one register or coil, for devices that refuse functions 6 and 5; without it one
register takes function 6 and one coil function 5. Proved for `mdl write` and every generated driver
(Python sync and asyncio on pymodbus, C++ and C on libmodbus) against `mdl sim` behind a proxy that
records each request's function code and refuses 5 and 6 with exception 1 (ILLEGAL FUNCTION), as such
devices do; the values written are read back from the sim with `mdl read`."""

from __future__ import annotations

import asyncio
import importlib.util
import json
import re
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path

import pytest
from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient

from mdl.formats.mdl import load_device
from support import c_harness, cpp_harness
from support.common import device_xml, fn_xml, import_generated, skip_or_fail
from support.cpp_harness import MODBUS_ENOBASE, Harness
from support.hostile_server import hostile_server
from support.refusing_proxy import refusing_proxy
from support.run import cli, run_mdl

FUNCTIONS = (
    fn_xml("level", "10", format="UINT16", write_multiple="true")
    + fn_xml("split", "20 22", format="UINT32", write_multiple="true")  # two runs of one register
    + fn_xml("enable", "5", format="BIT", register_type="coil", write_multiple="true")
    + fn_xml("plain", "30", format="UINT16")
    + fn_xml("plain_coil", "6", format="BIT", register_type="coil", write_multiple="false")
)
MULTIPLE = {"level": 1234, "split": 305419896, "enable": True}
SINGLE = {"plain": 4321, "plain_coil": True}
CODES = {"level": [16], "split": [16, 16], "enable": [15], "plain": [6], "plain_coil": [5]}
UNWRITTEN = {"level": 0, "split": 0, "enable": False, "plain": 0, "plain_coil": False}
OK, FAILED, ILLEGAL_FUNCTION = "ok", "failed", "exception 1"
TIMEOUT, LIE_TIMEOUT = 5.0, 1.0  # seconds a writer waits for a reply (no retries): from mdl sim, from a liar

Write = Callable[[str, object], str]  # (name, value) -> OK, "exception N" (a Modbus exception) or FAILED
Opener = Callable[[str, int, float], AbstractContextManager[Write]]  # (host, port, timeout) -> a connected writer


@pytest.fixture(scope="module")
def device(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("picky") / "picky_meter.xml"
    path.write_text(device_xml(FUNCTIONS, name="Picky Meter"), encoding="ascii")
    return path


def _text(value: object) -> str:
    return "1" if value is True else "0" if value is False else str(value)


def _mdl_writer(device: Path, _: Path) -> Opener:
    @contextmanager
    def open_writer(host: str, port: int, timeout: float) -> Iterator[Write]:
        def write(name: str, value: object) -> str:
            proc = cli(
                "write",
                device,
                "--host",
                host,
                "--port",
                port,
                "--timeout",
                timeout,
                "--retries",
                "0",
                f"{name}={_text(value)}",
            )
            if proc.returncode == 0:
                return OK
            assert proc.returncode == 3 and "Traceback" not in proc.stderr, proc.stderr
            found = re.search(r"Modbus exception (\d+)", proc.stderr)
            return f"exception {found[1]}" if found else FAILED

        yield write

    return open_writer


def _python_module(device: Path, workdir: Path):  # type: ignore[no-untyped-def]
    proc = run_mdl("gen", device, "--lang", "python", "-o", workdir)
    assert proc.returncode == 0, proc.stderr
    return import_generated(workdir / "picky_meter.py", f"picky_meter_{workdir.name}")


def _python_sync_writer(device: Path, workdir: Path) -> Opener:
    module = _python_module(device, workdir)

    @contextmanager
    def open_writer(host: str, port: int, timeout: float) -> Iterator[Write]:
        client = ModbusTcpClient(host, port=port, timeout=timeout, retries=0)
        assert client.connect()
        dev = module.PickyMeter(client)

        def write(name: str, value: object) -> str:
            try:
                getattr(dev, f"write_{name}")(value)
            except module.ModbusExceptionError as exc:
                return f"exception {exc.code}"
            except module.CommunicationError:
                return FAILED
            return OK

        try:
            yield write
        finally:
            client.close()

    return open_writer


def _python_async_writer(device: Path, workdir: Path) -> Opener:
    module = _python_module(device, workdir)

    @contextmanager
    def open_writer(host: str, port: int, timeout: float) -> Iterator[Write]:
        async def connect() -> AsyncModbusTcpClient:  # the client belongs to the loop it is made in
            client = AsyncModbusTcpClient(host, port=port, timeout=timeout, retries=0)
            assert await client.connect()
            return client

        loop = asyncio.new_event_loop()
        client = loop.run_until_complete(connect())
        dev = module.AsyncPickyMeter(client)

        def write(name: str, value: object) -> str:
            try:
                loop.run_until_complete(getattr(dev, f"write_{name}")(value))
            except module.ModbusExceptionError as exc:
                return f"exception {exc.code}"
            except module.CommunicationError:
                return FAILED
            return OK

        try:
            yield write
        finally:
            client.close()
            loop.run_until_complete(asyncio.sleep(0))
            loop.close()

    return open_writer


def _harness_writer(build: Callable[..., Path]) -> Callable[[Path, Path], Opener]:
    def make(device: Path, workdir: Path) -> Opener:
        exe = build(load_device(device), workdir, source_name=device.name)

        @contextmanager
        def open_writer(host: str, port: int, timeout: float) -> Iterator[Write]:
            assert host == "127.0.0.1"  # the harness connects to 127.0.0.1:PORT
            with Harness(exe, port, timeout_ms=round(1000 * timeout)) as h:

                def write(name: str, value: object) -> str:
                    answer = h.ask(f"write {name} {_text(value)}")
                    if answer == ["ok"]:
                        return OK
                    assert len(answer) == 1 and answer[0].startswith("error "), answer
                    code = int(answer[0].split()[1]) - MODBUS_ENOBASE
                    return f"exception {code}" if 1 <= code <= 11 else FAILED  # EMBXILFUN .. EMBXGTAR

                yield write

        return open_writer

    return make


WRITERS: dict[str, Callable[[Path, Path], Opener]] = {
    "mdl write": _mdl_writer,
    "python": _python_sync_writer,
    "python asyncio": _python_async_writer,
    "c++": _harness_writer(cpp_harness.build),
    "c": _harness_writer(c_harness.build),
}


@pytest.fixture(scope="module", params=list(WRITERS))
def writer(request, device, tmp_path_factory) -> Opener:
    """Each writer built once (the drivers generated and compiled) for the tests of this module."""
    return WRITERS[request.param](device, tmp_path_factory.mktemp(re.sub(r"\W", "_", request.param)))


def _read_back(device: Path, sim) -> dict[str, object]:  # type: ignore[no-untyped-def]
    proc = cli("read", device, *sim.connection, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return dict(json.loads(proc.stdout))


def test_write_multiple_writes_with_fc16_and_fc15_where_fc6_and_fc5_are_refused(writer, device, sim_factory):
    sim = sim_factory(device)
    with refusing_proxy(sim.host, sim.port, refused={5, 6}) as proxy, writer(proxy.host, proxy.port, TIMEOUT) as write:
        for name, value in MULTIPLE.items():
            before = len(proxy.codes)
            assert write(name, value) == OK, name
            assert proxy.codes[before:] == CODES[name], name
        for name, value in SINGLE.items():  # the control: this device does refuse 6 and 5
            before = len(proxy.codes)
            assert write(name, value) == ILLEGAL_FUNCTION, name
            assert proxy.codes[before:] == CODES[name], name
    assert _read_back(device, sim) == {**UNWRITTEN, **MULTIPLE}


def test_without_write_multiple_one_register_takes_fc6_and_one_coil_fc5(writer, device, sim_factory):
    sim = sim_factory(device)
    with refusing_proxy(sim.host, sim.port) as proxy, writer(proxy.host, proxy.port, TIMEOUT) as write:
        for name, value in SINGLE.items():
            before = len(proxy.codes)
            assert write(name, value) == OK, name
            assert proxy.codes[before:] == CODES[name], name
    assert _read_back(device, sim) == {**UNWRITTEN, **SINGLE}


def test_mdl_write_multiple_over_rtu_framing_checks_and_accepts_the_fc15_and_fc16_echoes(device, sim_factory):
    """The runtime frames RTU replies itself (their size from the function code): FC15's echo is whole."""
    sim = sim_factory(device, "--framer", "rtu")
    proc = cli("write", device, *sim.connection, "--framer", "rtu", *(f"{n}={_text(v)}" for n, v in MULTIPLE.items()))
    assert proc.returncode == 0, proc.stderr
    read = cli("read", device, *sim.connection, "--framer", "rtu", "--format", "json")
    assert read.returncode == 0, read.stderr
    assert json.loads(read.stdout) == {**UNWRITTEN, **MULTIPLE}


# A lying device (tests/support/hostile_server.py) answering the FC15 and FC16 writes of write_multiple: every
# writer reports the lie rather than a success ("honest" is the control). Pinned gap: the Python drivers
# see pymodbus' decoded reply, which does not show bytes after a complete echo (as for their other
# writes: test_python_driver.UNSEEN), so they take that echo as a success.
LIES = {
    "wrong_function_code": FAILED,
    "extra_registers": FAILED,
    "short": FAILED,
    "bad_byte_count": FAILED,
    "exception": "exception 4",
    "honest": OK,
}
UNSEEN = {("python", "extra_registers"), ("python asyncio", "extra_registers")}


@pytest.mark.parametrize("mode", list(LIES))
def test_a_lying_reply_to_a_write_multiple_is_not_a_success(request, writer, mode):
    expected = OK if (request.node.callspec.params["writer"], mode) in UNSEEN else LIES[mode]
    with hostile_server(mode) as (host, port), writer(host, port, LIE_TIMEOUT) as write:
        for name in ("level", "enable"):  # FC16 for one register, FC15 for one coil
            assert write(name, MULTIPLE[name]) == expected, (mode, name)


ONLY_MULTIPLE = (
    fn_xml("level", "10", format="UINT16", write_multiple="true")
    + fn_xml("enable", "5", format="BIT", register_type="coil", write_multiple="true")
    + fn_xml("reading", "40", format="UINT16", access="read", write_multiple="true")
)


def test_a_driver_carries_only_the_write_helpers_it_calls(tmp_path):
    """Every write says write_multiple: the C driver has no mdl_write_table (an unused static function
    fails -Werror), the C++ and Python drivers never call function 5 or 6. No function says it: the
    drivers are what they were (the golden files pin that)."""
    source = tmp_path / "only.xml"
    source.write_text(device_xml(ONLY_MULTIPLE, name="Only Multiple"), encoding="ascii")
    out = tmp_path / "out"
    proc = run_mdl("gen", source, "--lang", "all", "-o", out)
    assert proc.returncode == 0, proc.stderr
    c_text, cc_text, py_text = ((out / f"only_multiple.{ext}").read_text() for ext in ("c", "cc", "py"))
    assert "mdl_write_multiple" in c_text and "mdl_write_table" not in c_text
    assert "modbus_write_bit(" not in cc_text.split("::write_multiple_")[1]
    assert py_text.count("multiple=True") == 4  # level and enable, in the sync and the asyncio class
    plain = tmp_path / "plain.xml"
    plain.write_text(device_xml(fn_xml("level", "10", format="UINT16"), name="Plain"), encoding="ascii")
    proc = run_mdl("gen", plain, "--lang", "all", "-o", out)
    assert proc.returncode == 0, proc.stderr
    for ext in ("c", "cc", "h", "py"):
        assert "multiple" not in (out / f"plain.{ext}").read_text(), ext
    c_harness.compile_driver(out / "only_multiple.c", "gcc")  # STRICT, -Werror: no unused helper
    cpp_harness.compile_driver(out / "only_multiple.cc", "g++")  # the shared header's C++ side


def _tool(module: str) -> list[str]:
    """The command running a linter installed for this interpreter (mypy must see its pymodbus)."""
    if importlib.util.find_spec(module) is not None:
        return [sys.executable, "-m", module]
    found = shutil.which(module)
    if found is None:
        skip_or_fail(f"{module} is not installed (pip install '.[test]')")
    return [str(found)]


def test_the_python_driver_with_write_multiple_passes_ruff_and_mypy_strict(device, tmp_path):
    proc = run_mdl("gen", device, "--lang", "python", "-o", tmp_path)
    assert proc.returncode == 0, proc.stderr
    driver = tmp_path / "picky_meter.py"
    ruff = subprocess.run(
        [*_tool("ruff"), "check", "--isolated", "--no-cache", str(driver)], capture_output=True, text=True, timeout=300
    )
    assert ruff.returncode == 0, ruff.stdout + ruff.stderr
    mypy = subprocess.run(
        [
            *_tool("mypy"),
            "--config-file",
            "",
            "--strict",
            "--python-executable",
            sys.executable,
            "--cache-dir",
            str(tmp_path / ".mypy_cache"),
            str(driver),
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
    )
    assert mypy.returncode == 0, mypy.stdout + mypy.stderr


@pytest.mark.exhaustive  # clang-tidy takes seconds a driver: CI runs it, a quick local run need not
def test_clang_tidy_finds_nothing_in_a_cpp_driver_that_writes_multiple(device, tmp_path):
    proc = run_mdl("gen", device, "--lang", "cpp", "-o", tmp_path)
    assert proc.returncode == 0, proc.stderr
    tidy = cpp_harness.clang_tidy(tmp_path / "picky_meter.cc")
    assert tidy.returncode == 0 and "warning:" not in tidy.stdout, tidy.stdout + tidy.stderr
