"""Generated C99 and C++ drivers, one suite parametrized by target (`Native`, tests/support/drivers.py):
compiled by gcc and clang (C) or g++ and clang++ (C++) with the strict flags docs/c-api.md and
docs/cpp-api.md promise (and with ASan/UBSan), run against `mdl sim`, and compared value for value with
`mdl read` and the generated Python driver (floats bit for bit; C text as C text), on the example devices,
every format, order, length, scaling and fragment, hostile text, and random registers.

What only one language has is at the end, in its own section: C++ (clang-tidy, `[[nodiscard]]`, the
allocation count, the make example) and C (the Toolkit reference scenarios; the C++ driver runs them in
tests/unit/formats/toolkit/test_toolkit.py)."""

from __future__ import annotations

import json
import math
import random
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from mdl.device.server.scenarios import matches
from mdl.formats.loading import load_any, load_resolved
from mdl.formats.mdl import load_device
from mdl.model import Function
from mdl.model.layout import layout
from mdl.model.names import identifier
from support.common import DATA, EXAMPLE, REFERENCE, ROOT, device_xml, fn_xml, import_generated
from support.cpp_harness import MODBUS_ENOBASE, TIDY_CONFIG, Harness, clang_tidy, modbus_flags, toolchain
from support.devices import Sim
from support.drivers import (
    CPP,
    NATIVES,
    TARGETS,
    assert_exactly,
    load_registers,
    mdl_read,
    python_device,
    served_device,
)
from support.fragments import READS as CFRAG_READS
from support.fragments import WRITES as CFRAG_WRITES
from support.raw_images import ALL_SETTINGS
from support.run import run_mdl

ALL = DATA / "all_tables.xml"
HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"
XML_DEVICES = [p for p in sorted(DATA.glob("*.xml")) + sorted(EXAMPLE.parent.glob("*/*.xml"))]
DEVICES = [*XML_DEVICES, HEAT_PUMP]
GOLDEN_DRIVERS = {
    target: [
        ROOT / "tests" / "golden" / "all_tables" / f"all_tables{native.suffix}",
        EXAMPLE / f"temco_tstat{native.suffix}",
    ]
    for target, native in NATIVES.items()
}
QUICK_TEST_DEVICE = REFERENCE / "QuickTestDevice.yaml"


@pytest.fixture(params=TARGETS)
def native(request):
    return NATIVES[request.param]


@pytest.fixture(scope="module", params=TARGETS)
def all_tables(request, tmp_path_factory):
    """(native, the test program of all_tables.xml's driver)"""
    native = NATIVES[request.param]
    return native, native.build(load_device(ALL), tmp_path_factory.mktemp(f"{native}_all"), ALL.name)


def _source_id(p: Path) -> str:
    return f"{p.parent.name}/{p.name}"


@pytest.mark.parametrize(
    "target, compiler, source",
    [
        pytest.param(target, compiler, source, id=f"{target}-{_source_id(source)}-{compiler}")
        for target, native in NATIVES.items()
        for source in GOLDEN_DRIVERS[target] + DEVICES
        for compiler in native.compilers
    ],
)
def test_drivers_compile_without_a_warning(target, compiler, source, tmp_path):
    """The golden drivers and those of the test devices and the Toolkit example (build() compiles every
    other driver the tests generate the same way, with both compilers); a C driver never allocates."""
    native = NATIVES[target]
    driver = source if source.suffix == native.suffix else native.generate(load_any(source), source.name, tmp_path)
    text = driver.read_text(encoding="utf-8")
    assert native.allocates or ("malloc" not in text and "calloc" not in text)
    assert native.compile_driver(driver, compiler).stat().st_size > 0


@pytest.mark.parametrize("source", XML_DEVICES, ids=lambda p: p.name)
def test_example_devices_read_as_mdl_read_does(native, source, tmp_path, sim_factory):
    exe = native.build(load_device(source), tmp_path, source.name)
    sim = sim_factory(source, *(ALL_SETTINGS if source == ALL else ()))
    with Harness(exe, sim.port) as h:
        got = h.values()
        want = mdl_read(source, sim)
        assert_exactly(got, want)
        for name in want:
            if " " not in name:
                assert_exactly(h.values(f"read {name}"), {name: want[name]})


