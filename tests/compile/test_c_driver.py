"""Generated C99 drivers (mdl.targets.c): compiled by gcc and clang with the strict flags docs/c-api.md
promises, run against `mdl sim`, and compared value for value (floats bit for bit) with `mdl read`
and the generated Python driver, on the example devices and on random registers."""

from __future__ import annotations

import json
import math
import random
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient
from test_cpp_driver import (
    ALL_SETTINGS,
    BITS,
    DIFF_FUNCTIONS,
    DIFF_REGISTERS,
    FRAGMENT_READS,
    FRAGMENT_WRITES,
    load_registers,
    served_device,
)

from mdl.device.server.scenarios import matches
from mdl.formats.loading import load_any
from mdl.formats.mdl import load_device
from mdl.targets import render
from support.c_harness import COMPILERS, build, compile_driver
from support.common import DATA, EXAMPLE, REFERENCE, ROOT, fn_xml
from support.cpp_harness import MODBUS_ENOBASE, Harness
from support.devices import Sim
from support.run import run_mdl

ALL = DATA / "all_tables.xml"
HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"
XML_DEVICES = [p for p in sorted(DATA.glob("*.xml")) + sorted(EXAMPLE.parent.glob("*/*.xml"))]
DEVICES = [*XML_DEVICES, HEAT_PUMP]


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


