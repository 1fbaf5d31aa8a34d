"""Expressions over plain functions of every format: the expression language sees a plain integer
function as a long (int64), a float or scaled one as a double, a BIT as a boolean and a STRING as
text, so the C++ and C drivers' expression decoders take those types, and read what the Python
driver reads, on random registers and on the edges (0xFFFF, 0x8000, a UINT64 above 2^63)."""

from __future__ import annotations

import random
import re

import pytest

from mdl.formats.mdl import load_device
from mdl.targets import render
from support.c_harness import build as build_c
from support.common import device_xml, fn_xml
from support.cpp_harness import clang_tidy
from support.drivers import assert_exactly, assert_same_values, load_registers, served_device

# the plain functions, each on the registers after the last one's
PLAIN = [
    ("i8", 1, dict(format="INT8", length="Lower byte")),
    ("u8", 1, dict(format="UINT8", length="Upper byte")),
    ("i16", 1, dict(format="INT16")),
    ("u16", 1, dict(format="UINT16")),
    ("i32", 2, dict(format="INT32")),
    ("u32", 2, dict(format="UINT32", word_order="little")),
    ("i64", 4, dict(format="INT64")),
    ("u64", 4, dict(format="UINT64")),
    ("f32", 2, dict(format="FLOAT32")),
    ("f64", 4, dict(format="FLOAT64")),
    ("sc", 1, dict(format="INT16", multiplier="0.1")),
    ("ni", 1, dict(format="UINT16", not_implemented="0xFFFF")),  # nullable
    ("fr", 2, dict(format="UINT16", count="2", read_function_code="arg = r1 &gt; 32767 ? -1.0 : r1 % 100 / 3;")),
    ("st", 2, dict(format="STRING", count="2")),
]
NUMBERS = [name for name, _, fields in PLAIN if fields["format"] != "STRING"]
# on every number: each operator, unary minus, ^ (a double), concat and the value as it is
OPERATIONS = {
    "add": "{} + 1",
    "mul": "{} * 2",
    "div": "{} / 3",
    "sub": "7 - {}",
    "neg": "-{}",
    "pow": "{} ^ 2",
    "cat": "concat({}, '|')",
    "id": "{}",
}
MIXED = [
    ("m_sum", "i8 + u8 + i16 + u16 + i32 + u32 + i64 + u64"),
    ("m_mix", "u64 * f32 - sc + fr / i16"),
    ("m_cat", "concat(st, '/', b, '/', u64, '/', f32, '/', sc, '/', ni, '/', i64)"),
    ("m_bool", "boolean(b)"),
    ("m_label", "boolean(b; 'off'; 'on')"),
    ("m_text", "st"),
    ("m_long", "u16 * u32 * i64"),  # wraps as a long does
]


def _device() -> tuple[str, int]:
    out, address = [], 0
    for name, size, fields in PLAIN:
        out.append(fn_xml(name, " ".join(str(address + i) for i in range(size)), **fields))
        address += size
    out.append(fn_xml("b", "0", format="BIT", register_type="coil"))
    for name in NUMBERS + ["b"]:
        for op, text in OPERATIONS.items():
            if name == "b" and op not in ("cat", "id"):
                continue
            out.append(fn_xml(f"{name}_{op}", "0", expression=text.format(name)))
    out += [fn_xml(name, "0", expression=text) for name, text in MIXED]
    return "".join(out), address


FUNCTIONS, REGISTERS = _device()


@pytest.fixture(scope="module", params=["cpp", "c"])
def setup(tmp_path_factory, request):
    with served_device(
        tmp_path_factory, FUNCTIONS, "Param Device", None if request.param == "cpp" else build_c
    ) as served:
        yield request.param, served


def _registers(rng: random.Random) -> list[int]:
    return [rng.choice([0, 1, 0xFFFF, 0x8000, 0x7FFF, 0x4142, rng.randrange(65536)]) for _ in range(REGISTERS)]


def test_expressions_over_every_format_compile_and_read_as_the_python_driver(setup):
    """Exactly the Python driver's values, in C++ and in C: a UINT64 above 2^63 - 1 reaches an
    expression as its 64 bits, two's complement, in every target (docs/expressions.md)."""
    target, (path, module, client, h, _) = setup
    if target == "cpp":
        text = (path.parent / "param_device.cc").read_text()
        decoder = dict(re.findall(r"^ *values\.(\w+) = decode_(\w+)\(", text, re.M))
        # the same statements over integers of any format but UINT64 are one decoder (int64_t
        # parameters), and over floats, scaled values and a fragment's another (double ones); a UINT64
        # keeps its own
        assert len({decoder[f"{name}_add"] for name in ("i8", "u8", "i16", "u16", "i32", "u32", "i64", "ni")}) == 1
        assert len({decoder[f"{name}_add"] for name in ("f32", "f64", "sc", "fr")}) == 1
        assert decoder["u64_add"] == "u64_add" and decoder["i16_add"] != decoder["f32_add"]
    same = assert_same_values if target == "cpp" else assert_exactly
    dev = module.ParamDevice(client)
    rng = random.Random(11)
    edges = [[0] * REGISTERS, [0xFFFF] * REGISTERS, [0x8000] * REGISTERS, [0x7FFF] * REGISTERS]
    u64, st = (sum(size for _, size, _ in PLAIN[: [p[0] for p in PLAIN].index(name)]) for name in ("u64", "st"))
    for regs in edges + [_registers(rng) for _ in range(12)]:
        if rng.random() < 0.5:  # a UINT64 above 2^63
            regs[u64 : u64 + 4] = [0x8000 | rng.randrange(0x8000), rng.randrange(65536), rng.randrange(65536), 0xFFFF]
        # a C text ends at its first NUL (docs/c-api.md): the STRING's bytes hold none, so that its
        # value is the same text in every target
        regs[st : st + 2] = [w if w & 0xFF and w >> 8 else 0x4142 for w in regs[st : st + 2]]
        load_registers(client, regs, [rng.random() < 0.5])
        same(h.values(), dev.read_all())
        for name in (
            "u64_div",
            "u64_cat",
            "u64_add",
            "u16_add",
            "f32_mul",
            "ni_neg",
            "fr_pow",
            "m_mix",
            "m_cat",
            "b_cat",
            "m_label",
            "u64_id",
        ):
            same(h.values(f"read {name}"), {name: getattr(dev, f"read_{name}")()})


@pytest.mark.exhaustive  # clang-tidy takes seconds a driver, as in test_driver.py
def test_clang_tidy_finds_nothing_in_expressions_over_every_format(tmp_path):
    (tmp_path / "device.xml").write_text(device_xml(FUNCTIONS, name="Param Device"))
    for name, text in render(load_device(tmp_path / "device.xml"), "device.xml", "cpp").items():
        (tmp_path / name).write_text(text)
    proc = clang_tidy(tmp_path / "param_device.cc")
    assert proc.returncode == 0 and "warning:" not in proc.stdout, proc.stdout + proc.stderr
