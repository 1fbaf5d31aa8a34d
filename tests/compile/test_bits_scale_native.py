"""Issue 21 in the C++ and C drivers: `bits` and `scale_exponent`/`scale_by` read and written by the
generated drivers exactly as `mdl read`/`write` and the Python driver do (docs/bits-and-scale.md), on
tests/data/flags_and_scale.xml and on random devices of tests/fuzz/test_fuzz_bits_scale.py's strategy,
registers served by `mdl sim` and compared bit for bit (floats too)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from mdl.device.evaluate import Evaluator
from mdl.diagnostics import MdlError
from mdl.formats.mdl import load_device
from mdl.ir import codec
from mdl.ir import steps as ir
from mdl.model import Device, Function
from mdl.resolver import resolve
from mdl.targets import render
from support import c_harness, cpp_harness
from support.bits_scale import DEVICE, SETS, WRITES, _raw, _read, devices
from support.common import device_xml, fn_xml, import_generated
from support.cpp_harness import Harness
from support.devices import Sim
from support.drivers import assert_exactly, mdl_read
from support.refusing_proxy import refusing_proxy
from support.run import cli, run_mdl

BUILDERS = {"cpp": cpp_harness.build, "c": c_harness.build}
EINVAL, ENODATA = 22, 61


def _text(value: object) -> str:
    """A value as the harness reads it from its command line."""
    if isinstance(value, bool):
        return "1" if value else "0"
    return repr(value)


def _harness(lang: str, tmp_path: Path, device=None) -> Path:
    return BUILDERS[lang](device if device is not None else load_device(DEVICE), tmp_path, source_name=DEVICE.name)


# ---- tests/data/flags_and_scale.xml


def test_both_drivers_read_as_mdl_read_and_python(sim_factory, tmp_path):
    sim = sim_factory(DEVICE, *[x for name, value in SETS.items() for x in ("--set", f"{name}={value}")])
    want = mdl_read(DEVICE, sim)
    assert want["w"] == 123.4 and want["fan_speed"] == 50.0 and want["alarm"] is True  # not all zero
    out = tmp_path / "py"
    assert run_mdl("gen", DEVICE, "--lang", "python", "-o", out).returncode == 0
    driver = import_generated(out / "flags_and_scale.py", "flags_and_scale_native")
    client = ModbusTcpClient(sim.host, port=sim.port)
    assert client.connect()
    try:
        assert_exactly(dict(driver.FlagsAndScale(client).read_all()), want)
    finally:
        client.close()
    for lang in BUILDERS:
        (tmp_path / lang).mkdir()
        with Harness(_harness(lang, tmp_path / lang), sim.port) as h:
            assert_exactly(h.values(), want)
            for name, value in want.items():
                assert_exactly(h.values(f"read {name}"), {name: value})


@pytest.mark.parametrize("lang", list(BUILDERS))
def test_writes_land_as_mdl_read_reads_them(lang, sim_factory, tmp_path):
    """Each value of test_bits_scale's WRITES, with the function codes the Python driver uses; only the
    function's bits change; what does not fit is refused before anything is sent."""
    exe = _harness(lang, tmp_path)
    sim = sim_factory(DEVICE, "--set", "status_high=63")
    codes: dict[str, list[int]] = {}
    with refusing_proxy(sim.host, sim.port) as proxy, Harness(exe, proxy.port) as h:
        for name, value in WRITES.items():
            before = len(proxy.codes)
            assert h.ask(f"write {name} {_text(value)}") == ["ok"], name
            codes[name] = proxy.codes[before:]
        before = len(proxy.codes)
        assert h.values("write fan_speed 200.0") == {"error": EINVAL}  # 16 does not fit 4 bits
        assert h.values("write mode 4") == {"error": EINVAL}
        assert proxy.codes[before:] == []  # refused before anything is sent
        assert h.ask("write w_sf -32768") == ["ok"]  # "not implemented": w has no value
        before = len(proxy.codes)
        assert h.values("write w 5.0") == {"error": ENODATA}
        assert proxy.codes[before:] == [3]  # the factor read, nothing written
        assert h.values("read w") == {"w": None}
    assert codes["enabled"] == [22] and codes["alarm"] == [3, 6] and codes["wmax_lim_pct"] == [3, 6]
    assert codes["status_high"] == [3, 16] and codes["mode"] == [3, 6]
    got = _read(sim)
    assert {name: got[name] for name in WRITES} == {**WRITES, "mode": "auto"}
    assert _raw(sim, 100, 1) == [0x8331]
    assert got["w"] is None


