"""One printer per idea (issue 19): every expression operation kind is documented and printed by every
target's one printer, a device using every kind generates drivers that compile and import, and the
shared literal, range and runtime-picking helpers say what they print (hypothesis)."""

from __future__ import annotations

import importlib.util
import math
import shutil
import subprocess
import sys

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mdl.dsl.expr.ops import OpKind, printer
from mdl.dsl.expr.pyemit import PRINTER as PYTHON
from mdl.formats.mdl import load_device
from mdl.ir import steps as ir
from mdl.resolver import resolve
from mdl.targets.c.expressions import PRINTER as C
from mdl.targets.clike import int_bounds, int_limits
from mdl.targets.cpp.expressions import PRINTER as CPP
from mdl.targets.templating import RuntimePart, double_literal, pick
from support.c_harness import STRICT as C_STRICT
from support.common import fn_xml
from support.cpp_harness import STRICT as CPP_STRICT
from support.cpp_harness import modbus_flags
from support.run import run_mdl

PRINTERS = {"python": PYTHON, "c++": CPP, "c": C}

# expressions that together lower to every operation kind
EVERY_KIND = [
    "int16(swapbytes(hr:10)) + uint16(hr:11; 0xFFFF) * 2 - -int32(hr:12#2)",
    "uint32(swapendian(hr:14#2)) / int64(hr:16#4) ^ 0.5",
    "uint64(hr:20#4) + ieee754_32(hr:24#2) + ieee754_64(hr:26#4)",
    "concat(utf8(hr:30#2), hexstring(hr:32), eui48(hr:33#3), ipv4addr(hr:36#2), ipv6addr(hr:40#8), 'x', 1.5, 2)",
    "concat(enum(hr:50; 1 -> 'one'), bitset(hr:51; 0 -> 'a'), bitsetbit(hr:52; 3), boolean(true; 'no'; 'yes'))",
    'int16("0x1234")',
    "boolean(c:5)",
]


@pytest.mark.parametrize("target", PRINTERS)
def test_every_printer_prints_every_operation_kind(target):
    assert set(PRINTERS[target]) == set(OpKind)


def test_a_printer_missing_a_kind_is_refused_by_name():
    """The control: the check that every printer passes fails for one that misses a kind."""
    incomplete = {kind: PYTHON[kind] for kind in OpKind if kind is not OpKind.BITSETBIT}
    with pytest.raises(TypeError, match="misses the operation kinds bitsetbit"):
        printer(incomplete)


def test_every_operation_kind_says_what_it_computes():
    docs = [kind.__doc__ or "" for kind in OpKind]
    assert all(len(doc) > 20 for doc in docs) and len(set(docs)) == len(docs)


def _device_xml() -> str:
    from support.common import device_xml

    functions = [
        fn_xml(f"e{i}", "0", expression=text.replace("<", "&lt;").replace(">", "&gt;"))
        for i, text in enumerate(EVERY_KIND)
    ]
    return device_xml("".join(functions), name="Every Kind")


def test_the_device_lowers_to_every_kind(tmp_path):
    """The device the next test generates really holds every kind (else that test proves less)."""
    path = tmp_path / "every.xml"
    path.write_text(_device_xml())
    steps = [ir.find_step(f.codec.decode, ir.Expression) for f in resolve(load_device(path), str(path)).functions]
    assert {op.kind for step in steps if step is not None for op in step.lowered.ops} == set(OpKind)


@pytest.mark.compile  # builds generated C++/C: heavier than its folder
def test_every_kind_generates_drivers_that_compile_and_import(tmp_path):
    path = tmp_path / "every.xml"
    path.write_text(_device_xml())
    out = tmp_path / "out"
    result = run_mdl("gen", path, "--lang", "all", "-o", out)
    assert result.returncode == 0, result.stderr
    spec = importlib.util.spec_from_file_location("every_kind", out / "every_kind.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert hasattr(module, "EveryKind")
    cflags, _ = modbus_flags()
    for compiler, flags, source in (("g++", CPP_STRICT, "every_kind.cc"), ("gcc", C_STRICT, "every_kind.c")):
        if shutil.which(compiler) is None:
            pytest.skip(f"{compiler} is not installed")
        done = subprocess.run(
            [compiler, *flags, *cflags, "-fsyntax-only", "-I", str(out), str(out / source)],
            capture_output=True,
            text=True,
        )
        assert done.returncode == 0, done.stderr


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(st.one_of(finite, st.integers(min_value=-(2**64), max_value=2**64)), st.booleans())
def test_a_double_literal_reads_back_as_its_double(x, parenthesized):
    text = double_literal(x, parenthesized)
    assert text.strip("()") == text.lstrip("(").rstrip(")") and " " not in text
    inner = text[1:-1] if text.startswith("(") else text
    assert float(inner) == float(x) and math.copysign(1, float(inner)) == math.copysign(1, float(x))
    assert "." in inner or "e" in inner  # a double literal in C, C++ and Python alike
    assert text.startswith("(-") == (parenthesized and math.copysign(1, float(x)) < 0)


@pytest.mark.parametrize("x", [math.inf, -math.inf, math.nan])
def test_no_double_literal_spells_a_non_finite_number(x):
    with pytest.raises(ValueError, match="cannot be a literal"):
        double_literal(x)


SMALL_TYPES = ["bool", "int8_t", "uint8_t", "int16_t", "uint16_t"]
bound = st.one_of(st.none(), st.floats(min_value=-70000, max_value=70000, allow_nan=False))


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(SMALL_TYPES), bound, bound)
def test_int_bounds_refuse_exactly_the_values_outside(t, minimum, maximum):
    """Against every value of the type: a value is refused by the printed tests exactly where it is
    outside minimum..maximum, and `never` (every value refused without a test) only where none is
    within (resolve refuses a minimum above the maximum before a target prints one)."""
    assume(minimum is None or maximum is None or minimum <= maximum)
    limits = int_limits(t)
    assert limits is not None
    b = int_bounds(minimum, maximum, t)
    assert b is not None
    values = range(limits[0], limits[1] + 1)
    inside = [v for v in values if (minimum is None or v >= minimum) and (maximum is None or v <= maximum)]
    assert not (b.never and inside)
    if not b.never:
        passes = [v for v in values if (b.low is None or v >= b.low) and (b.high is None or v <= b.high)]
        assert passes == inside
        assert b.low is None or b.low > limits[0]  # no test that no value can fail (-Wtype-limits)
        assert b.high is None or b.high < limits[1]


def test_int_limits_know_the_c_integer_types_only():
    assert int_limits("uint64_t") == (0, 2**64 - 1) and int_limits("int32_t") == (-(2**31), 2**31 - 1)
    assert int_limits("double") is None and int_limits("std::string") is None and int_limits("char") is None


names = st.sampled_from("abcdefgh")


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(names, st.frozensets(names)), max_size=8, unique_by=lambda p: p[0]), st.sets(names))
def test_pick_takes_what_is_named_and_what_that_uses_in_file_order(spec, wanted):
    parts = [RuntimePart((name,), f"<{name}>", uses) for name, uses in spec]
    picked = pick(parts, wanted)
    assert picked == [p for p in parts if p in picked]  # in the file's order
    defined = {p.names[0] for p in parts}
    closure, todo = set(), [n for n in wanted if n in defined]
    while todo:
        n = todo.pop()
        if n not in closure:
            closure.add(n)
            todo += [u for u in dict(spec)[n] if u in defined]
    assert {p.names[0] for p in picked} == closure


if __name__ == "__main__":
    sys.exit(pytest.main([__file__]))
