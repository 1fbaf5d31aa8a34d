"""Generated C++ drivers: compiled by g++ and clang++ with the strict flags docs/cpp-api.md promises
(and once with ASan/UBSan), checked by clang-tidy, run against `mdl sim`, and compared with the
generated Python driver and `mdl read` on random registers."""

from __future__ import annotations

import json
import math
import random
import re
import struct
from contextlib import contextmanager
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from mdl.formats.loading import load_resolved
from mdl.formats.mdl import load_device
from mdl.model.layout import layout
from mdl.model.names import stem as file_stem
from mdl.targets import render
from support.common import DATA, EXAMPLE, REFERENCE, ROOT, device_xml, fn_xml, import_generated
from support.cpp_harness import (
    COMPILERS,
    MODBUS_ENOBASE,
    STRICT,
    TIDY_CONFIG,
    Harness,
    build,
    clang_tidy,
    compile_driver,
    toolchain,
)
from support.devices import Sim
from support.fragments import READS as CFRAG_READS
from support.fragments import WRITES as CFRAG_WRITES
from support.raw_images import ALL_SETTINGS
from support.run import run_mdl

ALL = DATA / "all_tables.xml"


def same(a, b) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            return a is b
        a, b = float(a), float(b)
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return struct.pack(">d", a) == struct.pack(">d", b)  # bit for bit: every target rounds alike
    return a == b


def assert_same_values(cpp: dict, py: dict):
    assert set(cpp) == set(py), set(cpp) ^ set(py)
    for name in py:
        assert same(cpp[name], py[name]), (name, cpp[name], py[name])


@pytest.fixture(scope="module")
def all_tables_cpp(tmp_path_factory):
    return build(load_device(ALL), tmp_path_factory.mktemp("cpp_all"), source_name=ALL.name)


def _python_values(path, sim, module_name):
    out = path.parent / f"py_{module_name}"
    out.mkdir(exist_ok=True)
    assert run_mdl("gen", path, "--lang", "python", "-o", out).returncode == 0
    device = load_device(path)
    from mdl.model.names import identifier

    module = import_generated(out / f"{identifier(device.name)}.py", module_name)
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        cls = next(
            getattr(module, n)
            for n in module.__all__
            if not n.startswith("Async")
            and n[0].isupper()
            and n not in ("DeviceError", "CommunicationError", "ModbusExceptionError", "ValueRangeError")
        )
        return cls(client).read_all()
    finally:
        client.close()


def test_all_tables_compile_run_and_agree_with_python(all_tables_cpp, sim_factory, tmp_path):
    sim = sim_factory(ALL, *ALL_SETTINGS)
    h = Harness(all_tables_cpp, sim.port)
    try:
        cpp = h.values()
        assert cpp["setpoint"] == 21.5 and cpp["mode"] == 2 and cpp["label"] == "Hall"
        assert cpp["big"] == -5000000000 and cpp["serial"] == 305419896 and cpp["low_byte"] == -3
        assert cpp["pump"] is True and cpp["door_open"] is True and cpp["voltage"] == 0.0
        copy = tmp_path / "all_tables.xml"
        copy.write_text(ALL.read_text())
        assert_same_values(cpp, _python_values(copy, sim, "all_tables_py_cpp"))
        assert h.values("read energy") == {"energy": 1234.567}
        assert h.values("read power") == {"power": -12.5}
    finally:
        h.close()


def test_examples_compile_and_read(sim_factory, tmp_path):
    exe = build(load_device(EXAMPLE / "temco_tstat.xml"), tmp_path, source_name="temco_tstat.xml")
    sim = sim_factory(
        EXAMPLE / "temco_tstat.xml",
        "--set",
        "room_temperature=21.5",
        "--set",
        "serial_number=80012345",
        "--set",
        "firmware_version=4.6",
        "--set",
        "occupancy=1",
    )
    h = Harness(exe, sim.port)
    try:
        values = h.values()
        assert values["room_temperature"] == 21.5 and values["serial_number"] == 80012345
        assert values["firmware_version"] == 4.6 and values["occupancy"] == 1.0
        assert h.ask("write occupied_setpoint 23.5") == ["ok"]
        assert h.values("write occupied_setpoint 40") == {"error": 22}  # EINVAL: above the maximum
    finally:
        h.close()
    proc = run_mdl(
        "read",
        EXAMPLE / "temco_tstat.xml",
        "--host",
        sim.host,
        "--port",
        sim.port,
        "occupied_setpoint",
        "--format",
        "json",
    )
    assert json.loads(proc.stdout) == {"occupied_setpoint": 23.5}


