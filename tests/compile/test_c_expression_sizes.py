"""Every text buffer of a C expression decoder is sized for the longest value device data can give,
whatever the device names in its expressions: a bitset (a list) given to concat, a text function
declared after the expression that uses it, a text or list returned as is, concat of concat, enum and
bitset labels longer than the defaults, a STRING function. Each device's C driver is built with the
strict flags, run against `mdl sim` with the registers that make the longest labels, and read value
for value as the generated Python driver reads it; one build under AddressSanitizer proves that no
read writes past a buffer. A driver of register-less expressions only compiles without a warning."""

from __future__ import annotations

import random
import re
from pathlib import Path

import pytest

from mdl.formats.mdl import load_device
from support.c_harness import build, build_sanitized, harness_source
from support.common import device_xml, fn_xml
from support.cpp_harness import Harness
from support.drivers import assert_exactly, load_registers, served_device

LONG = "a label much longer than any default label of an enum or a bitset, " * 2


def _fn(name: str, expression: str, addresses: str = "0") -> str:
    return fn_xml(name, addresses, expression=expression)


# Each expression is declared BEFORE the functions it names (bug C), so that a capacity computed in
# declaration order would see 0 for them.
SIZES = "".join(
    [
        # B: a bitset given to concat, directly, returned as is, and nested in another concat
        _fn("ll1", "concat(lx1)", "1"),
        _fn("ll2", "concat(lr, '/', lx1, '/', lxm)", "1 2"),
        _fn("ll3", "concat(ll2, ll2)", "1 2"),
        _fn("lr", "lx1", "1"),  # a list returned as is
        _fn("lx1", "bitset(hr:1)", "1"),  # default labels: Bit 0 .. Bit 15
        _fn("lxm", f"bitset(hr:2; 0 -> '{LONG}0'; 7 -> '{LONG}7'; 15 -> '{LONG}15')", "2"),
        # C: a text declared later, returned as is, in concat of concat
        _fn("x", "concat(y, 'a')"),
        _fn("c1", "concat(c2, '!', c2)"),
        _fn("c2", "concat(c3, c3, x)"),
        _fn("c3", "y"),  # a text returned as is
        _fn("y", "enum(hr:0; 0 -> 'zero'; 1 -> 'one')"),  # unmapped: No mapping for value 0x.. 0x..
        _fn("ym", f"enum(hr:0; 0 -> '{LONG}')"),
        _fn("cm", "concat(ym, ym)"),
        # a boolean's labels, a utf8 text, a STRING function (a parameter of its own text size)
        _fn("cb", "concat(bl, '+', bl)", "1"),
        _fn("bl", f"boolean(bb; 'f'; '{LONG}')", "1"),
        _fn("bb", "bitsetbit(hr:1; 3)", "1"),
        _fn("cu", "concat(u, u, 1.5, 2, true)", "6 7"),
        _fn("u", "utf8(hr:6#2)", "6 7"),
        _fn("cs", "concat(s, '|', sr)", "3 4 5"),
        _fn("sr", "s", "3 4 5"),  # a STRING function returned as is
        fn_xml("s", "3 4 5", format="STRING", count="3"),
        _fn("tiny", "'ab'"),  # a text shorter than the harness's poison
        _fn("big", "concat(ll3, c1, cm, cb, cu, cs)", "1 2 3 4 5 6 7"),
    ]
)
SIZE_REGISTERS = 8
# plain functions over the same registers, so that the test can write them (expressions are read-only)
RAW = "".join(fn_xml(f"raw{i}", str(i), format="UINT16") for i in range(SIZE_REGISTERS))
# the longest values: an unmapped enum value, every bit set, invalid UTF-8 (U+FFFD for each byte)
LONGEST = [0xFFFF, 0xFFFF, 0xFFFF, 0x4142, 0x4344, 0x4546, 0xFFFF, 0xFFFF]
NAMES = (
    "ll1",
    "ll2",
    "ll3",
    "lr",
    "lx1",
    "lxm",
    "x",
    "c1",
    "c2",
    "c3",
    "y",
    "ym",
    "cm",
    "cb",
    "bl",
    "bb",
    "cu",
    "u",
    "cs",
    "sr",
    "s",
    "tiny",
    "big",
)