def _python_values(path, sim, module_name):
    out = path.parent / f"py_{module_name}"
    out.mkdir(exist_ok=True)
    assert run_mdl("gen", path, "--lang", "python", "-o", out).returncode == 0
    device = load_device(path)
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


def test_all_tables_read_as_python_and_writes_go_both_ways(all_tables, sim_factory, tmp_path):
    native, exe = all_tables
    sim = sim_factory(ALL, *ALL_SETTINGS)
    with Harness(exe, sim.port) as h:
        values = h.values()
        assert values["setpoint"] == 21.5 and values["mode"] == 2 and values["label"] == "Hall"
        assert values["big"] == -5000000000 and values["serial"] == 305419896 and values["low_byte"] == -3
        assert values["pump"] is True and values["door_open"] is True and values["voltage"] == 0.0
        copy = tmp_path / "all_tables.xml"
        copy.write_text(ALL.read_text())
        native.assert_agree(values, _python_values(copy, sim, f"all_tables_py_{native}"))
        assert h.values("read energy") == {"energy": 1234.567}
        assert h.values("read power") == {"power": -12.5}
        # the driver writes, mdl read reads
        assert h.ask("write setpoint 23.5") == ["ok"]
        assert h.ask(f"write label {b'Kitchen'.hex()}") == ["ok"]
        assert h.ask("write big -42") == ["ok"]
        got = mdl_read(ALL, sim)
        assert got["setpoint"] == 23.5 and got["label"] == "Kitchen" and got["big"] == -42
        assert h.values(f"write label {b'abcdefghi'.hex()}") == {"error": 22}  # 9 bytes do not fit 8
        # mdl write writes, the driver reads
        proc = run_mdl("write", ALL, "--host", sim.host, "--port", sim.port, "setpoint=19.5", "label=Den", "big=-7")
        assert proc.returncode == 0, proc.stderr
        assert h.values("read setpoint") == {"setpoint": 19.5}
        assert h.values("read label") == {"label": "Den"}
        assert h.values("read big") == {"big": -7}
        assert_exactly(h.values(), mdl_read(ALL, sim))


def test_examples_compile_and_read(native, sim_factory, tmp_path):
    exe = native.build(load_device(EXAMPLE / "temco_tstat.xml"), tmp_path, "temco_tstat.xml")
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
    with Harness(exe, sim.port) as h:
        values = h.values()
        assert values["room_temperature"] == 21.5 and values["serial_number"] == 80012345
        assert values["firmware_version"] == 4.6 and values["occupancy"] == 1.0
        assert h.ask("write occupied_setpoint 23.5") == ["ok"]
        assert h.values("write occupied_setpoint 40") == {"error": 22}  # EINVAL: above the maximum
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


def test_sanitizers_find_nothing(native, sim_factory, tmp_path):
    exe = native.build_sanitized(load_device(ALL), tmp_path)
    sim = sim_factory(ALL, *ALL_SETTINGS)
    h = Harness(exe, sim.port)
    h.values()
    h.ask("write label 4b69746368656e")
    assert h.values("read label") == {"label": "Kitchen"}
    assert h.values("write label 61626364656667686970") == {"error": 22}  # 10 bytes do not fit 8
    err = h.close()
    assert "runtime error" not in err and "AddressSanitizer" not in err


def test_modbus_exception_sets_errno_and_read_all_falls_back(native, tmp_path, write_device, sim_factory):
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
    exe = native.build(described, tmp_path)
    sim = sim_factory(actual, "--set", "a=7", "--set", "b=9")
    with Harness(exe, sim.port) as h:
        assert h.values("read c") == {"error": MODBUS_ENOBASE + 2}  # EMBXILADD
        assert h.values("read a") == {"a": 7}
        assert h.values() == {"error": MODBUS_ENOBASE + 2}  # c cannot be read at all
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
    with Harness(native.build(device2, tmp_path / "p2"), sim.port) as h:
        assert h.values() == {"a": 7, "b": 9}
        assert h.values() == {"a": 7, "b": 9}  # the refused group is remembered by the driver


