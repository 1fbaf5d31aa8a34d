"""Functions of one shape share their value IR (issue 29): resolve builds each shape's steps once
(mdl.ir.build.build_shared) and makes each shape's text once. Sharing must never change a
function's codec: every field `build` reads is in the key, or the codecs would differ here."""

from __future__ import annotations

from dataclasses import replace

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mdl.ir.build import build, build_shared, shape_key
from mdl.model import Device, Function
from mdl.model.layout import FORMAT_BITS, LayoutError, layout
from mdl.resolver import ResolvedFunction, _shape, resolve

NUMBERS = [None, 0.0, -0.0, 1, 1.0, 0.1, 0.5, -3.0, 5, 100.25, 1e-300]
# each field a function may set -> the values drawn for it
FIELDS = {
    "addresses": st.lists(st.integers(0, 20), min_size=1, max_size=5),
    "length": st.sampled_from([None, "Full word", "Lower byte", "Upper byte"]),
    "count": st.sampled_from([None, 1, 2, 4]),
    "format": st.sampled_from([None, *FORMAT_BITS]),
    "multiplier": st.sampled_from(NUMBERS),
    "offset": st.sampled_from(NUMBERS),
    "minimum": st.sampled_from(NUMBERS),
    "maximum": st.sampled_from(NUMBERS),
    "register_type": st.sampled_from([None, "holding", "input", "coil", "discrete"]),
    "byte_order": st.sampled_from([None, "big", "little"]),
    "word_order": st.sampled_from([None, "big", "little"]),
    "access": st.sampled_from([None, "read", "write", "read_write"]),
    "not_implemented": st.sampled_from([None, [], ["FFFF"], ["0xFFFF"], ["8000", "FFFF"], ["FFFFFFFF"]]),
    "bits": st.sampled_from([None, "3", "0-7", "7-0", "15"]),
    "scale_exponent": st.sampled_from([None, "sf"]),
    "scale_by": st.sampled_from([None, "k"]),
    "write_function_code": st.sampled_from([None, None, None, "22", "r1 = arg"]),
    "read_function_code": st.sampled_from([None, None, None, "arg = r1"]),
}
function = st.builds(Function, name=st.just("f"), description=st.just(""), **FIELDS)
# a function of registers that lays out (most of `function`'s draws do not), for a first one
registers = st.builds(
    Function,
    name=st.just("f"),
    description=st.just(""),
    addresses=st.integers(0, 20).map(lambda a: [a]),
    format=st.sampled_from(["INT16", "UINT16", "INT32", "UINT32", "FLOAT32", "INT64", "STRING"]),
    **{k: v for k, v in FIELDS.items() if k not in ("addresses", "format", "register_type", "count", "length")},
)


@st.composite
def related_functions(draw: st.DrawFn) -> list[Function]:
    """Functions, most of them an earlier one with one field changed: pairs that differ in a single
    field are where a key missing that field would share a codec it must not."""
    out = [draw(registers)]
    for _ in range(draw(st.integers(1, 12))):
        if draw(st.integers(0, 3)) == 0:
            out.append(draw(function))
            continue
        earlier = draw(st.sampled_from(out))
        name = draw(st.sampled_from([*sorted(FIELDS), "moved", "moved"]))
        if name == "moved":  # the same function elsewhere: the one change that keeps its shape
            shift = draw(st.integers(1, 100))
            out.append(replace(earlier, addresses=[a + shift for a in earlier.addresses], units="elsewhere"))
        else:
            out.append(replace(earlier, **{name: draw(FIELDS[name])}))
    return out


@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(related_functions())
def test_a_shared_build_is_the_build_of_the_function_itself(functions):
    built: dict = {}
    for fn in functions:
        try:
            lay = layout(fn)
        except LayoutError:
            continue
        alone = build(fn, lay)
        shared = build_shared(fn, lay, built)
        event("shared" if shape_key(fn, lay) is not None and built[shape_key(fn, lay)] is not shared else "built")
        assert repr(shared) == repr(alone)  # repr: -0.0 is not 0.0, 1 is not 1.0


def test_functions_of_one_shape_share_their_steps_and_shape_texts():
    functions = [
        Function(f"t{i}", "", [2 * i], format="INT16", multiplier=0.1, minimum=-40.0, maximum=85.0) for i in range(3)
    ] + [Function("x", "", [10], format="INT16", multiplier=0.1, minimum=-40.0, maximum=-0.0)]
    resolved = resolve(Device("d", "d", functions, "1.0"))
    first, second, third, other = resolved.functions
    assert first.codec.decode is second.codec.decode is third.codec.decode
    assert first.codec.encode is second.codec.encode
    assert other.codec.encode is not first.codec.encode  # -0.0 is its own maximum
    assert [f.codec.addresses for f in resolved.functions] == [(0,), (2,), (4,), (10,)]
    for f in resolved.functions:
        fresh = ResolvedFunction(f.fn, f.ident, f.layout, f.codec)
        assert (f.decode_shape, f.encode_shape) == (_shape(fresh.codec.decode), _shape(fresh.codec.encode))
    assert "-0.0" in other.encode_shape and "-0.0" not in first.encode_shape