def test_sanitizers_find_nothing(sim_factory, tmp_path):
    exe = build(load_device(ALL), tmp_path, sanitize=True)
    sim = sim_factory(ALL, *ALL_SETTINGS)
    h = Harness(exe, sim.port)
    h.values()
    h.ask("write label 4b69746368656e")
    assert h.values("read label") == {"label": "Kitchen"}
    assert h.values("write label 61626364656667686970") == {"error": 22}  # 10 bytes do not fit 8
    err = h.close()
    assert "runtime error" not in err and "AddressSanitizer" not in err


def test_modbus_exception_sets_errno_and_read_all_falls_back(tmp_path, write_device, sim_factory):
    described = load_device(
        write_device(
            fn_xml("a", "10", format="UINT16")
            + fn_xml("cmd", "11", format="UINT16", access="write")
            + fn_xml("b", "12", format="UINT16")
            + fn_xml("c", "40", format="INT16"),
            name="Planned",
        )
    )
    actual = write_device(
        fn_xml("a", "10", format="UINT16") + fn_xml("b", "12", format="UINT16"), name="Planned", filename="actual.xml"
    )
    exe = build(described, tmp_path)
    sim = sim_factory(actual, "--set", "a=7", "--set", "b=9")
    h = Harness(exe, sim.port)
    try:
        assert h.values("read c") == {"error": MODBUS_ENOBASE + 2}  # EMBXILADD
        assert h.values("read a") == {"a": 7}
        assert h.values() == {"error": MODBUS_ENOBASE + 2}  # c cannot be read at all
    finally:
        h.close()
    device2 = load_device(
        write_device(
            fn_xml("a", "10", format="UINT16")
            + fn_xml("cmd", "11", format="UINT16", access="write")
            + fn_xml("b", "12", format="UINT16"),
            name="Planned",
            filename="p2.xml",
        )
    )
    (tmp_path / "p2").mkdir()
    exe2 = build(device2, tmp_path / "p2")
    h = Harness(exe2, sim.port)
    try:
        assert h.values() == {"a": 7, "b": 9}
        assert h.values() == {"a": 7, "b": 9}
    finally:
        h.close()


def test_functions_sharing_registers_share_their_smaller_request(tmp_path, write_device, sim_factory):
    """After exception 2 a group is read as one request per distinct run of registers, however many
    functions read it (the Toolkit's QuickTestDevice has five functions on one coil)."""
    described = load_device(
        write_device(
            fn_xml("a", "10", format="UINT16")
            + fn_xml("a_again", "10", format="UINT16")
            + fn_xml("cmd", "11", format="UINT16", access="write")
            + fn_xml("b", "12 13", format="UINT32")
            + fn_xml("b_low", "13", format="UINT16")
            + fn_xml("b_again", "12 13", format="INT32"),
            name="Shared",
        )
    )
    actual = write_device(
        fn_xml("a", "10", format="UINT16") + fn_xml("b", "12 13", format="UINT32"), name="Shared", filename="actual.xml"
    )
    exe = build(described, tmp_path)
    splits = re.findall(r"^    \{(kHolding, \d+, \d+), \d+\},$", (tmp_path / "shared.cc").read_text(), re.M)
    assert splits == ["kHolding, 10, 1", "kHolding, 12, 2", "kHolding, 13, 1"]
    sim = sim_factory(actual, "--set", "a=7", "--set", "b=65539")
    h = Harness(exe, sim.port)
    try:
        assert h.values() == {"a": 7, "a_again": 7, "b": 65539, "b_low": 3, "b_again": 65539}
    finally:
        h.close()


def test_unreachable_device(all_tables_cpp):
    import subprocess

    proc = subprocess.run([str(all_tables_cpp), "1"], input="", capture_output=True, text=True, timeout=30)
    assert proc.returncode == 1 and "connect failed" in proc.stdout