@pytest.mark.parametrize("lang", list(BUILDERS))
def test_a_scaled_write_uses_the_factor_the_device_has_now(lang, sim_factory, tmp_path):
    exe = _harness(lang, tmp_path)
    sim = sim_factory(DEVICE)
    with Harness(exe, sim.port) as h:
        assert h.ask("write wmax_lim_pct 55") == ["ok"]
        assert _raw(sim, 202, 1) == [5500]  # its initial factor, -2
        assert cli("write", DEVICE, *sim.connection, "wmax_lim_pct_sf=-1").returncode == 0
        assert h.values("read wmax_lim_pct") == {"wmax_lim_pct": 550.0}  # the old raw value, the new factor
        assert h.ask("write wmax_lim_pct 55.5") == ["ok"]
        assert _raw(sim, 202, 1) == [555]
        assert _read(sim, "wmax_lim_pct") == {"wmax_lim_pct": 55.5}
        assert cli("write", DEVICE, *sim.connection, "wmax_lim_pct_sf=0").returncode == 0
        assert h.ask("write wmax_lim_pct 42") == ["ok"]
        assert _raw(sim, 202, 1) == [42]
        assert h.values("write wmax_lim_pct 100.5") == {"error": EINVAL}  # above its maximum
        # scale_by, with a multiplier and an offset: (105 - 5) / 0.1 / 10 = 100
        assert h.ask("write energy 105") == ["ok"]
        assert _raw(sim, 211, 2) == [0, 100]
        assert _read(sim, "energy") == {"energy": 105.0}
        assert cli("write", DEVICE, *sim.connection, "energy_scale=0").returncode == 0
        assert h.values("write energy 5") == {"error": EINVAL}  # no raw value gives it with a factor of 0
        assert _raw(sim, 211, 2) == [0, 100]
        assert h.values("read energy") == {"energy": 5.0}  # 100 * 0.1 * 0 + 5
        assert h.ask("write w_sf 3") == ["ok"]
        assert h.values("write w 1e9") == {"error": EINVAL}  # 10^6 does not fit INT16
        assert h.ask("write w 12000") == ["ok"]
        assert _raw(sim, 201, 1) == [12]
        assert_exactly(h.values(), mdl_read(DEVICE, sim))


# ---- random devices: every function's value and every write as mdl computes them

SPAN = range(10, 32)  # the addresses the random devices use (tests/fuzz/test_fuzz_bits_scale.py)


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """One `mdl sim` serving a plain register at every address the random devices use."""
    path = tmp_path_factory.mktemp("served") / "served.xml"
    path.write_text(device_xml("".join(fn_xml(f"r{a}", str(a), format="UINT16") for a in SPAN), name="Served"))
    sim = Sim(path)
    client = ModbusTcpClient(sim.host, port=sim.port)
    assert client.connect()
    try:
        yield sim, client
    finally:
        client.close()
        assert sim.stop() == 0, sim.stderr


def _load(client, raw: dict[tuple[str, int], int]) -> None:
    regs = [raw.get(("holding", a), 0) for a in SPAN]
    assert not client.write_registers(SPAN[0], regs, device_id=1).isError()


def _regs(client, addresses: tuple[int, ...]) -> list[int]:
    got = client.read_holding_registers(SPAN[0], count=len(SPAN), device_id=1).registers
    return [got[a - SPAN[0]] for a in addresses]


EXAMPLES = int(os.environ.get("MDL_NATIVE_EXAMPLES", "6"))  # each builds two drivers: a few by default


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
@given(devices(), st.sampled_from([0.0, 1.5, -7.25, 123.0, 1e9]))
def test_random_devices_read_and_write_as_mdl(served, tmp_path_factory, case, scaled_value):
    """A longer run by hand: MDL_NATIVE_EXAMPLES=100 (docs/bits-and-scale.md)."""
    sim, client = served
    device, raw = case
    try:
        resolved = resolve(device)
    except MdlError:
        return  # refused, as the fuzz test's
    evaluator = Evaluator(resolved)
    names = [f.name for f in resolved.functions]
    lookup = lambda table, a: raw.get((table, a), 0)  # noqa: E731
    want = evaluator.values(names, lookup)
    for lang, build in BUILDERS.items():
        exe = build(device, tmp_path_factory.mktemp(lang))
        _load(client, raw)
        with Harness(exe, sim.port) as h:
            assert_exactly(h.values(), want)
            for name in names:
                assert_exactly(h.values(f"read {name}"), {name: want[name]})
            for f in resolved.functions:
                if f.fn.bits is not None:
                    _bits_writes_land(h, client, evaluator, f, raw)
            _scaled_write(h, client, evaluator, resolved.by_name["scaled"], want["sf"], scaled_value, raw)