# each target's table of the requests a refused group is split into: (start, count) of the holding registers
SPLITS = {
    "c": re.compile(r"^    \{MDL_HOLDING, (\d+), (\d+), \d+U\},$", re.M),
    "cpp": re.compile(r"^    \{kHolding, (\d+), (\d+), \d+\},$", re.M),
}


def test_functions_sharing_registers_share_their_smaller_request(native, tmp_path, write_device, sim_factory):
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
    exe = native.build(described, tmp_path)
    splits = SPLITS[native.target].findall((tmp_path / f"shared{native.suffix}").read_text())
    assert splits == [("10", "1"), ("12", "2"), ("13", "1")]
    sim = sim_factory(actual, "--set", "a=7", "--set", "b=65539")
    with Harness(exe, sim.port) as h:
        assert h.values() == {"a": 7, "a_again": 7, "b": 65539, "b_low": 3, "b_again": 65539}


def test_unreachable_device(all_tables):
    _, exe = all_tables
    proc = subprocess.run([str(exe), "1"], input="", capture_output=True, text=True, timeout=30)
    assert proc.returncode == 1 and "connect failed" in proc.stdout


# ---- differential: random registers; the native driver, the Python driver and mdl read ----

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
        out.append(fn_xml(name, str(addr), **fields))
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


@pytest.fixture(scope="module", params=TARGETS)
def diff_setup(request, tmp_path_factory):
    """(native, path, Python driver module, client, harness, sim) of the device of every format"""
    native = NATIVES[request.param]
    with served_device(tmp_path_factory, DIFF_FUNCTIONS + BITS, "Diff Device", native.build) as served:
        yield (native, *served)


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
)
@given(
    regs=st.lists(st.integers(0, 0xFFFF), min_size=DIFF_REGISTERS, max_size=DIFF_REGISTERS),
    bits=st.lists(st.booleans(), min_size=2, max_size=2),
)
def test_native_and_python_agree_on_random_registers(diff_setup, regs, bits):
    native, _, module, client, h, _ = diff_setup
    load_registers(client, regs, bits)
    native.assert_agree(h.values(), module.DiffDevice(client).read_all())


def test_mdl_read_agrees_with_both_drivers(diff_setup):
    native, path, module, client, h, sim = diff_setup
    rng = random.Random(7)
    for _ in range(4):
        regs = [rng.choice([0, 0xFFFF, 0x8000, 0x7FFF, rng.randrange(65536)]) for _ in range(DIFF_REGISTERS)]
        load_registers(client, regs, [rng.random() < 0.5, rng.random() < 0.5])
        py = module.DiffDevice(client).read_all()
        cli = mdl_read(path, sim)
        for name, value in py.items():
            got = cli[name]
            if isinstance(value, float) and not math.isfinite(value):
                assert str(got) == str(value)
            else:
                assert got == value, (name, got, value)
        values = h.values()
        native.assert_agree(values, py)
        native.assert_agree(values, cli)


@pytest.mark.parametrize("name, value", [("v0", -5), ("v12", 200), ("v40", -1), ("v3", -32768)])
def test_writes_round_trip_both_ways(diff_setup, name, value):
    native, _, module, client, h, _ = diff_setup
    dev = module.DiffDevice(client)
    assert h.ask(f"write {name} {value}") == ["ok"]
    assert native.same(h.values(f"read {name}")[name], getattr(dev, f"read_{name}")())
    getattr(dev, f"write_{name}")(getattr(dev, f"read_{name}")())
    assert native.same(h.values(f"read {name}")[name], getattr(dev, f"read_{name}")())


def test_scaled_and_string_writes_round_trip(diff_setup):
    native, path, module, client, h, _ = diff_setup
    dev = module.DiffDevice(client)
    functions = load_device(path).functions
    for fn in [f for f in functions if f.multiplier]:
        assert h.ask(f"write {fn.name} 12.5") == ["ok"], fn.name
        assert native.same(h.values(f"read {fn.name}")[fn.name], getattr(dev, f"read_{fn.name}")())
        getattr(dev, f"write_{fn.name}")(7.5)
        assert native.same(h.values(f"read {fn.name}")[fn.name], getattr(dev, f"read_{fn.name}")())
    for fn in [f for f in functions if f.format == "STRING"]:
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