# ---- differential: random registers, three readers ----

INTS = ["INT8", "UINT8", "INT16", "UINT16", "INT32", "UINT32", "INT64", "UINT64"]
ORDERS = [("big", "big"), ("big", "little"), ("little", "big"), ("little", "little")]
READ_FRAGMENTS = [
    "arg = (int16_t)r1 / 10.0f;",
    "arg = ((uint32_t)r1 << 16 | r2) * 0.001;",
    "arg = (r1 >> 4 & 0xF) * 10 + (r1 & 0xF);",
    "arg = r1 > 32767 ? -1.0 : r1 % 100 / 3;",
    "arg = (float)(int16_t)r2 * 0.5f - r1 / 7;",
]


def _xml_text(code: str) -> str:
    return code.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _diff_functions() -> tuple[str, int]:
    """The functions' XML, and the registers they take."""
    out, addr, n = [], 0, 0

    def add(**fields) -> None:
        nonlocal addr, n
        name = f"v{n}"
        n += 1
        xml = fn_xml(name, str(addr), **fields)
        out.append(xml)
        from mdl.model import Function

        fn = Function(
            name,
            name,
            [addr],
            length=fields.get("length"),
            count=int(fields["count"]) if "count" in fields else None,
            format=fields.get("format"),
        )
        addr += len(layout(fn).addresses)

    for fmt in INTS:
        for bo, wo in ORDERS:
            add(format=fmt, byte_order=bo, word_order=wo)
        for length in ("Lower byte", "Upper byte"):
            for wo in ("big", "little"):
                add(format=fmt, length=length, word_order=wo)
    for fmt in ("FLOAT32", "FLOAT64"):
        for bo, wo in ORDERS:
            add(format=fmt, byte_order=bo, word_order=wo)
    add(format="STRING", count="4")
    add(format="STRING", count="3", byte_order="little")
    add(format="STRING", count="5", length="Lower byte")
    add(format="INT16", multiplier="0.1")
    add(format="UINT32", multiplier="0.01", offset="-273.15", word_order="little")
    add(format="INT8", length="Upper byte", multiplier="2.5", offset="1")
    add(format="FLOAT32", multiplier="10", offset="0.5")
    add(format="UINT16", not_implemented="0xFFFF 0x8000")
    add(format="STRING", count="4", not_implemented="0x0000")  # SunSpec strings: all NULs is no value
    add(format="INT32", not_implemented="0x80000000")
    add(format="UINT16", count="3")
    for code in READ_FRAGMENTS:
        add(format="UINT16", count="2", read_function_code=_xml_text(code))
    return "".join(out), addr


DIFF_FUNCTIONS, DIFF_REGISTERS = _diff_functions()
BITS = fn_xml("coil_a", "0", format="BIT", register_type="coil") + fn_xml(
    "coil_b", "1", format="BIT", register_type="coil"
)


@contextmanager
def served_device(tmp_path_factory, functions: str, name: str, build_harness=None):
    """A device built from `functions`: a harness of its driver (C++ by default; tests/support/c_harness.py's
    `build` for C) and its Python driver module, both against one `mdl sim`."""
    if build_harness is None:
        toolchain()
        build_harness = build
    d = tmp_path_factory.mktemp("device")
    path = d / "device.xml"
    path.write_text(device_xml(functions, name=name))
    device = load_device(path)
    exe = build_harness(device, d)
    stem = file_stem(name)
    (d / f"{stem}.py").write_text(render(device, "device.xml", "python")[f"{stem}.py"])
    module = import_generated(d / f"{stem}.py", f"{stem}_{d.name}")
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


@pytest.fixture(scope="module")
def diff_setup(tmp_path_factory):
    with served_device(tmp_path_factory, DIFF_FUNCTIONS + BITS, "Diff Device") as served:
        yield served


