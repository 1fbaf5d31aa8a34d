"""What the tests of generated drivers share: the native targets (C and C++) behind one interface, `Native`
(how to generate a driver, compile it, build it with its test program, plain or with ASan and UBSan, and how its
values compare with another reader's); a device served to a native driver and to the generated Python driver at
once; the comparisons with the Python driver and mdl read; the Python driver's device class.

The test programs are support/c_harness.py's and support/cpp_harness.py's; both speak cpp_harness's line
protocol, so `cpp_harness.Harness` runs either. Every compiler they reach goes through `require_tier`."""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from pymodbus.client import ModbusTcpClient

from mdl.formats.loading import load_any
from mdl.formats.mdl import load_device
from mdl.model import Device
from mdl.model.names import stem
from mdl.targets import render
from support import c_harness, cpp_harness
from support.common import device_xml, import_generated
from support.cpp_harness import Harness
from support.devices import Sim
from support.run import run_mdl

# ---- comparisons ----


def exactly(c_value, other) -> bool:
    """The C driver's value is the other's: floats bit for bit (NaN for NaN), text as C text (up to
    its first NUL, docs/c-api.md)."""
    if isinstance(other, float) and isinstance(c_value, float):
        if math.isnan(other):
            return math.isnan(c_value)
        return c_value == other and math.copysign(1, c_value) == math.copysign(1, other)
    if isinstance(c_value, float) and other in ("nan", "inf", "-inf"):  # mdl read's JSON for them
        return str(c_value) == other
    if isinstance(other, str) and isinstance(c_value, str):
        return c_value == other.split("\x00", 1)[0]
    if isinstance(other, bool) or isinstance(c_value, bool):
        return c_value is other or (isinstance(c_value, bool) and isinstance(other, bool) and c_value == other)
    return c_value == other and type(c_value) is type(other)


def assert_exactly(c_values: dict, other: dict):
    assert set(c_values) == set(other), set(c_values) ^ set(other)
    bad = {n: (c_values[n], other[n]) for n in other if not exactly(c_values[n], other[n])}
    assert not bad, bad


def same(a, b) -> bool:
    """The C++ driver's value is the other's: floats bit for bit (every target rounds alike), NaN for NaN;
    text byte for byte."""
    for x, y in ((a, b), (b, a)):
        if isinstance(x, float) and y in ("nan", "inf", "-inf"):  # mdl read's JSON for them
            return str(x) == y
    if isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            return a is b
        a, b = float(a), float(b)
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return struct.pack(">d", a) == struct.pack(">d", b)
    return a == b


def assert_same_values(cpp: dict, py: dict):
    assert set(cpp) == set(py), set(cpp) ^ set(py)
    for name in py:
        assert same(cpp[name], py[name]), (name, cpp[name], py[name])


