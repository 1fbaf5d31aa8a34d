"""Generated C++ drivers: compiled with -Wall -Wextra -Werror (and once with ASan/UBSan), run against
`mdl sim`, and compared with the generated Python driver and `mdl read` on random registers."""

from __future__ import annotations

import json
import math

import pytest
from conftest import DATA, EXAMPLE, Sim, fn_xml, import_generated, run_mdl
from cpp_harness import MODBUS_ENOBASE, Harness, build, toolchain
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from mdl.gen import render
from mdl.layout import layout
from mdl.mdlxml import load_device

ALL = DATA / "all_tables.xml"
ALL_SETTINGS = ["--set", "setpoint=21.5", "--set", "mode=Cool", "--set", "label=Hall", "--set", "energy=1234.567",
                "--set", "power=-12.5", "--set", "big=-5000000000", "--set", "temp_offset=-10",
                "--set", "serial=305419896", "--set", "low_byte=-3", "--set", "high_byte=200", "--set", "pump=1",
                "--set", "flow=12.3", "--set", "door_open=1"]


def same(a, b) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            return a is b
        a, b = float(a), float(b)
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return a == b or math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-300)
    return a == b


def assert_same_values(cpp: dict, py: dict):
    assert set(cpp) == set(py), (set(cpp) ^ set(py))
    for name in py:
        assert same(cpp[name], py[name]), (name, cpp[name], py[name])


@pytest.fixture(scope="module")
def all_tables_cpp(tmp_path_factory):
    return build(load_device(ALL), tmp_path_factory.mktemp("cpp_all"))


def _python_values(path, sim, module_name):
    out = path.parent / f"py_{module_name}"
    out.mkdir(exist_ok=True)
    assert run_mdl("gen", path, "--lang", "python", "-o", out).returncode == 0
    device = load_device(path)
    from mdl.names import identifier

    module = import_generated(out / f"{identifier(device.name)}.py", module_name)
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        cls = next(getattr(module, n) for n in module.__all__ if not n.startswith("Async") and n[0].isupper()
                   and n not in ("DeviceError", "CommunicationError", "ModbusExceptionError", "ValueRangeError"))
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
    exe = build(load_device(EXAMPLE / "temco_tstat.xml"), tmp_path)
    sim = sim_factory(EXAMPLE / "temco_tstat.xml", "--set", "room_temperature=21.5", "--set", "serial_number=80012345",
                      "--set", "firmware_version=4.6", "--set", "occupancy=1")
    h = Harness(exe, sim.port)
    try:
        values = h.values()
        assert values["room_temperature"] == 21.5 and values["serial_number"] == 80012345
        assert values["firmware_version"] == pytest.approx(4.6) and values["occupancy"] == 1.0
        assert h.ask("write occupied_setpoint 23.5") == ["ok"]
        assert h.ask("write occupied_setpoint 40") == [f"error {22}"]  # EINVAL: above the maximum
    finally:
        h.close()
    proc = run_mdl("read", EXAMPLE / "temco_tstat.xml", "--host", sim.host, "--port", sim.port, "occupied_setpoint",
                   "--format", "json")
    assert json.loads(proc.stdout) == {"occupied_setpoint": 23.5}


def test_sanitizers_find_nothing(sim_factory, tmp_path):
    exe = build(load_device(ALL), tmp_path, sanitize=True)
    sim = sim_factory(ALL, *ALL_SETTINGS)
    h = Harness(exe, sim.port)
    h.values()
    h.ask("write label 4b69746368656e")
    assert h.values("read label") == {"label": "Kitchen"}
    assert h.ask("write label 61626364656667686970") == [f"error {22}"]  # 10 bytes do not fit 8
    err = h.close()
    assert "runtime error" not in err and "AddressSanitizer" not in err


def test_modbus_exception_sets_errno_and_read_all_falls_back(tmp_path, write_device, sim_factory):
    described = load_device(write_device(
        fn_xml("a", "10", format="UINT16") + fn_xml("cmd", "11", format="UINT16", access="write")
        + fn_xml("b", "12", format="UINT16") + fn_xml("c", "40", format="INT16"), name="Planned"))
    actual = write_device(fn_xml("a", "10", format="UINT16") + fn_xml("b", "12", format="UINT16"),
                          name="Planned", filename="actual.xml")
    exe = build(described, tmp_path)
    sim = sim_factory(actual, "--set", "a=7", "--set", "b=9")
    h = Harness(exe, sim.port)
    try:
        assert h.values("read c") == {"error": MODBUS_ENOBASE + 2}  # EMBXILADD
        assert h.values("read a") == {"a": 7}
        assert h.values() == {"error": MODBUS_ENOBASE + 2}  # c cannot be read at all
    finally:
        h.close()
    device2 = load_device(write_device(fn_xml("a", "10", format="UINT16") + fn_xml("cmd", "11", format="UINT16", access="write")
                                       + fn_xml("b", "12", format="UINT16"), name="Planned", filename="p2.xml"))
    (tmp_path / "p2").mkdir()
    exe2 = build(device2, tmp_path / "p2")
    h = Harness(exe2, sim.port)
    try:
        assert h.values() == {"a": 7, "b": 9}
        assert h.values() == {"a": 7, "b": 9}
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


