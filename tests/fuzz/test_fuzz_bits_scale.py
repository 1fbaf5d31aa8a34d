"""Differential fuzzing of `bits`, `scale_exponent` and `scale_by` (issue 21): random devices whose
functions share registers with random bits and scale by random factor registers, random raw registers.
mdl's own decoding (the IR's closures, mdl.device.evaluate), its printed poll decoder (the second decode of
a BufferDecoder) and the generated Python driver's decoders give the same value, bit for bit; every write
the codec encodes equals the driver's, and read back after the merge gives the value written while every
function on other bits keeps its value. The XML writer and reader keep every such device as it was."""

from __future__ import annotations

import math
import struct

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.device.evaluate import Evaluator
from mdl.diagnostics import MdlError
from mdl.formats.mdl.load import tree_to_device
from mdl.formats.mdl.parse import parse_source
from mdl.formats.mdl.write import device_to_xml
from mdl.ir import codec
from mdl.ir import steps as ir
from mdl.model import Device, Function
from mdl.resolver import resolve
from mdl.targets.python.emit import render_files
from support.bits_scale import devices


def _same(a: object, b: object) -> bool:
    """Equal values of the same type, floats bit for bit."""
    if isinstance(a, float) and isinstance(b, float):
        return struct.pack(">d", a) == struct.pack(">d", b)
    return type(a) is type(b) and a == b


def _driver(resolved) -> dict:
    (text,) = render_files(resolved, "fuzz.xml").values()
    namespace: dict = {"__name__": "mdl_fuzz_driver"}
    exec(compile(text, "<fuzz driver>", "exec"), namespace)  # noqa: S102  # our own generated code
    return namespace


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(devices())
def test_every_decoder_agrees_and_writes_land(case):
    device, raw = case
    try:
        resolved = resolve(device)
    except MdlError:
        return  # e.g. an INT64 register span over the addresses drawn: refused, never half-read
    evaluator = Evaluator(resolved)
    names = [f.name for f in resolved.functions]
    values = evaluator.values(names, lambda table, a: raw.get((table, a), 0))
    # the printed poll decoder of mdl read (its second call) and the generated driver's
    slots: dict[str, tuple[int, ...]] = {}
    buffer: list[int | None] = []
    for f in resolved.closure(names):
        slots[f.name] = tuple(range(len(buffer), len(buffer) + len(f.layout.addresses)))
        buffer += [raw.get((f.layout.table, a), 0) for a in f.layout.addresses]
    decoder = evaluator.decoder(names, slots)
    assert decoder(buffer) == values
    printed = decoder(buffer)
    driver = _driver(resolved)
    regs_of = {f.name: [raw.get((f.layout.table, a), 0) for a in f.layout.addresses] for f in resolved.functions}
    for f in resolved.functions:
        args = [values[d] for d in f.deps]
        assert _same(printed[f.name], values[f.name]), f.name
        assert _same(driver[f"_decode_{f.ident}"](regs_of[f.name], *args), values[f.name]), f.name
    for f in resolved.functions:
        if f.fn.bits is None:
            continue
        _write_lands(f, evaluator, driver, regs_of, values)


def _write_lands(f, evaluator, driver, regs_of, values) -> None:
    merge = ir.find_step(f.codec.encode, ir.Merge)
    assert merge is not None
    low, high = f.fn.bit_range
    width = high - low + 1
    for raw_value in (0, 1, (1 << width) - 1, (1 << width) // 3):
        value = bool(raw_value & 1) if width == 1 else raw_value * f.fn.eff_multiplier + f.fn.eff_offset
        new = evaluator.encode(f.name, value)
        assert new == driver[f"_encode_{f.ident}"](value)
        regs = codec.merge(regs_of[f.name], new, merge.masks)
        got = evaluator.values([f.name], lambda table, a, regs=regs: regs[f.layout.addresses.index(a)])[f.name]
        if width == 1:
            assert got is value
        else:
            assert math.isclose(got, value, rel_tol=1e-12, abs_tol=1e-9), (got, value)
        for other in evaluator.resolved.functions:  # the other functions on these registers keep their values
            if other is f or other.fn.bits is None or other.layout.addresses != f.layout.addresses:
                continue
            o_low, o_high = other.fn.bit_range
            if o_high < low or o_low > high:
                kept = evaluator.values([other.name], lambda table, a, regs=regs: regs[f.layout.addresses.index(a)])
                assert _same(kept[other.name], values[other.name]), other.name


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(devices(), st.sampled_from(["power_w", "x", None]), st.lists(st.integers(0, 0xFFFF), min_size=1, max_size=2))
def test_the_xml_writer_and_reader_keep_them(tmp_path_factory, case, role, initial):
    device, _ = case
    device.functions[0].role = role
    device.functions[-1].initial = initial
    path = tmp_path_factory.mktemp("xml") / "d.xml"
    path.write_text(device_to_xml(device), encoding="ascii")
    tree, data = parse_source(path)
    assert tree_to_device(tree, str(path), data) == device


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=12))
def test_any_bits_text_is_a_range_or_refused_with_a_position(text):
    fn = Function("a", "a", [1], format="UINT32", bits=text)
    found = fn.bit_range
    problems = [
        d
        for d in __import__("mdl.resolver.checks", fromlist=["check_device"]).check_device(
            Device("D", "d", [fn], version="1.0")
        )
        if d.severity == "error"
    ]
    if found is None:
        assert any("is not N or N-M" in d.message for d in problems)
    else:
        assert 0 <= found[0] <= found[1] <= 99
        assert bool(problems) == (found[1] >= 32)