def mdl_read(path: Path, sim) -> dict:
    """`mdl read --format json`, with enumerations as the number a driver reads (mdl read shows the label)."""
    proc = run_mdl("read", path, "--host", sim.host, "--port", sim.port, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    values = json.loads(proc.stdout, parse_constant=float)
    for fn in load_any(path).functions:
        if fn.values and isinstance(values.get(fn.name), str):
            values[fn.name] = next(k for k, label in fn.values.items() if label == values[fn.name])
    return values


# ---- the native targets ----


@dataclass(frozen=True)
class Native:
    """One native target: `mdl gen --lang <target>`, its compilers and strict flags, its test program."""

    target: str  # "c" or "cpp": the --lang, and the test ids
    language: str  # "C" or "C++"
    suffix: str  # the driver's source: ".c" or ".cc" (the header beside it is ".h")
    program: str  # the test program's source file, written beside the driver
    compilers: tuple[str, ...]  # every driver compiles without a warning under each
    strict: tuple[str, ...]  # the flags its docs promise (-Werror among them)
    tool: Callable[[str], str]  # a compiler's path, or skip (fail under CI); compile tier only
    compile_driver: Callable[[Path, str], Path]  # (driver source, compiler) -> its object, once per content
    build: Callable[..., Path]  # (device, workdir, source_name=...) -> the test program
    build_sanitized: Callable[..., Path]  # the same, with ASan and UBSan (-fno-sanitize-recover=all)
    assert_agree: Callable[[dict, dict], None]  # its values against another reader's (Python, mdl read)
    same: Callable[[object, object], bool]  # one value against another reader's
    allocates: bool  # whether the driver may use the heap (C: never, docs/c-api.md)

    def generate(self, device: Device, source_name: str, directory: Path) -> Path:
        """Write the generated driver (and its header) into directory; its source file."""
        directory.mkdir(parents=True, exist_ok=True)
        for name, text in render(device, source_name, self.target).items():
            (directory / name).write_text(text, encoding="utf-8")
        return next(p for p in directory.glob(f"*{self.suffix}") if p.name != self.program)

    def __str__(self) -> str:
        return self.target


C = Native(
    target="c",
    language="C",
    suffix=".c",
    program="c_harness.c",
    compilers=c_harness.COMPILERS,
    strict=tuple(c_harness.STRICT),
    tool=c_harness.tool,
    compile_driver=c_harness.compile_driver,
    build=c_harness.build,
    build_sanitized=c_harness.build_sanitized,
    assert_agree=assert_exactly,
    same=exactly,
    allocates=False,
)
CPP = Native(
    target="cpp",
    language="C++",
    suffix=".cc",
    program="harness.cc",
    compilers=cpp_harness.COMPILERS,
    strict=tuple(cpp_harness.STRICT),
    tool=cpp_harness.tool,
    compile_driver=cpp_harness.compile_driver,
    build=lambda device, workdir, source_name="harness.xml": cpp_harness.build(
        device, workdir, source_name=source_name
    ),
    build_sanitized=lambda device, workdir, source_name="harness.xml": cpp_harness.build(
        device, workdir, sanitize=True, source_name=source_name
    ),
    assert_agree=assert_same_values,
    same=same,
    allocates=True,
)
NATIVES = {native.target: native for native in (C, CPP)}
TARGETS = tuple(NATIVES)  # ("c", "cpp"): what the driver suites are parametrized by


# ---- a device served to two drivers ----


def load_registers(client, regs, bits):
    for start in range(0, len(regs), 120):
        assert not client.write_registers(start, regs[start : start + 120], device_id=1).isError()
    for i, b in enumerate(bits):
        assert not client.write_coil(i, b, device_id=1).isError()


@contextmanager
def served_device(tmp_path_factory, functions: str, name: str, build_harness=None) -> Iterator[tuple]:
    """A device built from `functions`: a harness of its native driver (`build_harness(device, workdir)`:
    a `Native`'s build, the C++ one by default) and its Python driver module, both against one `mdl sim`.
    Yields (path, module, client, harness, sim)."""
    if build_harness is None:
        cpp_harness.toolchain()
        build_harness = CPP.build
    d = tmp_path_factory.mktemp("device")
    path = d / "device.xml"
    path.write_text(device_xml(functions, name=name))
    device = load_device(path)
    exe = build_harness(device, d)
    file_stem = stem(name)
    (d / f"{file_stem}.py").write_text(render(device, "device.xml", "python")[f"{file_stem}.py"])
    module = import_generated(d / f"{file_stem}.py", f"{file_stem}_{d.name}")
    sim = Sim(path)
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    h = Harness(exe, sim.port)
    try:
        yield path, module, client, h, sim
    finally:
        h.close()
        client.close()
        sim.stop()


def python_device(device, workdir: Path):
    name = f"{stem(device.name)}.py"
    (workdir / name).write_text(render(device, "ref.xml", "python")[name])
    module = import_generated(workdir / name, f"tk_{stem(device.name)}")
    return next(
        getattr(module, n)
        for n in module.__all__
        if not n.startswith("Async") and n[0].isupper() and not n.endswith("Error")
    )
