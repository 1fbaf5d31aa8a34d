"""`shortest_float32`: for every float32, the fewest significant digits that read back as the same bits."""

from __future__ import annotations

import math
import struct

from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device.output import _shortest_float32, shortest_float32

F32 = struct.Struct(">f")


@settings(max_examples=3000, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_shortest_text_reads_back_as_the_same_float32(bits):
    value = F32.unpack(bits.to_bytes(4, "big"))[0]
    got = shortest_float32(value)
    if not math.isfinite(value):
        assert got is value or (math.isnan(got) and math.isnan(value))
        return
    assert F32.pack(got) == F32.pack(value)  # the same float32 (sign of zero included)
    digits = len(repr(got).lstrip("-").split("e")[0].replace(".", "").strip("0")) or 1  # significant digits
    if digits > 1:  # no text of fewer significant digits is the same float32
        fewer = float(f"{value:.{digits - 1}g}")
        try:
            assert F32.pack(fewer) != F32.pack(value)
        except OverflowError:
            pass


@given(st.floats(allow_nan=False, allow_infinity=False, width=64))
def test_a_double_no_float32_holds_is_left_as_it_is(value):
    try:
        exact = F32.unpack(F32.pack(value))[0] == value
    except OverflowError:
        exact = False
    if not exact:
        assert shortest_float32(value) == value


def test_zeros_keep_their_sign_whichever_came_first():
    """The cache keys equal numbers as one: -0.0 asked first must not make 0.0 read back as -0.0 (a record
    printing `-0.0` for a register of zeros), nor the other way round."""
    for first, second in ((-0.0, 0.0), (0.0, -0.0)):
        assert math.copysign(1.0, shortest_float32(first)) == math.copysign(1.0, first)
        assert math.copysign(1.0, shortest_float32(second)) == math.copysign(1.0, second)
    assert str(shortest_float32(0.0)) == "0.0" and str(shortest_float32(-0.0)) == "-0.0"


def tried_digit_by_digit(value: float) -> float:
    """The shortest text by trying 1, 2 ... 9 significant digits: what shortest_float32 gives in one try."""
    bits = F32.pack(value)
    for digits in range(1, 10):
        candidate = float(f"{value:.{digits}g}")
        try:
            if F32.pack(candidate) == bits:
                return candidate
        except OverflowError:
            continue
    return value


@settings(max_examples=5000, deadline=None)
@given(
    st.one_of(
        st.integers(0, 2**32 - 1),  # any bits
        st.integers(0, 2**24 - 1).map(lambda b: b | (0x3F800000 & ~0x7FFFFF)),  # mantissas around 1.0
        st.sampled_from([0x00800000, 0x00800001, 0x007FFFFF, 0x7F7FFFFF, 0x4B800000, 0x3F800000, 0x40000000]),
        st.integers(-(10**6), 10**6).map(lambda n: int.from_bytes(F32.pack(n / 100), "big")),  # two decimals
    )
)
def test_one_try_at_six_digits_gives_what_trying_each_digit_gives(bits):
    value = F32.unpack(bits.to_bytes(4, "big"))[0]
    if not math.isfinite(value) or value == 0:
        return
    got = _shortest_float32.__wrapped__(value)  # uncached
    assert got == tried_digit_by_digit(value) and math.copysign(1.0, got) == math.copysign(1.0, value)