@pytest.fixture(scope="module", params=TARGETS)
def fragment_setup(request, tmp_path_factory):
    """(native, the Python driver, client, harness) of the device of every fragment"""
    native = NATIVES[request.param]
    functions = FRAGMENT_READS + FRAGMENT_WRITES
    with served_device(tmp_path_factory, functions, "Fragment Device", native.build) as (_, module, client, h, _):
        yield native, module.FragmentDevice(client), client, h


def _register_sets(n: int) -> list[list[int]]:
    rng = random.Random(3)
    edges = [[value] * n for value in (0, 1, 0x7FFF, 0x8000, 0xFFFF)]
    return edges + [
        [rng.choice([0, 1, 2, 0x7FFF, 0x8000, 0xFFFF, rng.randrange(65536)]) for _ in range(n)] for _ in range(6)
    ]


def test_fragment_reads_agree_with_python(fragment_setup):
    """Value for value, and failure (EDOM, ERANGE) for failure."""
    native, dev, client, h = fragment_setup
    for regs in _register_sets(FRAGMENT_WRITE_BASE):
        load_registers(client, regs, [])
        for i, code in enumerate(CFRAG_READS):
            try:
                python = {f"rd{i}": getattr(dev, f"read_rd{i}")()}
            except ArithmeticError:
                python = {"error": (EDOM, ERANGE)}
            got = h.values(f"read rd{i}")
            if "error" in got:
                assert got["error"] in python.get("error", ()), (code, regs[4 * i : 4 * i + 4], got, python)
            else:
                native.assert_agree(got, python)


def test_fragment_writes_agree_with_python(fragment_setup):
    """At the ends of, inside and outside each write fragment's range (support/fragments.py's WRITES): the
    native driver writes the registers the Python driver writes, or both refuse the value."""
    native, dev, client, h = fragment_setup
    rng = random.Random(11)
    compared = 0
    for i, (code, (lo, hi)) in enumerate(CFRAG_WRITES):
        address = FRAGMENT_WRITE_BASE + 2 * i
        for value in [lo, hi, (lo + hi) / 2, hi * 10 + 1, lo - hi - 1, *(rng.uniform(lo, hi) for _ in range(4))]:
            outcomes = []
            for driver in (native.target, "python"):
                assert not client.write_registers(address, [0xDEAD, 0xBEEF], device_id=1).isError()
                if driver == "python":
                    try:
                        getattr(dev, f"write_wr{i}")(value)
                        failed = False
                    except (ArithmeticError, ValueError):
                        failed = True
                else:
                    failed = h.ask(f"write wr{i} {value!r}") != ["ok"]
                registers = client.read_holding_registers(address, count=2, device_id=1).registers
                outcomes.append("refused" if failed else registers)
            assert outcomes[0] == outcomes[1], (code, value, outcomes)
            compared += outcomes[0] != "refused"
    assert compared > len(CFRAG_WRITES)  # most values inside the ranges are written, not refused


# ---- hostile text: names, descriptions, units and labels stay inside comments and string literals ----

NASTY = 'x */ int evil_symbol; /* \\ " ??/ &#10;#define evil_macro 1&#10;// next\\'
NASTY_LITERAL = 'Dev x */ int evil_symbol; /* \\\\ \\" \\?\\?/ \\012#define evil_macro 1\\012// next\\\\ \\302\\260'
# each target's device name constant (stem -> its line) and the comments over the two functions' own code
NAME_CONSTANT = {
    "c": lambda stem: f'#define {stem.upper()}_DEVICE_NAME "{NASTY_LITERAL}"\n',
    "cpp": lambda stem: f'kDeviceName = "{NASTY_LITERAL}";\n',
}
SPLICE_COMMENTS = {
    "c": ("\n/* splice ?? / */\n", "\n/* splice \uff3c */\n"),
    "cpp": ("\n// splice ?? /\n", "\n// splice \uff3c\n"),
}
TRIGRAPHS = {"c": [], "cpp": ["-trigraphs"]}  # -std=c99 has them on; C++17 has none unless asked