def load_registers(client, regs, bits):
    for start in range(0, len(regs), 120):
        assert not client.write_registers(start, regs[start : start + 120], device_id=1).isError()
    for i, b in enumerate(bits):
        assert not client.write_coil(i, b, device_id=1).isError()


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
)
@given(
    regs=st.lists(st.integers(0, 0xFFFF), min_size=DIFF_REGISTERS, max_size=DIFF_REGISTERS),
    bits=st.lists(st.booleans(), min_size=2, max_size=2),
)
def test_cpp_python_agree_on_random_registers(diff_setup, regs, bits):
    _, module, client, h, _ = diff_setup
    load_registers(client, regs, bits)
    py = module.DiffDevice(client).read_all()
    assert_same_values(h.values(), py)


def test_mdl_read_agrees_with_both_drivers(diff_setup):
    import random

    path, module, client, h, sim = diff_setup
    rng = random.Random(7)
    for _ in range(4):
        regs = [rng.choice([0, 0xFFFF, 0x8000, 0x7FFF, rng.randrange(65536)]) for _ in range(DIFF_REGISTERS)]
        load_registers(client, regs, [rng.random() < 0.5, rng.random() < 0.5])
        py = module.DiffDevice(client).read_all()
        proc = run_mdl("read", path, "--host", sim.host, "--port", sim.port, "--format", "json")
        assert proc.returncode == 0, proc.stderr
        cli = json.loads(proc.stdout, parse_constant=float)
        for name, value in py.items():
            got = cli[name]
            if isinstance(value, float) and not math.isfinite(value):
                assert str(got) == str(value)
            else:
                assert got == value, (name, got, value)
        assert_same_values(h.values(), py)


@pytest.mark.parametrize("name, value", [("v0", -5), ("v12", 200), ("v40", -1), ("v3", -32768)])
def test_writes_round_trip_both_ways(diff_setup, name, value):
    _, module, client, h, _ = diff_setup
    dev = module.DiffDevice(client)
    assert h.ask(f"write {name} {value}") == ["ok"]
    assert getattr(dev, f"read_{name}")() == h.values(f"read {name}")[name]
    getattr(dev, f"write_{name}")(getattr(dev, f"read_{name}")())
    assert h.values(f"read {name}")[name] == getattr(dev, f"read_{name}")()


def test_scaled_and_string_writes_round_trip(diff_setup):
    _, module, client, h, _ = diff_setup
    dev = module.DiffDevice(client)
    scaled = [f for f in load_device(diff_setup[0]).functions if f.multiplier]
    for fn in scaled:
        assert h.ask(f"write {fn.name} 12.5") == ["ok"], fn.name
        assert same(getattr(dev, f"read_{fn.name}")(), h.values(f"read {fn.name}")[fn.name])
        getattr(dev, f"write_{fn.name}")(7.5)
        assert same(h.values(f"read {fn.name}")[fn.name], getattr(dev, f"read_{fn.name}")())
    strings = [f for f in load_device(diff_setup[0]).functions if f.format == "STRING"]
    for fn in strings:
        assert h.ask(f"write {fn.name} {b'Abc'.hex()}") == ["ok"]
        assert getattr(dev, f"read_{fn.name}")() == "Abc"
        getattr(dev, f"write_{fn.name}")("xyz")
        assert h.values(f"read {fn.name}") == {fn.name: "xyz"}


# ---- fragments: every one test_cfrag.py proves the Python translation on against gcc ----

FRAGMENT_READS = "".join(
    fn_xml(f"rd{i}", str(4 * i), format="UINT16", count="4", read_function_code=_xml_text(code))
    for i, code in enumerate(CFRAG_READS)
)
FRAGMENT_WRITE_BASE = 4 * len(CFRAG_READS)
FRAGMENT_WRITES = "".join(
    fn_xml(
        f"wr{i}",
        str(FRAGMENT_WRITE_BASE + 2 * i),
        format="UINT16",
        count="2",
        access="write",
        write_function_code=_xml_text(code),
    )
    for i, (code, _) in enumerate(CFRAG_WRITES)
)
EDOM, ERANGE = 33, 34


@pytest.fixture(scope="module")
def fragment_setup(tmp_path_factory):
    functions = FRAGMENT_READS + FRAGMENT_WRITES
    with served_device(tmp_path_factory, functions, "Fragment Device") as (_, module, client, h, _):
        yield module.FragmentDevice(client), client, h


