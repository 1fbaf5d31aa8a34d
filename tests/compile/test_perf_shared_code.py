"""The C++ and C drivers print one decoder and one encoder per shape of value IR (and one member or
function reading or writing one run of registers for it), so that 10,000 functions compile fast:
functions that share them must read and write exactly what functions of their own did, and IRs
that print differently (a bound of -0.0 and one of 0.0) must not be shared."""

from __future__ import annotations

import random

import pytest

from mdl.model import Device, Function
from mdl.model.layout import layout
from mdl.targets import render
from support.c_harness import build as build_c
from support.common import fn_xml
from support.drivers import assert_exactly, assert_same_values, load_registers, served_device

ORDERS = [("big", "big"), ("little", "little")]


def _repeated() -> tuple[str, int]:
    """Functions in pairs of the same IR (and a third on two runs of registers), every kind of value."""
    kinds = [
        dict(format=f, byte_order=b, word_order=w) for f in ("INT16", "UINT32", "FLOAT32", "FLOAT64") for b, w in ORDERS
    ]
    kinds += [
        dict(format="UINT8", length="Upper byte"),
        dict(format="INT16", multiplier="0.1", minimum="-50"),
        dict(format="UINT32", multiplier="0.01", offset="-273.15"),
        dict(format="STRING", count="3"),
        dict(format="UINT16", not_implemented="0xFFFF"),
        dict(format="INT32", write_multiple="true"),
    ]
    out, address = [], 0
    for i, kind in enumerate(kinds):
        size = len(
            layout(
                Function(
                    "x",
                    "",
                    [0],
                    format=kind["format"],
                    count=int(kind.get("count", 0)) or None,
                    length=kind.get("length"),
                )
            ).addresses
        )
        for copy in range(2):
            out.append(fn_xml(f"k{i}_{copy}", str(address), **kind))
            address += size
    # one more function of the IR of k2_0 and k2_1 (UINT32), on two runs of registers with one between
    out.append(fn_xml("runs", f"{address} {address + 2}", format="UINT32"))
    out.append(fn_xml("between", str(address + 1), format="INT16"))
    return "".join(out), address + 3


FUNCTIONS, REGISTERS = _repeated()
BITS = "".join(fn_xml(f"coil{i}", str(i), format="BIT", register_type="coil") for i in range(3))


def test_functions_of_one_ir_share_their_code_and_bounds_of_either_zero_do_not():
    functions = [
        Function(f"t{i}", "", [i], format="FLOAT32", minimum=bound, maximum=10.0)
        for i, bound in enumerate([0.0, -0.0, 0.0, -0.0])
    ]
    files = render(Device("Zeros", "bounds", functions), "zeros.xml", "all")
    py, cc, c, h = files["zeros.py"], files["zeros.cc"], files["zeros.c"], files["zeros.h"]
    assert "if value < -0.0:" in py and "if value < 0.0:" in py
    # two encoders, each shared by two functions, and a writer for each
    assert cc.count("\nint encode_") == 2 and "value < -0.0" in cc and "value < 0.0" in cc
    # (C++: each write_<name> calls its shared write inline, in the header)
    assert cc.count("::write_0_(") == 1 and h.count("return write_0_(") == 2 and h.count("return write_1_(") == 2
    assert c.count("\nstatic int encode_") == 2 and c.count("return write_0(ctx") == 2
    # one decoder for all four, and one read of one register
    assert cc.count("\nfloat decode_") == 1 and h.count("return read_0_(") == 4
    assert c.count("\nstatic int decode_") == 1 and c.count("return read_0(ctx") == 4


@pytest.fixture(scope="module")
def cpp_setup(tmp_path_factory):
    with served_device(tmp_path_factory, FUNCTIONS + BITS, "Shared Device") as served:
        yield served


@pytest.fixture(scope="module")
def c_setup(tmp_path_factory):
    with served_device(tmp_path_factory, FUNCTIONS + BITS, "Shared Device", build_c) as served:
        yield served