def mdl_read(path: Path, sim) -> dict:
    """`mdl read --format json`, with enumerations as the number a driver reads (mdl read shows the label)."""
    proc = run_mdl("read", path, "--host", sim.host, "--port", sim.port, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    values = json.loads(proc.stdout, parse_constant=float)
    for fn in load_any(path).functions:
        if fn.values and isinstance(values.get(fn.name), str):
            values[fn.name] = next(k for k, label in fn.values.items() if label == values[fn.name])
    return values


@pytest.mark.parametrize("compiler", COMPILERS)
@pytest.mark.parametrize("source", DEVICES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_drivers_compile_without_a_warning(compiler, source, tmp_path):
    for name, text in render(load_any(source), source.name, "c").items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    c_file = next(tmp_path.glob("*.c"))
    assert "malloc" not in c_file.read_text() and "calloc" not in c_file.read_text()
    assert compile_driver(c_file, compiler).stat().st_size > 0


@pytest.mark.parametrize("source", XML_DEVICES, ids=lambda p: p.name)
def test_example_devices_read_as_mdl_read_does(source, tmp_path, sim_factory):
    device = load_device(source)
    exe = build(device, tmp_path, source.name)
    sim = sim_factory(source, *(ALL_SETTINGS if source == ALL else ()))
    with Harness(exe, sim.port) as h:
        got = h.values()
        want = mdl_read(source, sim)
        assert_exactly(got, want)
        for name in want:
            if " " not in name:
                assert_exactly(h.values(f"read {name}"), {name: want[name]})


def test_all_tables_values_and_writes_both_ways(tmp_path, sim_factory):
    exe = build(load_device(ALL), tmp_path, ALL.name)
    sim = sim_factory(ALL, *ALL_SETTINGS)
    with Harness(exe, sim.port) as h:
        c = h.values()
        assert c["setpoint"] == 21.5 and c["mode"] == 2 and c["label"] == "Hall"
        assert c["big"] == -5000000000 and c["serial"] == 305419896 and c["low_byte"] == -3
        assert c["pump"] is True and c["door_open"] is True
        # C writes, mdl read reads
        assert h.ask("write setpoint 23.5") == ["ok"]
        assert h.ask(f"write label {b'Kitchen'.hex()}") == ["ok"]
        assert h.ask("write big -42") == ["ok"]
        got = mdl_read(ALL, sim)
        assert got["setpoint"] == 23.5 and got["label"] == "Kitchen" and got["big"] == -42
        assert h.values(f"write label {b'abcdefghi'.hex()}") == {"error": 22}  # 9 bytes do not fit 8
        # mdl write writes, C reads
        proc = run_mdl("write", ALL, "--host", sim.host, "--port", sim.port, "setpoint=19.5", "label=Den", "big=-7")
        assert proc.returncode == 0, proc.stderr
        assert h.values("read setpoint") == {"setpoint": 19.5}
        assert h.values("read label") == {"label": "Den"}
        assert h.values("read big") == {"big": -7}
        assert_exactly(h.values(), mdl_read(ALL, sim))


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
    with Harness(exe, sim.port) as h:
        assert h.values("read c") == {"error": MODBUS_ENOBASE + 2}  # EMBXILADD
        assert h.values("read a") == {"a": 7}
        assert h.values() == {"error": MODBUS_ENOBASE + 2}
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
    with Harness(build(device2, tmp_path / "p2"), sim.port) as h:
        assert h.values() == {"a": 7, "b": 9}
        assert h.values() == {"a": 7, "b": 9}  # the refused group is remembered by the driver struct


def test_unreachable_device(tmp_path):
    exe = build(load_device(ALL), tmp_path, ALL.name)
    proc = subprocess.run([str(exe), "1"], input="", capture_output=True, text=True, timeout=30)
    assert proc.returncode == 1 and "connect failed" in proc.stdout


# ---- differential: random registers, the C driver, the Python driver and mdl read ----


@pytest.fixture(scope="module")
def diff_setup(tmp_path_factory):
    with served_device(tmp_path_factory, DIFF_FUNCTIONS + BITS, "Diff Device", build) as served:
        yield served


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
)
@given(
    regs=st.lists(st.integers(0, 0xFFFF), min_size=DIFF_REGISTERS, max_size=DIFF_REGISTERS),
    bits=st.lists(st.booleans(), min_size=2, max_size=2),
)
def test_c_and_python_agree_on_random_registers(diff_setup, regs, bits):
    _, module, client, h, _ = diff_setup
    load_registers(client, regs, bits)
    assert_exactly(h.values(), module.DiffDevice(client).read_all())


def test_mdl_read_agrees_with_the_c_driver(diff_setup):
    path, _, client, h, sim = diff_setup
    rng = random.Random(7)
    for _ in range(4):
        regs = [rng.choice([0, 0xFFFF, 0x8000, 0x7FFF, rng.randrange(65536)]) for _ in range(DIFF_REGISTERS)]
        load_registers(client, regs, [rng.random() < 0.5, rng.random() < 0.5])
        assert_exactly(h.values(), mdl_read(path, sim))


@pytest.mark.parametrize("name, value", [("v0", -5), ("v12", 200), ("v40", -1), ("v3", -32768)])
def test_writes_round_trip_both_ways(diff_setup, name, value):
    _, module, client, h, _ = diff_setup
    dev = module.DiffDevice(client)
    assert h.ask(f"write {name} {value}") == ["ok"]
    assert exactly(h.values(f"read {name}")[name], getattr(dev, f"read_{name}")())
    getattr(dev, f"write_{name}")(getattr(dev, f"read_{name}")())
    assert exactly(h.values(f"read {name}")[name], getattr(dev, f"read_{name}")())


def test_scaled_and_string_writes_round_trip(diff_setup):
    path, module, client, h, _ = diff_setup
    dev = module.DiffDevice(client)
    functions = load_device(path).functions
    for fn in [f for f in functions if f.multiplier]:
        assert h.ask(f"write {fn.name} 12.5") == ["ok"], fn.name
        assert exactly(h.values(f"read {fn.name}")[fn.name], getattr(dev, f"read_{fn.name}")())
        getattr(dev, f"write_{fn.name}")(7.5)
        assert exactly(h.values(f"read {fn.name}")[fn.name], getattr(dev, f"read_{fn.name}")())
    for fn in [f for f in functions if f.format == "STRING"]:
        assert h.ask(f"write {fn.name} {b'Abc'.hex()}") == ["ok"]
        assert getattr(dev, f"read_{fn.name}")() == "Abc"
        getattr(dev, f"write_{fn.name}")("xyz")
        assert h.values(f"read {fn.name}") == {fn.name: "xyz"}


@pytest.fixture(scope="module")
def fragment_setup(tmp_path_factory):
    functions = FRAGMENT_READS + FRAGMENT_WRITES
    with served_device(tmp_path_factory, functions, "Fragment Device", build) as (_, module, client, h, _):
        yield module.FragmentDevice(client), client, h


def test_fragment_reads_agree_with_python(fragment_setup):
    from test_cpp_driver import EDOM, ERANGE, FRAGMENT_WRITE_BASE, _register_sets

    from support.fragments import READS

    dev, client, h = fragment_setup
    for regs in _register_sets(FRAGMENT_WRITE_BASE):
        load_registers(client, regs, [])
        for i, code in enumerate(READS):
            try:
                python = {f"rd{i}": getattr(dev, f"read_rd{i}")()}
            except ArithmeticError:
                python = {"error": (EDOM, ERANGE)}
            got = h.values(f"read rd{i}")
            if "error" in got:
                assert got["error"] in python.get("error", ()), (code, got, python)
            else:
                assert_exactly(got, python)


# ---- Toolkit expressions: the heat pump example and the 59 reference scenarios ----

TOOLKIT_FILES = [HEAT_PUMP, *sorted(REFERENCE.glob("*.yaml"))]


@pytest.mark.parametrize("yaml_file", TOOLKIT_FILES, ids=lambda p: p.stem)
def test_toolkit_scenarios_through_the_c_driver(yaml_file, tmp_path):
    """One simulator per file serves scenario k at unit k; the C harness reads every unit and agrees
    with each scenario's expected values and, exactly, with the generated Python driver."""
    from support.drivers import python_device

    device = load_any(yaml_file)
    driver_cls = python_device(device, tmp_path)
    exe = build(device, tmp_path, yaml_file.name)
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
        assert_exactly(c_values[unit], python[unit])


def test_fragment_writes_agree_with_python(fragment_setup):
    """At the ends of, inside and outside each write fragment's range (test_cfrag.WRITES): the C driver
    writes the registers the Python driver writes, or both refuse the value."""
    from test_cpp_driver import FRAGMENT_WRITE_BASE

    from support.fragments import WRITES as CFRAG_WRITES

    dev, client, h = fragment_setup
    rng = random.Random(11)
    compared = 0
    for i, (code, (lo, hi)) in enumerate(CFRAG_WRITES):
        address = FRAGMENT_WRITE_BASE + 2 * i
        for value in [lo, hi, (lo + hi) / 2, hi * 10 + 1, lo - hi - 1, *(rng.uniform(lo, hi) for _ in range(4))]:
            outcomes = []
            for driver in ("c", "python"):
                assert not client.write_registers(address, [0xDEAD, 0xBEEF], device_id=1).isError()
                if driver == "c":
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
            compared += outcomes[0] != "refused"
    assert compared > len(CFRAG_WRITES)  # most values inside the ranges are written, not refused


# ---- hostile text: names, descriptions and units stay inside comments and string literals ----


def test_hostile_text_stays_inside_comments_and_strings(tmp_path, write_device, sim_factory):
    """`*/`, `/*`, `??/` (C99 has trigraphs), quotes, a `#define` after a line break, a final backslash
    and non-ASCII, in the device's name and a function's description and units, and function names
    ending in `??/` and `\\`: the driver compiles under STRICT with gcc and clang (build), declares
    nothing of the text, and reads as mdl read does. (Control characters and the header --lang all
    shares: tests/compile/test_c_all_header.py.)"""
    import re

    from support.c_harness import STRICT, tool
    from support.cpp_harness import modbus_flags

    nasty = 'x */ int evil_symbol; /* \\ " ??/ &#10;#define evil_macro 1&#10;// next\\'
    path = write_device(
        fn_xml("t", "1", format="UINT16", units=nasty).replace(
            "<description>t</description>", f"<description>{nasty}</description>"
        )
        + fn_xml("splice ??/", "2", format="UINT16")
        + fn_xml("splice \\", "3", format="UINT16"),
        name=f"Dev {nasty} &#176;",
    )
    exe = build(load_device(path), tmp_path)
    nm = subprocess.run(["nm", str(exe)], capture_output=True, text=True).stdout
    symbols = {line.split()[-1] for line in nm.splitlines() if line.strip()}
    assert "main" in symbols and not symbols & {"evil_symbol", "evil_macro"}
    header = next(tmp_path.glob("*.h")).read_text(encoding="utf-8")
    driver = next(p for p in tmp_path.glob("*.c") if p.name != "c_harness.c").read_text(encoding="utf-8")
    stem = next(tmp_path.glob("*.h")).stem
    assert (
        f'#define {stem.upper()}_DEVICE_NAME "Dev x */ int evil_symbol; /* \\\\ \\" \\?\\?/ \\012#define '
        f'evil_macro 1\\012// next\\\\ \\302\\260"\n'
    ) in header
    # in comments: UTF-8 as written, `*/`, `/*` and `??/` broken by a space, a final backslash made U+FF3C
    text = 'x * / int evil_symbol; / * \\ " ?? / #define evil_macro 1 // next'
    assert f" * Driver for Dev {text}\\ \u00b0: test\n" in header
    assert f"    /** {text}\uff3c [{text}\uff3c] */\n" in header
    assert "\n/* splice ?? / */\n" in driver and "\n/* splice \uff3c */\n" in driver
    for source in (header, driver):
        assert not re.search(r"^[ \t]*#[ \t]*define[ \t]+evil", source, re.M)
        assert not [line for line in source.splitlines() if line.endswith(("\\", "??/"))]
    # the control: under STRICT (-std=c99: trigraphs on) a comment ending in `??/` splices the next line
    spliced = tmp_path / "spliced.c"
    spliced.write_text("/* splice */\n// splice ??/\nint evil_symbol;\n")
    cflags, _ = modbus_flags()
    proc = subprocess.run(
        [tool("gcc"), *STRICT, "-fsyntax-only", *cflags, str(spliced)], capture_output=True, text=True
    )
    assert proc.returncode != 0 and "trigraph" in proc.stderr, proc.stderr
    # served under a plain name: `mdl sim` prints the device's name, line breaks and all, in its banner
    served = tmp_path / "served.xml"
    served.write_text(path.read_text(encoding="ascii").replace(f"<name>Dev {nasty} &#176;</name>", "<name>Dev</name>"))
    sim = sim_factory(served, "--set", "t=7", "--set", "splice ??/=8")
    with Harness(exe, sim.port) as h:
        values = h.values()
        assert values["t"] == 7 and values["splice ??/"] == 8
        assert_exactly(values, mdl_read(served, sim))


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


def test_hostile_expression_labels_stay_inside_string_literals(tmp_path):
    """Toolkit enum and bitset labels become string literals of the C driver: `*/`, `??/`, quotes,
    backslashes and non-ASCII there compile under STRICT (gcc and clang) and read back byte for byte,
    as the generated Python driver reads them."""
    from support.drivers import python_device

    path = tmp_path / "hostile.yaml"
    path.write_text(_hostile_toolkit(), encoding="utf-8")
    device = load_any(path)
    assert [f.description for f in device.functions] == ["Mode */ #define evil_macro 1 ??/", "Active alarms \\"]
    driver_cls = python_device(device, tmp_path)
    exe = build(device, tmp_path, path.name)
    nm = subprocess.run(["nm", str(exe)], capture_output=True, text=True).stdout
    assert not {line.split()[-1] for line in nm.splitlines() if line.strip()} & {"evil_symbol", "evil_macro"}
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