def _register_sets(n: int) -> list[list[int]]:
    rng = random.Random(3)
    edges = [[value] * n for value in (0, 1, 0x7FFF, 0x8000, 0xFFFF)]
    return edges + [
        [rng.choice([0, 1, 2, 0x7FFF, 0x8000, 0xFFFF, rng.randrange(65536)]) for _ in range(n)] for _ in range(6)
    ]


def test_fragment_reads_agree_with_python(fragment_setup):
    """Value for value, and failure (EDOM, ERANGE) for failure."""
    dev, client, h = fragment_setup
    for regs in _register_sets(FRAGMENT_WRITE_BASE):
        load_registers(client, regs, [])
        for i, code in enumerate(CFRAG_READS):
            try:
                python = {f"rd{i}": getattr(dev, f"read_rd{i}")()}
            except ArithmeticError:
                python = {"error": (EDOM, ERANGE)}
            cpp = h.values(f"read rd{i}")
            if "error" in cpp:
                assert cpp["error"] in python.get("error", ()), (code, regs[4 * i : 4 * i + 4], cpp, python)
            else:
                assert_same_values(cpp, python)


def test_fragment_writes_agree_with_python(fragment_setup):
    """At the ends of, inside and outside each write fragment's range: the C++ driver writes the
    registers the Python driver writes, or both refuse the value."""
    dev, client, h = fragment_setup
    rng = random.Random(11)
    for i, (code, (lo, hi)) in enumerate(CFRAG_WRITES):
        address = FRAGMENT_WRITE_BASE + 2 * i
        for value in [lo, hi, (lo + hi) / 2, hi * 10 + 1, lo - hi - 1, *(rng.uniform(lo, hi) for _ in range(4))]:
            outcomes = []
            for driver in ("c++", "python"):
                assert not client.write_registers(address, [0xDEAD, 0xBEEF], device_id=1).isError()
                if driver == "c++":
                    failed = h.ask(f"write wr{i} {value!r}") != ["ok"]
                else:
                    try:
                        getattr(dev, f"write_wr{i}")(value)
                        failed = False
                    except (ArithmeticError, ValueError):
                        failed = True
                registers = client.read_holding_registers(address, count=2, device_id=1).registers
                outcomes.append("refused" if failed else registers)
            assert outcomes[0] == outcomes[1], (code, value, outcomes)


