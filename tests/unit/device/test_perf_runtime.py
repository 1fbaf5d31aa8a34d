"""`mdl read`'s runtime decodes a poll with one Python function compiled for the functions read, from
the second read of the same names on (mdl.device.evaluate.BufferDecoder, printed by the Python
target's templates): every value must be the one the first read's closures (mdl.ir.codec) give,
bit for bit, and the one the generated Python driver gives for the same registers. The device's
registers come from an in-process stand-in for the wire (`Session.read_request`), so that
hypothesis can try many of them quickly."""

from __future__ import annotations

import math
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.device.connection import Connection
from mdl.device.link import ModbusExceptionError
from mdl.device.runtime import Session
from mdl.formats.loading import load_resolved
from mdl.ir import codec
from mdl.model.layout import layout
from mdl.targets import render
from support.common import EXAMPLE, REFERENCE, ROOT, device_xml, fn_xml, import_generated

ORDERS = [("big", "big"), ("big", "little"), ("little", "big"), ("little", "little")]
HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"


def _functions() -> str:
    """Every format, order and length, scaled, "not implemented", text, fragments and bits, each
    twice at other addresses (functions of the same IR share a decoder), and one whose registers
    are not consecutive."""
    kinds = [
        dict(format=f, byte_order=b, word_order=w)
        for f in ("INT16", "UINT32", "INT64", "FLOAT32", "FLOAT64")
        for b, w in ORDERS
    ]
    kinds += [
        dict(format="INT8", length="Lower byte"),
        dict(format="UINT8", length="Upper byte", byte_order="little"),
        dict(format="INT16", multiplier="0.1"),
        dict(format="UINT32", multiplier="0.01", offset="-273.15"),
        dict(format="UINT16", not_implemented="0xFFFF 0x8000"),
        dict(format="INT32", not_implemented="0x80000000"),
        dict(format="STRING", count="3"),
        dict(format="STRING", count="2", length="Lower byte"),
        dict(format="UINT16", count="2", read_function_code="arg = r1 * 65536.0 + r2 / 1000.0;"),
        dict(format="INT16", read_function_code="arg = (int16_t)r1 / 10.0f;"),
    ]
    out, address = [], 0
    for copy in range(2):
        for i, kind in enumerate(kinds):
            name = f"c{copy}_{i}"
            out.append(fn_xml(name, str(address), **kind))
            address += 8
    out.append(fn_xml("split", "300 302", format="UINT32"))
    out += [fn_xml(f"coil{i}", str(i), format="BIT", register_type="coil") for i in range(3)]
    out += [fn_xml(f"input{i}", str(i), format="BIT", register_type="discrete") for i in range(2)]
    return "".join(out)


@pytest.fixture(scope="module")
def device(tmp_path_factory):
    path = tmp_path_factory.mktemp("runtime") / "runtime.xml"
    path.write_text(device_xml(_functions(), name="Runtime Device"), encoding="ascii")
    return load_resolved(path)