def _diff_functions() -> str:
    out, addr, n = [], 0, 0

    def add(**fields):
        nonlocal addr, n
        name = f"v{n}"
        n += 1
        xml = fn_xml(name, str(addr), **fields)
        out.append(xml)
        from mdl.model import Function

        fn = Function(name, name, [addr], length=fields.get("length"), count=int(fields["count"]) if "count" in fields else None,
                      format=fields.get("format"))
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
    add(format="INT32", not_implemented="0x80000000")
    add(format="UINT16", count="3")
    for code in READ_FRAGMENTS:
        add(format="UINT16", count="2", read_function_code=code.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;"))
    return "".join(out), addr


DIFF_FUNCTIONS, DIFF_REGISTERS = _diff_functions()
BITS = fn_xml("coil_a", "0", format="BIT", register_type="coil") + fn_xml("coil_b", "1", format="BIT", register_type="coil")


@pytest.fixture(scope="module")
def diff_setup(tmp_path_factory):
    toolchain()
    d = tmp_path_factory.mktemp("diff")
    from conftest import device_xml

    path = d / "diff.xml"
    path.write_text(device_xml(DIFF_FUNCTIONS + BITS, name="Diff Device"))
    device = load_device(path)
    exe = build(device, d)
    (d / "diff_device.py").write_text(render(device, "diff.xml", "python")["diff_device.py"])
    module = import_generated(d / "diff_device.py", "diff_device_py")
    sim = Sim(path)
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    h = Harness(exe, sim.port)
    yield path, module, client, h, sim
    h.close()
    client.close()
    sim.stop()


def _load(client, regs, bits):
    for start in range(0, len(regs), 120):
        assert not client.write_registers(start, regs[start:start + 120], device_id=1).isError()
    for i, b in enumerate(bits):
        assert not client.write_coil(i, b, device_id=1).isError()


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(regs=st.lists(st.integers(0, 0xFFFF), min_size=DIFF_REGISTERS, max_size=DIFF_REGISTERS),
       bits=st.lists(st.booleans(), min_size=2, max_size=2))
def test_cpp_python_agree_on_random_registers(diff_setup, regs, bits):
    _, module, client, h, _ = diff_setup
    _load(client, regs, bits)
    py = module.DiffDevice(client).read_all()
    assert_same_values(h.values(), py)


def test_mdl_read_agrees_with_both_drivers(diff_setup):
    import random

    path, module, client, h, sim = diff_setup
    rng = random.Random(7)
    for _ in range(4):
        regs = [rng.choice([0, 0xFFFF, 0x8000, 0x7FFF, rng.randrange(65536)]) for _ in range(DIFF_REGISTERS)]
        _load(client, regs, [rng.random() < 0.5, rng.random() < 0.5])
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
    sim = sim_factory(EXAMPLE / "temco_tstat.xml", "--set", "room_temperature=21.5", "--set", "serial_number=80012345",
                      "--set", "fan_speed=2")
    run = subprocess.run([str(work / "build" / "tstat_reader"), "127.0.0.1", str(sim.port), "22.5"],
                         capture_output=True, text=True, timeout=30)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["room temperature: 21.5", "serial number: 80012345",
                                       "occupied setpoint: 22.5", "fan speed: 2"]
    again = subprocess.run(make, capture_output=True, text=True)
    assert "g++" not in again.stdout  # nothing to rebuild
    bad = subprocess.run([str(work / "build" / "tstat_reader"), "127.0.0.1", str(sim.port), "45"],
                         capture_output=True, text=True, timeout=30)
    assert bad.returncode == 1 and "Invalid argument" in bad.stderr


def test_hostile_text_stays_inside_comments_and_strings(tmp_path, write_device):
    import subprocess

    nasty = 'x */ int evil_symbol; /* \\ " ??/ &#10;// next\\'
    path = write_device(fn_xml("t", "1", format="UINT16", units=nasty).replace(
        "<description>t</description>", f"<description>{nasty}</description>"), name=f"Dev {nasty} &#176;")
    exe = build(load_device(path), tmp_path)
    nm = subprocess.run(["nm", "-C", str(exe)], capture_output=True, text=True).stdout
    assert "evil_symbol" not in nm
    header = next(tmp_path.glob("*.h")).read_text()
    assert "kDeviceName = \"Dev x */ int evil_symbol; /* \\\\ \\\" \\?\\?/ \\012// next\\\\ \\302\\260\"" in header