@pytest.mark.parametrize("target", ["cpp", "c"])
def test_shared_code_reads_and_writes_as_the_python_driver(target, request):
    path, module, client, h, _ = request.getfixturevalue(f"{target}_setup")
    text = path.parent / f"shared_device.{'cc' if target == 'cpp' else 'c'}"
    assert "more function" in text.read_text()  # the device does share code
    compare = assert_same_values if target == "cpp" else assert_exactly
    dev = module.SharedDevice(client)
    rng = random.Random(3)
    for _ in range(6):
        regs = [rng.choice([0, 0xFFFF, 0x8000, 0x7FFF, rng.randrange(65536)]) for _ in range(REGISTERS)]
        load_registers(client, regs, [rng.random() < 0.5 for _ in range(3)])
        compare(h.values(), dev.read_all())
        for name in ("k0_1", "k9_0", "k11_1", "runs", "coil2"):
            compare(h.values(f"read {name}"), {name: getattr(dev, f"read_{name}")()})
    # writes through the shared writers, read back by the other driver
    for name, value in [
        ("k0_1", "-1234"),
        ("k5_0", "2.5"),
        ("k9_1", "12.3"),
        ("k13_0", "-7"),
        ("runs", "70000"),
        ("coil1", "1"),
    ]:
        assert h.ask(f"write {name} {value}") == ["ok"], name
        compare(h.values(f"read {name}"), {name: getattr(dev, f"read_{name}")()})
    dev.write_k10_1(-40.0)
    compare(h.values("read k10_1"), {"k10_1": dev.read_k10_1()})
    assert h.values("write k9_0 -60") == {"error": 22}  # below the minimum: EINVAL, as its pair's


# ---- expressions: functions of the same statements share one decoder ----

EXPRESSIONS = "".join(
    fn_xml(name, addresses, expression=expression)
    for name, addresses, expression in [
        ("sf", "0", "int16(hr:0)"),
        ("a0", "1", "uint16(hr:1) * 10^sf"),
        ("a1", "2", "uint16(hr:2) * 10^sf"),
        ("b0", "3 4", "int32(hr:3#2) / 100"),
        ("b1", "5 6", "int32(hr:5#2) / 100"),
        ("s0", "1", "a0 + a1"),
        ("s1", "3", "b0 + b1"),  # the same statements on other functions' values
        ("n0", "7", "uint16(hr:7; 0xFFFF)"),
        ("n1", "8", "uint16(hr:8; 0xFFFF)"),
        ("t0", "9 10", "utf8(hr:9#2)"),
        ("t1", "11 12", "utf8(hr:11#2)"),
    ]
)
EXPRESSION_REGISTERS = 13
# plain functions over the same registers, so that the test can write them (expressions are read-only)
RAW = "".join(fn_xml(f"raw{i}", str(i), format="UINT16") for i in range(EXPRESSION_REGISTERS))


@pytest.fixture(scope="module", params=["cpp", "c"])
def expression_setup(tmp_path_factory, request):
    harness = None if request.param == "cpp" else build_c
    with served_device(tmp_path_factory, EXPRESSIONS + RAW, "Expression Device", harness) as served:
        yield request.param, served


def test_functions_of_one_expression_share_a_decoder_and_read_as_the_python_driver(expression_setup):
    target, (path, module, client, h, _) = expression_setup
    text = (path.parent / f"expression_device.{'cc' if target == 'cpp' else 'c'}").read_text()
    # one decoder for each pair: a, b, s, n and t; sf alone keeps its own
    assert text.count("more function of the same expression") == 5, text
    assert ("decode_sf(" in text) and "decode_a0(" not in text and "decode_s1(" not in text
    compare = assert_same_values if target == "cpp" else assert_exactly
    dev = module.ExpressionDevice(client)
    rng = random.Random(5)
    for _ in range(8):
        regs = [rng.choice([0, 1, 0xFFFF, 0x8000, 0x4142, rng.randrange(65536)]) for _ in range(EXPRESSION_REGISTERS)]
        regs[0] = rng.choice([-2, -1, 0, 1, 2]) & 0xFFFF  # the scale factor
        load_registers(client, regs, [])
        compare(h.values(), dev.read_all())
        for name in ("a1", "b0", "s0", "s1", "n1", "t1"):
            compare(h.values(f"read {name}"), {name: getattr(dev, f"read_{name}")()})