def same(a, b) -> bool:
    """The same value: the same type, floats bit for bit (NaN for NaN)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return (math.isnan(a) and math.isnan(b)) or struct.pack(">d", a) == struct.pack(">d", b)
    return a == b


def assert_same(got: dict, expected: dict) -> None:
    assert list(got) == list(expected)
    bad = {name: (got[name], expected[name]) for name in expected if not same(got[name], expected[name])}
    assert not bad, bad


def session(resolved, registers: dict, refused: frozenset = frozenset()) -> Session:
    """A Session whose requests answer from `registers` ((table, address) -> value, 0 where absent)
    and refuse (exception 2) any request holding an address of `refused`."""
    s = Session(resolved, Connection())

    def read_request(req):
        if any((req.table, a) in refused for a in range(req.start, req.end)):
            raise ModbusExceptionError("reading", 2)
        return [registers.get((req.table, a), 0) for a in range(req.start, req.end)]

    s.read_request = read_request  # type: ignore[method-assign]
    return s


def _registers(resolved, draw_word, draw_bit) -> dict:
    out = {}
    for f in resolved.functions:
        for a in f.layout.addresses:
            bit = f.layout.table in ("coil", "discrete")
            out[(f.layout.table, a)] = draw_bit() if bit else draw_word()
    return out


def _words(data):
    interesting = st.sampled_from([0, 0xFFFF, 0x8000, 0x7FFF, 0x7F80, 0xFF80, 0x0001])
    return lambda: data.draw(st.one_of(interesting, st.integers(0, 0xFFFF)))


def _compiled(s: Session) -> bool:
    return all(plan.decode.compiled is not None for plan in s._plans.values())


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_poll_decodes_as_the_first_read_and_the_codec_do(device, data):
    registers = _registers(device, _words(data), lambda: data.draw(st.integers(0, 1)))
    functions = [f.fn for f in device.readable]
    s = session(device, registers)
    first = s.read(functions)  # the closures
    assert not _compiled(s)
    second = s.read(functions)  # the compiled function
    assert _compiled(s)
    assert_same(second, first)
    for f in device.readable:
        regs = [registers[(f.layout.table, a)] for a in f.layout.addresses]
        try:
            expected = codec.decode(f.fn, regs)
        except Exception as exc:  # a fragment without a value: the read refuses it too  # noqa: BLE001
            pytest.fail(f"{f.name}: {exc}")
        assert same(second[f.name], expected), (f.name, second[f.name], expected)
    registers.update(_registers(device, _words(data), lambda: data.draw(st.integers(0, 1))))
    assert_same(s.read(functions), session(device, registers).read(functions))


def test_a_poll_of_some_functions_decodes_them_alone(device):
    """A list of some functions has its own plan and its own compiled function."""
    registers = {key: (i * 7919) & 0xFFFF for i, key in enumerate(_registers(device, int, int))}
    some = [device.by_name[name].fn for name in ("c1_3", "split", "c0_24", "coil2")]
    s = session(device, registers)
    first = s.read(some)
    assert list(first) == ["c1_3", "split", "c0_24", "coil2"]
    assert_same(s.read(some), first)
    assert _compiled(s)


def test_the_generated_python_driver_decodes_as_the_runtime(device, tmp_path):
    """The driver's read_all buffer holds the same registers: the values are the same, bit for bit."""
    stem = device.stem
    (tmp_path / f"{stem}.py").write_text(render(device, "runtime.xml", "python")[f"{stem}.py"])
    module = import_generated(tmp_path / f"{stem}.py", "perf_runtime_driver")
    registers = {key: (i * 40503 + 17) & 0xFFFF for i, key in enumerate(_registers(device, int, int))}
    for (table, a), value in list(registers.items()):
        if table in ("coil", "discrete"):
            registers[(table, a)] = value & 1
    raw = [0] * module._BUFFER_SIZE
    for (table, start, count), offset, _ in module._PLAN:
        raw[offset : offset + count] = [registers.get((table, a), 0) for a in range(start, start + count)]
    functions = [f.fn for f in device.readable]
    s = session(device, registers)
    s.read(functions)
    polled = s.read(functions)
    driver = module._values(raw)
    assert set(driver) == set(polled)
    bad = {n: (driver[n], polled[n]) for n in polled if not same(driver[n], polled[n])}
    assert not bad, bad


def _expression_devices():
    files = [HEAT_PUMP, *sorted(REFERENCE.glob("*.yaml"))]
    return [pytest.param(path, id=path.stem) for path in files if path.is_file()]


@pytest.mark.parametrize("path", _expression_devices())
def test_expressions_decode_alike_with_and_without_a_refused_register(path):
    resolved = load_resolved(path)
    functions = [f.fn for f in resolved.readable]
    registers = {key: (i * 2654435761) & 0xFFFF for i, key in enumerate(_registers(resolved, int, int))}
    s = session(resolved, registers)
    first = s.read(functions)
    assert_same(s.read(functions), first)
    assert _compiled(s)
    # one register refused even alone: the functions that read it are expressions here, which read
    # None for it; the poll decodes with the closures, as the first read did
    key = next(iter(registers))
    refused = frozenset([key])
    gap = session(resolved, registers, refused)
    first = gap.read(functions)
    assert_same(gap.read(functions), first)


def test_a_refused_register_of_a_plain_function_fails_every_read(device):
    registers = {key: 1 for key in _registers(device, int, int)}
    functions = [f.fn for f in device.readable]
    s = session(device, registers, frozenset([("holding", 0)]))
    for _ in range(3):
        with pytest.raises(ModbusExceptionError):
            s.read(functions)


def test_the_example_reads_the_same_on_every_poll():
    resolved = load_resolved(EXAMPLE / "temco_tstat.xml")
    functions = [f.fn for f in resolved.readable]
    registers = {(f.layout.table, a): len(f.name) + a for f in resolved.functions for a in layout(f.fn).addresses}
    s = session(resolved, registers)
    polls = [s.read(functions) for _ in range(3)]
    assert_same(polls[1], polls[0])
    assert_same(polls[2], polls[0])


def test_a_one_off_read_does_not_import_jinja(tmp_path):
    """`mdl read` starts fast: the first read decodes with the closures; a poll pays for the compiled
    function (and Jinja) once, on its second read."""
    import subprocess
    import sys

    path = tmp_path / "one.xml"
    path.write_text(device_xml(fn_xml("a", "0", format="INT16") + fn_xml("b", "1", format="FLOAT32")))
    script = f"""
import sys
from mdl.device.connection import Connection
from mdl.device.runtime import Session
from mdl.formats.loading import load_resolved
resolved = load_resolved({str(path)!r})
s = Session(resolved, Connection())
s.read_request = lambda req: [0x4049 + a for a in range(req.start, req.end)]
first = s.read([f.fn for f in resolved.readable])
print("jinja2" in sys.modules)
second = s.read([f.fn for f in resolved.readable])
print("jinja2" in sys.modules, first == second)
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "True", "True"]
