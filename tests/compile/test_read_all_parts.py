"""read_all in parts (issue 29): the C and C++ drivers decode a large device's values in functions of at
most 64 functions each (clike.READ_ALL_PART), out of line, so that gcc and g++ compile in time linear
in the device; the C driver checks every register and fragment first and then decodes straight into
*out. A device of several parts, its expressions naming functions of earlier parts, must read exactly
what the Python driver reads, and a refused register must leave *out as it was (the harnesses poison it)."""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.formats.mdl import load_device
from mdl.targets.clike import READ_ALL_PART
from mdl.targets.cpp import emit as cpp_emit
from support.c_harness import build as build_c
from support.common import device_xml, fn_xml
from support.cpp_harness import MODBUS_ENOBASE, Harness
from support.cpp_harness import build as build_cpp
from support.drivers import assert_exactly, assert_same_values, load_registers, served_device

ENUM = {"values": {0: "Off", 1: "On"}}
KINDS = [  # (extra elements, registers), cycled
    (dict(format="UINT16", multiplier="0.1", minimum="0", maximum="500"), 1),
    (dict(format="INT16", multiplier="0.5", offset="-40"), 1),
    (dict(format="FLOAT32", byte_order="little", word_order="little"), 2),
    (dict(format="UINT16", **ENUM), 1),
    (dict(format="INT32", multiplier="0.01"), 2),
    (dict(format="UINT32", not_implemented="0xFFFFFFFF"), 2),
    (dict(format="FLOAT64", word_order="little"), 4),
    (dict(format="STRING", count="2"), 2),
    (dict(format="INT16", minimum="-100", maximum="100"), 1),
]
SIZE = 3 * READ_ALL_PART + 10  # four parts


def _device() -> tuple[str, int]:
    out, address = [], 0
    for i in range(SIZE):
        kind, size = KINDS[i % len(KINDS)]
        if i % 50 == 49:  # an expression reading registers, and naming a number of an earlier part
            dep = next((j for j in range(i - READ_ALL_PART - 1, -1, -1) if j % len(KINDS) in (0, 1, 4)), None)
            named = f"f{dep} + " if dep is not None else ""
            out.append(fn_xml(f"e{i}", str(address), expression=f"{named}uint16(hr:{address})"))
            out.append(fn_xml(f"w{i}", str(address), format="UINT16"))  # its register, writable in mdl sim
            address += 1
            continue
        out.append(fn_xml(f"f{i}", str(address), **kind))
        address += size
    out.append(fn_xml("sf", str(address), format="INT16"))
    out.append(fn_xml("scaled", str(address + 1), format="UINT16", scale_exponent="sf"))
    out.append(fn_xml("coil0", "0", format="BIT", register_type="coil"))
    return "".join(out), address + 2


FUNCTIONS, REGISTERS = _device()
NAMES = re.findall(r"<name>([^<]+)</name>", FUNCTIONS)