def _bits_writes_land(h: Harness, client, evaluator: Evaluator, f, raw) -> None:
    merge = ir.find_step(f.codec.encode, ir.Merge)
    assert merge is not None
    low, high = f.fn.bit_range
    width = high - low + 1
    kind = f.codec.write_type.kind
    for raw_value in (0, 1, (1 << width) - 1, (1 << width) // 3):
        value = (
            bool(raw_value & 1)
            if width == 1
            else raw_value
            if kind == "int"
            else raw_value * f.fn.eff_multiplier + f.fn.eff_offset
        )
        _load(client, raw)
        current = _regs(client, f.layout.addresses)
        assert h.ask(f"write {f.name} {_text(value)}") == ["ok"], (f.name, value)
        expected = codec.merge(current, evaluator.encode(f.name, value), merge.masks)
        assert _regs(client, f.layout.addresses) == expected, (f.name, value)
    _load(client, raw)
    if width < 64 and kind != "bool":  # a value beyond the bits is refused, nothing written
        too_big = (1 << width) if kind == "int" else (1 << width) * f.fn.eff_multiplier + f.fn.eff_offset
        if not (kind == "int" and width in (8, 16, 32)):  # those do not fit the C type: nothing to send
            assert h.values(f"write {f.name} {_text(too_big)}") == {"error": EINVAL}, (f.name, too_big)
            assert _regs(client, f.layout.addresses) == [raw.get(("holding", a), 0) for a in f.layout.addresses]


def _scaled_write(h: Harness, client, evaluator: Evaluator, f, factor, value: float, raw) -> None:
    _load(client, raw)
    before = _regs(client, f.layout.addresses)
    try:
        expected = evaluator.encode(f.name, value, factor)
    except ValueError:  # mdl refuses it (no factor, a factor of 0, does not fit): so do the drivers
        missing = factor is None or (f.fn.scale_exponent is not None and not -22 <= factor <= 22)
        got = h.values(f"write {f.name} {_text(value)}")
        assert got == {"error": ENODATA if missing else EINVAL}, (value, factor, got)
        assert _regs(client, f.layout.addresses) == before
        return
    assert h.ask(f"write {f.name} {_text(value)}") == ["ok"], (value, factor)
    assert _regs(client, f.layout.addresses) == expected, (value, factor)


# ---- what only some devices have: each driver carries what it calls, and compiles without a warning

EDGES = {
    "write-only bits, one byte": [
        Function("low", "low byte bits", [1], format="UINT8", bits="1-3", access="write"),
        Function("flag", "a flag written with 16", [2], format="UINT16", bits="9", write_multiple=True),
    ],
    "only function 22": [Function("on", "on", [1], format="UINT16", bits="3", write_function_code="22")],
    "function 22 over two registers": [
        Function("mid", "mid", [1, 2], format="UINT32", bits="12-19", write_function_code="22")
    ],
    "scale_by only, wide factors": [
        Function("big", "a UINT64 factor", [10], format="UINT64"),
        Function("v", "scaled", [20], format="INT32", scale_by="big", offset=-1.5, access="write"),
        Function("field", "a factor of bits", [30], format="UINT16", bits="4-7"),
        Function("u", "scaled by bits", [31], format="UINT16", multiplier=0.25, scale_by="field"),
    ],
    "an exponent with a multiplier": [
        Function("sf", "sf", [1], format="INT16", not_implemented=["0x8000"]),
        Function("a", "a", [2], format="INT16", multiplier=0.1, scale_exponent="sf"),
        Function("b", "b", [3], format="UINT16", multiplier=3.0, scale_exponent="sf", access="read"),
    ],
}


@pytest.mark.parametrize("edge", list(EDGES))
@pytest.mark.parametrize("lang, compilers", [("cpp", cpp_harness.COMPILERS), ("c", c_harness.COMPILERS)])
def test_edge_devices_compile_without_a_warning(edge, lang, compilers, tmp_path):
    device = Device("Edge", "edge", EDGES[edge], version="1.0")
    resolve(device)  # valid
    for name, text in render(device, "edge.xml", lang).items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    source = next(tmp_path.glob("*.cc" if lang == "cpp" else "*.c"))
    for compiler in compilers:
        build = cpp_harness.compile_driver if lang == "cpp" else c_harness.compile_driver
        assert build(source, compiler).stat().st_size > 0
    text = source.read_text()
    assert ("mask_write" in text) == any(f.write_function_code == "22" for f in EDGES[edge])
    assert ("power_of_ten" in text) == any(f.scale_exponent for f in EDGES[edge])