def test_hostile_text_stays_inside_comments_and_strings(native, tmp_path, write_device, sim_factory):
    """`*/`, `/*`, `??/` (trigraphs: C99 has them), quotes, a `#define` after a line break, a final
    backslash and non-ASCII, in the device's name and a function's description and units, and function
    names ending in `??/` and `\\` (formats no other function has: their own code, under a comment that
    ends with the name): the driver compiles under the strict flags with both compilers (build) and with
    trigraphs on, declares nothing of the text, and reads as mdl read does. (Control characters and the
    header --lang all shares: tests/compile/test_c_all_header.py.)"""
    path = write_device(
        fn_xml("t", "1", format="UINT16", units=NASTY).replace(
            "<description>t</description>", f"<description>{NASTY}</description>"
        )
        + fn_xml("splice ??/", "2", format="INT32")
        + fn_xml("splice \\", "4", format="FLOAT32"),
        name=f"Dev {NASTY} &#176;",
    )
    exe = native.build(load_device(path), tmp_path)
    nm = subprocess.run(["nm", "-C", str(exe)], capture_output=True, text=True).stdout
    symbols = {line.split()[-1] for line in nm.splitlines() if line.strip()}
    assert "main" in symbols and not symbols & {"evil_symbol", "evil_macro"}
    if native.target == "cpp":  # C's functions carry the device's stem (`dev_x_int_evil_symbol_..._init`)
        assert "evil_symbol" not in nm and "evil_macro" not in nm
    header_file = next(tmp_path.glob("*.h"))
    header = header_file.read_text(encoding="utf-8")
    driver_file = next(p for p in tmp_path.glob(f"*{native.suffix}") if p.name != native.program)
    driver = driver_file.read_text(encoding="utf-8")
    assert NAME_CONSTANT[native.target](header_file.stem) in header
    # in comments: UTF-8 as written, `*/`, `/*` and `??/` broken by a space, a final backslash made U+FF3C
    text = 'x * / int evil_symbol; / * \\ " ?? / #define evil_macro 1 // next'
    assert f" * Driver for Dev {text}\\ \u00b0: test\n" in header
    assert f"    /** {text}\uff3c [{text}\uff3c] */\n" in header
    assert all(comment in driver for comment in SPLICE_COMMENTS[native.target]), driver
    for source in (header, driver):
        assert not re.search(r"^[ \t]*#[ \t]*define[ \t]+evil", source, re.M)
        assert not [line for line in source.splitlines() if line.endswith(("\\", "??/"))]
    # where trigraphs count, the driver still compiles; the control: there a comment ending in `??/` splices
    # the next line
    cflags, _ = modbus_flags()
    compiler = native.tool(native.compilers[0])
    flags = [*native.strict, *TRIGRAPHS[native.target], "-fsyntax-only", *cflags]
    proc = subprocess.run([compiler, *flags, str(driver_file)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    spliced = tmp_path / f"spliced{native.suffix}"
    spliced.write_text("/* splice */\n// splice ??/\nint evil_symbol;\n")
    proc = subprocess.run([compiler, *flags, str(spliced)], capture_output=True, text=True)
    assert proc.returncode != 0 and "trigraph" in proc.stderr, proc.stderr
    # served under a plain name: `mdl sim` prints the device's name, line breaks and all, in its banner
    served = tmp_path / "served.xml"
    served.write_text(path.read_text(encoding="ascii").replace(f"<name>Dev {NASTY} &#176;</name>", "<name>Dev</name>"))
    sim = sim_factory(served, "--set", "t=7", "--set", "splice ??/=8")
    with Harness(exe, sim.port) as h:
        values = h.values()
        assert values["t"] == 7 and values["splice ??/"] == 8
        assert_exactly(values, mdl_read(served, sim))


def test_descriptions_reach_comments_as_utf8(native, tmp_path, write_device):
    path = write_device(
        fn_xml("t", "1", format="INT16", multiplier="0.1", units="&#176;C").replace(
            "<description>t</description>", "<description>Temperature in &#176;C, &#177;0.5 K</description>"
        )
    )
    native.build(load_device(path), tmp_path)
    header = next(tmp_path.glob("*.h")).read_text(encoding="utf-8")
    indent = "    " if native.target == "cpp" else ""  # a member of the C++ class, a function of C
    assert f"{indent}/** Read Temperature in \u00b0C, \u00b10.5 K [\u00b0C] */\n" in header
    assert "\\x" not in header and "\\260" not in header


MODE_LABELS = ["Off */ int evil_symbol; /*", "Heat ??/", 'Cool "q" \\', "D\u00e9frost \u00b0"]
ALARM_LABELS = ["a */ b", "??/", "\\", '\u00e9 "']


def _hostile_toolkit() -> str:
    """A Toolkit schema whose texts and enum and bitset labels hold `*/`, `??/`, quotes, backslashes and
    non-ASCII, with four scenarios (Mode 0..3)."""
    import yaml

    def mapping(labels: list[str]) -> str:
        return "; ".join(f"{i} -> '{label}'" for i, label in enumerate(labels))

    schema = {
        "description": 'Hostile */ ??/ "q" \\ \u00b0',
        "schemaFeatureLevel": 2,
        "blocks": [
            {
                "id": "Status",
                "description": "Block */ /* ??/",
                "fields": [
                    {
                        "id": "Mode",
                        "description": "Mode */ #define evil_macro 1 ??/",
                        "unit": "x */ ??/",
                        "expression": f"enum(hr:0 ; {mapping(MODE_LABELS)})",
                    },
                    {
                        "id": "Alarms",
                        "description": "Active alarms \\",
                        "expression": f"bitset(hr:1 ; {mapping(ALARM_LABELS)})",
                    },
                ],
            }
        ],
        "tests": [
            {
                "id": f"S{mode}",
                "description": f"mode {mode}",
                "input": [{"firstAddress": "hr:0", "rawValues": f"{mode:04X} {alarms:04X}"}],
            }
            for mode, alarms in ((0, 0b0001), (1, 0b0010), (2, 0b0100), (3, 0b1111))
        ],
    }
    return yaml.safe_dump(schema, allow_unicode=True, sort_keys=False)


def test_hostile_expression_labels_stay_inside_string_literals(native, tmp_path):
    """Toolkit enum and bitset labels become string literals of the driver: `*/`, `??/`, quotes,
    backslashes and non-ASCII there compile under the strict flags (both compilers) and read back byte
    for byte, as the generated Python driver reads them."""
    path = tmp_path / "hostile.yaml"
    path.write_text(_hostile_toolkit(), encoding="utf-8")
    device = load_any(path)
    assert [f.description for f in device.functions] == ["Mode */ #define evil_macro 1 ??/", "Active alarms \\"]
    driver_cls = python_device(device, tmp_path)
    exe = native.build(device, tmp_path, path.name)
    nm = subprocess.run(["nm", "-C", str(exe)], capture_output=True, text=True).stdout
    assert "evil_symbol" not in nm and "evil_macro" not in nm
    sim = Sim([path] * len(device.tests), *[arg for sc in device.tests for arg in ("--scenario", sc.id)])
    try:
        client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
        assert client.connect()
        try:
            python = {unit: driver_cls(client, unit=unit).read_all() for unit in sim.units}
        finally:
            client.close()
        for unit, mode in zip(sim.units, range(4), strict=True):
            assert python[unit]["Mode"] == MODE_LABELS[mode]
            with Harness(exe, sim.port, unit=unit) as h:
                assert_exactly(h.values(), python[unit])
    finally:
        sim.stop()
    assert python[sim.units[3]]["Alarms"] == ALARM_LABELS


# ---- C only: the Toolkit reference scenarios (the C++ driver's: tests/unit/formats/toolkit/test_toolkit.py) ----

TOOLKIT_FILES = [HEAT_PUMP, *sorted(REFERENCE.glob("*.yaml"))]


@pytest.mark.parametrize("yaml_file", TOOLKIT_FILES, ids=lambda p: p.stem)
def test_toolkit_scenarios_through_the_c_driver(yaml_file, tmp_path):
    """One simulator per file serves scenario k at unit k; the C harness reads every unit and agrees
    with each scenario's expected values and, exactly, with the generated Python driver."""
    c = NATIVES["c"]
    device = load_any(yaml_file)
    driver_cls = python_device(device, tmp_path)
    exe = c.build(device, tmp_path, yaml_file.name)
    sim = Sim([yaml_file] * len(device.tests), *[arg for sc in device.tests for arg in ("--scenario", sc.id)])
    try:
        client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
        assert client.connect()
        try:
            python = {unit: driver_cls(client, unit=unit).read_all() for unit in sim.units}
        finally:
            client.close()
        c_values = {}
        for unit in sim.units:
            with Harness(exe, sim.port, unit=unit) as h:
                c_values[unit] = h.values()
    finally:
        sim.stop()
    for unit, sc in zip(sim.units, device.tests, strict=True):
        for name, want in sc.expected.items():
            assert matches(c_values[unit][name], want), (sc.id, name, c_values[unit][name], want)
        c.assert_agree(c_values[unit], python[unit])


# ---- C++ only: the make example, clang-tidy, [[nodiscard]], a read_all without the heap ----


def test_example_program_builds_with_make_and_reads_the_simulator(tmp_path, sim_factory):
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


@pytest.mark.exhaustive  # clang-tidy takes seconds a driver: CI runs it, a quick local run need not
@pytest.mark.parametrize(
    "driver", ["all_tables", "temco_tstat", "formats", "fragments", "expressions", "flags_and_scale"]
)
def test_clang_tidy_finds_nothing(driver, tmp_path):
    if driver == "flags_and_scale":  # bits, function 22, scale_exponent and scale_by (issue 21)
        source = DATA / "flags_and_scale.xml"
        cc = CPP.generate(load_device(source), source.name, tmp_path)
    elif driver in ("formats", "fragments"):  # every format and order; every fragment test_cfrag.py knows
        functions = DIFF_FUNCTIONS + BITS if driver == "formats" else FRAGMENT_READS + FRAGMENT_WRITES
        (tmp_path / "device.xml").write_text(device_xml(functions, name=driver))
        cc = CPP.generate(load_device(tmp_path / "device.xml"), "device.xml", tmp_path / "out")
    elif driver == "expressions":
        if not QUICK_TEST_DEVICE.exists():
            pytest.skip(f"no conformance data at {QUICK_TEST_DEVICE}")
        cc = CPP.generate(load_resolved(QUICK_TEST_DEVICE).device, QUICK_TEST_DEVICE.name, tmp_path)
    else:
        cc = next(p for p in GOLDEN_DRIVERS["cpp"] if p.stem == driver)
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
        [gxx, *CPP.strict, "-fsyntax-only", *cflags, f"-I{GOLDEN_DRIVERS['cpp'][0].parent}", str(program)],
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
    """all_tables' one text value fits std::string's own buffer, so read_all needs no heap at all (a C
    driver never allocates: test_drivers_compile_without_a_warning)."""
    gxx, cflags, libs = toolchain()
    golden = GOLDEN_DRIVERS["cpp"][0]
    (tmp_path / "count.cc").write_text(COUNT_ALLOCATIONS)
    exe = tmp_path / "count"
    proc = subprocess.run(
        [
            gxx,
            "-std=c++17",
            "-O0",
            *cflags,
            f"-I{golden.parent}",
            "-o",
            str(exe),
            str(tmp_path / "count.cc"),
            str(CPP.compile_driver(golden, "g++")),
            *libs,
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    sim = sim_factory(ALL, *ALL_SETTINGS)
    run = subprocess.run([str(exe), str(sim.port)], capture_output=True, text=True, timeout=30)
    assert run.stdout == "0 0 Hall\n", run.stdout + run.stderr