@pytest.fixture(scope="module")
def cpp_parts(tmp_path_factory):
    """The C++ driver with its class in a chain of classes of 64 functions (a device of more than
    CLASS_PART functions has; 64 here so that a small device does)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(cpp_emit, "CLASS_PART", 64)
        with served_device(tmp_path_factory, FUNCTIONS, "Parts Device") as served:
            yield served


@pytest.fixture(scope="module")
def c_parts(tmp_path_factory):
    with served_device(tmp_path_factory, FUNCTIONS, "Parts Device", build_c) as served:
        yield served


def _bodies(text: str) -> dict[str, str]:
    """Each function defined at the top level of a C or C++ file: its name and body."""
    out = {}
    for m in re.finditer(r"^[^\s#/{}][^\n;]*?\b(\w+)\((?:[^;{]|\n)*?\) \{\n(.*?)^\}", text, re.M | re.S):
        out[m.group(1)] = m.group(2)
    return out


@pytest.mark.parametrize("target", ["cpp", "c"])
def test_read_all_decodes_in_parts_of_at_most_64_functions(target, request):
    path = request.getfixturevalue(f"{target}_parts")[0]
    text = (path.parent / f"parts_device.{'cc' if target == 'cpp' else 'c'}").read_text()
    bodies = _bodies(text)
    part = "decode_part_" if target == "cpp" else "read_all_part_"
    parts = sorted(name for name in bodies if name.startswith(part))
    assert len(parts) == -(-FUNCTIONS.count("<function>") // READ_ALL_PART)  # every function, in parts of 64
    for name in parts:  # a value assigned or decoded into per function of its part
        assert 0 < len(re.findall(r"decode_\w+\(", bodies[name])) <= READ_ALL_PART, name
        assert re.search(rf"(\[\[gnu::noinline\]\]|MDL_NOINLINE) (static )?\w+ {name}\(", text), name
    read_all = next(body for name, body in bodies.items() if name.endswith("read_all") and "part" in body)
    assert not re.search(r"\bdecode_(?!part_)\w+\(r, &?values", read_all)  # read_all only calls its parts


def test_the_class_derives_from_a_chain_of_parts_and_writes_with_a_factor_of_the_first(cpp_parts):
    path, module, client, h, _ = cpp_parts
    header = (path.parent / "parts_device.h").read_text()
    parts = re.findall(r"^class Part(\d+) : public (\w+) \{$", header, re.M)
    assert parts == [(str(k), "Core" if k == 0 else f"Part{k - 1}") for k in range(len(parts))]
    assert len(parts) == -(-FUNCTIONS.count("<function>") // 64)
    assert f"class PartsDevice : public parts_device_parts::Part{len(parts) - 1} {{" in header
    part0 = header[header.index("class Part0 ") : header.index("class Part1 ")]
    assert "int read_sf(" in part0  # the factor, read by the write of `scaled` in a later class
    dev = module.PartsDevice(client)
    load_registers(client, [0] * REGISTERS, [False])
    dev.write_f0(12.3)  # a value of a shared writer, in the first class
    assert h.ask("write sf 2") == ["ok"] and h.ask("write scaled 1200") == ["ok"]
    assert_same_values(h.values("read scaled"), {"scaled": dev.read_scaled()})
    assert client.read_holding_registers(REGISTERS - 1, count=1, device_id=1).registers == [12]  # 12 * 10^2
    assert_same_values(h.values(), dev.read_all())


@settings(
    max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
)
@given(
    regs=st.lists(
        st.sampled_from([0, 1, 0xFFFF, 0x8000, 0x7FFF, 0x4120, 0x3F80, 0x4142]) | st.integers(0, 0xFFFF),
        min_size=REGISTERS,
        max_size=REGISTERS,
    ),
    bit=st.booleans(),
)
def test_every_part_reads_what_the_python_driver_reads(c_parts, cpp_parts, regs, bit):
    for (_, module, client, h, _), compare in ((c_parts, assert_exactly), (cpp_parts, assert_same_values)):
        load_registers(client, regs, [bit])
        compare(h.values(), module.PartsDevice(client).read_all())


@pytest.mark.parametrize("target", ["cpp", "c"])
def test_a_register_refused_in_the_last_part_leaves_every_value_as_it_was(target, tmp_path, sim_factory):
    """A register of the last part's function that the device refuses (exception 2, even asked alone)
    fails read_all with EMBXILADD before *out changes: the harnesses poison every value first and
    check after a failure that each still holds its poison (the earlier parts wrote nothing)."""
    build = build_c if target == "c" else build_cpp
    described = tmp_path / "described.xml"
    described.write_text(device_xml(FUNCTIONS, name="Parts Device"))
    missing = f"f{SIZE - 2}"
    assert FUNCTIONS.count(f"<name>{missing}</name>") == 1
    actual = tmp_path / "actual.xml"
    served = re.sub(rf"  <function>\n    <name>{missing}</name>.*?</function>\n", "", FUNCTIONS, flags=re.S)
    assert served.count("<function>") == FUNCTIONS.count("<function>") - 1
    actual.write_text(device_xml(served, "Parts Device"))
    exe = build(load_device(described), tmp_path)
    sim = sim_factory(actual)
    with Harness(exe, sim.port) as h:
        assert h.values() == {"error": MODBUS_ENOBASE + 2}  # EMBXILADD, every value still poisoned
        assert h.values(f"read {NAMES[0]}").keys() == {NAMES[0]}  # the driver still reads
        assert h.values() == {"error": MODBUS_ENOBASE + 2}  # again, by smaller requests