def test_example_program_builds_with_make_and_reads_the_simulator(tmp_path, sim_factory):
    import shutil
    import subprocess
    import sys

    toolchain()
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    src = EXAMPLE.parent / "cpp_reader"
    work = tmp_path / "cpp_reader"
    shutil.copytree(src, work, ignore=shutil.ignore_patterns("build"))
    make = ["make", "-C", str(work), f"MDL={sys.executable} -m mdl", f"MDL_FILE={EXAMPLE / 'temco_tstat.xml'}"]
    proc = subprocess.run(make, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "-m mdl gen" in proc.stdout
    sim = sim_factory(
        EXAMPLE / "temco_tstat.xml",
        "--set",
        "room_temperature=21.5",
        "--set",
        "serial_number=80012345",
        "--set",
        "fan_speed=2",
    )
    run = subprocess.run(
        [str(work / "build" / "tstat_reader"), "127.0.0.1", str(sim.port), "22.5"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == [
        "room temperature: 21.5",
        "serial number: 80012345",
        "occupied setpoint: 22.5",
        "fan speed: 2",
    ]
    again = subprocess.run(make, capture_output=True, text=True)
    assert "g++" not in again.stdout  # nothing to rebuild
    bad = subprocess.run(
        [str(work / "build" / "tstat_reader"), "127.0.0.1", str(sim.port), "45"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert bad.returncode == 1 and "Invalid argument" in bad.stderr


def test_hostile_text_stays_inside_comments_and_strings(tmp_path, write_device):
    import subprocess

    nasty = 'x */ int evil_symbol; /* \\ " ??/ &#10;// next\\'
    path = write_device(
        fn_xml("t", "1", format="UINT16", units=nasty).replace(
            "<description>t</description>", f"<description>{nasty}</description>"
        )
        # formats no other function has: their own code, under a comment that ends with the name
        + fn_xml("splice ??/", "2", format="INT32")
        + fn_xml("splice \\", "4", format="FLOAT32"),
        name=f"Dev {nasty} &#176;",
    )
    exe = build(load_device(path), tmp_path)
    nm = subprocess.run(["nm", "-C", str(exe)], capture_output=True, text=True).stdout
    assert "evil_symbol" not in nm
    header = next(tmp_path.glob("*.h")).read_text(encoding="utf-8")
    assert 'kDeviceName = "Dev x */ int evil_symbol; /* \\\\ \\" \\?\\?/ \\012// next\\\\ \\302\\260"' in header
    # in comments: UTF-8 as written, `*/`, `/*` and `??/` broken by a space, a final backslash made U+FF3C
    text = 'x * / int evil_symbol; / * \\ " ?? / // next'
    assert f" * Driver for Dev {text}\\ \u00b0: test\n" in header
    assert f"    /** {text}\uff3c [{text}\uff3c] */\n" in header
    driver = next(p for p in tmp_path.glob("*.cc") if p.name != "harness.cc")
    assert "\n// splice ?? /\n" in driver.read_text() and "\n// splice \uff3c\n" in driver.read_text()
    # where trigraphs count (before C++17, or with -trigraphs), `??/` ending a line would splice the next one
    gxx, cflags, _ = toolchain()
    proc = subprocess.run(
        [gxx, *STRICT, "-trigraphs", "-fsyntax-only", *cflags, str(driver)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr


def test_descriptions_reach_comments_as_utf8(tmp_path, write_device):
    path = write_device(
        fn_xml("t", "1", format="INT16", multiplier="0.1", units="&#176;C").replace(
            "<description>t</description>", "<description>Temperature in &#176;C, &#177;0.5 K</description>"
        )
    )
    build(load_device(path), tmp_path)
    header = next(tmp_path.glob("*.h")).read_text(encoding="utf-8")
    assert "    /** Read Temperature in \u00b0C, \u00b10.5 K [\u00b0C] */\n" in header
    assert "\\x" not in header and "\\260" not in header


# ---- what users' compilers and linters say about the drivers ----

GOLDEN_DRIVERS = [ROOT / "tests" / "golden" / "all_tables" / "all_tables.cc", EXAMPLE / "temco_tstat.cc"]
TEST_DEVICES = [p for p in sorted(DATA.glob("*.xml")) + sorted(EXAMPLE.parent.glob("*/*.xml"))]
QUICK_TEST_DEVICE = REFERENCE / "QuickTestDevice.yaml"


def _driver(device, source_name: str, directory: Path) -> Path:
    """The generated .cc of a device (its .h beside it), written into directory."""
    directory.mkdir(parents=True, exist_ok=True)
    for name, text in render(device, source_name, "cpp").items():
        (directory / name).write_text(text, encoding="utf-8")
    return next(directory.glob("*.cc"))


@pytest.mark.parametrize("compiler", COMPILERS)
@pytest.mark.parametrize("source", GOLDEN_DRIVERS + TEST_DEVICES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_drivers_compile_without_a_warning(compiler, source, tmp_path):
    """The golden drivers and those of the test devices (build() compiles every other driver the tests
    generate the same way, with both compilers)."""
    cc = source if source.suffix == ".cc" else _driver(load_device(source), source.name, tmp_path)
    assert compile_driver(cc, compiler).stat().st_size > 0


@pytest.mark.exhaustive  # clang-tidy takes seconds a driver: CI runs it, a quick local run need not
@pytest.mark.parametrize(
    "driver", ["all_tables", "temco_tstat", "formats", "fragments", "expressions", "flags_and_scale"]
)
def test_clang_tidy_finds_nothing(driver, tmp_path):
    if driver == "flags_and_scale":  # bits, function 22, scale_exponent and scale_by (issue 21)
        source = DATA / "flags_and_scale.xml"
        cc = _driver(load_device(source), source.name, tmp_path)
    elif driver in ("formats", "fragments"):  # every format and order; every fragment test_cfrag.py knows
        functions = DIFF_FUNCTIONS + BITS if driver == "formats" else FRAGMENT_READS + FRAGMENT_WRITES
        (tmp_path / "device.xml").write_text(device_xml(functions, name=driver))
        cc = _driver(load_device(tmp_path / "device.xml"), "device.xml", tmp_path / "out")
    elif driver == "expressions":
        if not QUICK_TEST_DEVICE.exists():
            pytest.skip(f"no conformance data at {QUICK_TEST_DEVICE}")
        cc = _driver(load_resolved(QUICK_TEST_DEVICE).device, QUICK_TEST_DEVICE.name, tmp_path)
    else:
        cc = next(p for p in GOLDEN_DRIVERS if p.stem == driver)
    proc = clang_tidy(cc)
    assert proc.returncode == 0 and "warning:" not in proc.stdout, proc.stdout + proc.stderr


def test_the_clang_tidy_checks_are_the_documented_ones():
    config = TIDY_CONFIG.read_text()
    checks = [c.strip().rstrip(",") for c in config.split("Checks: >-\n", 1)[1].split("\n") if c.startswith("  ")]
    assert "bugprone-*" in checks and "-modernize-use-trailing-return-type" in checks
    assert "WarningsAsErrors: '*'" in config
    doc = (ROOT / "docs" / "cpp-api.md").read_text(encoding="utf-8")
    assert all(f"`{c}`" in doc for c in checks), [c for c in checks if f"`{c}`" not in doc]


@pytest.mark.parametrize(
    "statement, compiles",
    [
        ("static_cast<void>(dev.read_all(&values));", True),
        ("if (dev.read_all(&values) == -1) { return 1; }", True),
        ("dev.read_all(&values);", False),
        ("dev.read_serial(&serial);", False),
        ("dev.write_mode(2);", False),
    ],
)
def test_an_ignored_status_does_not_compile(statement, compiles, tmp_path):
    import subprocess

    gxx, cflags, _ = toolchain()
    program = tmp_path / "user.cc"
    program.write_text(f"""#include "all_tables.h"

int main() {{
    AllTables dev(nullptr);
    AllTablesValues values;
    uint32_t serial = 0;
    {statement}
    return static_cast<int>(serial) + (values.pump ? 1 : 0);
}}
""")
    proc = subprocess.run(
        [gxx, *STRICT, "-fsyntax-only", *cflags, f"-I{GOLDEN_DRIVERS[0].parent}", str(program)],
        capture_output=True,
        text=True,
    )
    assert (proc.returncode == 0) == compiles, proc.stderr
    assert compiles or "nodiscard" in proc.stderr


COUNT_ALLOCATIONS = r"""#include "all_tables.h"

#include <cstdio>
#include <cstdlib>
#include <new>

static long allocations = 0;

void *operator new(std::size_t n) {
    ++allocations;
    void *p = std::malloc(n > 0 ? n : 1);
    if (p == nullptr) throw std::bad_alloc();
    return p;
}
void operator delete(void *p) noexcept { std::free(p); }
void operator delete(void *p, std::size_t) noexcept { std::free(p); }

int main(int argc, char **argv) {
    if (argc != 2) return 2;
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", std::atoi(argv[1]));
    modbus_set_slave(ctx, 1);
    if (modbus_connect(ctx) == -1) return 3;
    AllTables dev(ctx);
    AllTablesValues values;
    const long before = allocations;
    const int rc = dev.read_all(&values);
    std::printf("%d %ld %s\n", rc, allocations - before, values.label.c_str());
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}
"""


def test_read_all_allocates_nothing(tmp_path, sim_factory):
    """all_tables' one text value fits std::string's own buffer, so read_all needs no heap at all."""
    import subprocess

    gxx, cflags, libs = toolchain()
    (tmp_path / "count.cc").write_text(COUNT_ALLOCATIONS)
    exe = tmp_path / "count"
    proc = subprocess.run(
        [
            gxx,
            "-std=c++17",
            "-O0",
            *cflags,
            f"-I{GOLDEN_DRIVERS[0].parent}",
            "-o",
            str(exe),
            str(tmp_path / "count.cc"),
            str(compile_driver(GOLDEN_DRIVERS[0], "g++")),
            *libs,
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    sim = sim_factory(ALL, *ALL_SETTINGS)
    run = subprocess.run([str(exe), str(sim.port)], capture_output=True, text=True, timeout=30)
    assert run.stdout == "0 0 Hall\n", run.stdout + run.stderr