def _register_sets() -> list[list[int]]:
    """The longest values first, then each enum mapped, no bit set, and random ones (the STRING's
    registers without NUL bytes: C text ends at the first)."""
    rng = random.Random(11)
    out = [
        LONGEST,
        [0, 0, 0, 0x6162, 0x6364, 0x6566, 0x4142, 0x4344],
        [1, 0x0008, 0x8081, *LONGEST[3:]],
        [0x8000, 0x8001, 0x7FFF, 0x7A7A, 0x7A7A, 0x7A7A, 0xC3A9, 0xE282],
    ]
    for _ in range(4):
        regs = [rng.choice([0, 1, 0xFFFF, 0x8000, rng.randrange(65536)]) for _ in range(SIZE_REGISTERS)]
        regs[3:6] = [rng.randrange(0x21, 0x7F) << 8 | rng.randrange(0x21, 0x7F) for _ in range(3)]
        out.append(regs)
    return out


@pytest.fixture(scope="module")
def sizes_setup(tmp_path_factory):
    with served_device(tmp_path_factory, SIZES + RAW, "Sizes Device", build) as served:
        yield served


def _sizes(header: str) -> dict[str, int]:
    return {m.group(1).lower(): int(m.group(2)) for m in re.finditer(r"#define SIZES_DEVICE_(\w+)_SIZE (\d+)", header)}


def test_text_sizes_hold_the_longest_value_of_every_dependency(sizes_setup):
    path, module, client, h, _ = sizes_setup
    sizes = _sizes((path.parent / "sizes_device.h").read_text())
    load_registers(client, LONGEST, [])
    values = module.SizesDevice(client).read_all()
    for name, size in sizes.items():
        if isinstance(values.get(name), str):
            assert len(values[name].encode("utf-8")) < size, (name, size, values[name])
    # no decoder computes a text into an array of 0 or 1 byte (concat of a list or of a later text did)
    text = (path.parent / "sizes_device.c").read_text()
    assert not re.search(r"char t\d+\[[12]\] = \{0\};", text), re.findall(r"char t\d+\[\d+\] = ", text)


def test_expressions_on_later_functions_and_lists_read_as_the_python_driver(sizes_setup):
    _, module, client, h, _ = sizes_setup
    dev = module.SizesDevice(client)
    for regs in _register_sets():
        load_registers(client, regs, [])
        assert_exactly(h.values(), dev.read_all())
        for name in NAMES:
            assert_exactly(h.values(f"read {name}"), {name: getattr(dev, f"read_{name}")()})


def test_no_read_writes_past_a_buffer_under_address_sanitizer(sizes_setup, tmp_path):
    """The same driver and harness built with ASan and UBSan (which see a write past a stack array,
    where valgrind does not): every read of the longest values ends without a report."""
    path, module, client, _, sim = sizes_setup
    exe = build_sanitized(load_device(path), tmp_path, path.name)
    dev = module.SizesDevice(client)
    with Harness(exe, sim.port) as h:
        for regs in _register_sets()[:3]:
            load_registers(client, regs, [])
            assert_exactly(h.values(), dev.read_all())
            for name in NAMES:
                assert_exactly(h.values(f"read {name}"), {name: getattr(dev, f"read_{name}")()})


# E: a driver whose only functions are register-less expressions (no request at all)
CONSTANTS = "".join([_fn("k", "'abcdefgh'"), _fn("k2", "3 + 4"), _fn("k3", "''"), _fn("k4", "concat(k, k2, k3)")])


def test_a_driver_of_register_less_expressions_compiles_clean_and_reads_as_the_python_driver(tmp_path_factory):
    with served_device(tmp_path_factory, CONSTANTS, "Constant Device", build) as (path, module, client, h, _):
        text = (path.parent / "constant_device.c").read_text()
        assert "mdl_drop_stale_bytes" not in text and "modbus_flush" not in text
        dev = module.ConstantDevice(client)
        assert_exactly(h.values(), dev.read_all())
        for name in ("k", "k2", "k3", "k4"):
            assert_exactly(h.values(f"read {name}"), {name: getattr(dev, f"read_{name}")()})


def test_the_harness_poisons_a_text_within_its_size(tmp_path: Path):
    """tests/support/c_harness.py poisons each text before a read within the text's array, however short
    (`k3` holds one byte); the ASan test above runs it on texts shorter than the poison."""
    path = tmp_path / "device.xml"
    path.write_text(device_xml(CONSTANTS, name="Constant Device"))
    assert "strcpy(" not in harness_source(load_device(path), "constant_device")
