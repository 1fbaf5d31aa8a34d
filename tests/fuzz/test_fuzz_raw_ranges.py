"""Fuzzing `mdl read --raw`'s ranges and `--as` grouping (mdl.device.survey.rawread), and `mdl probe`'s --range,
--bauds and --tables: any text is a range inside the address space or a ValueError, never another exception;
a range printed reads back as itself; the values of a range cover exactly its registers.
MDL_FUZZ_EXAMPLES=20000 runs the long budget by hand."""

from __future__ import annotations

import os

from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device.survey.probe_options import parse_bauds, parse_list, parse_span
from mdl.device.survey.rawread import AS_TYPES, RAW_TABLES, RawRange, parse_raw_range, raw_functions
from mdl.model.layout import MAX_ADDRESS, layout

EXAMPLES = int(os.environ.get("MDL_FUZZ_EXAMPLES", "200"))
numbers = st.one_of(
    st.integers(0, 70000).map(str),
    st.integers(0, 10**30).map(str),
    st.just("9" * 5000),
    st.text(alphabet="0123456789\u0663\u00b2 +-", max_size=10),
)
words = st.sampled_from([*RAW_TABLES, "HR", "Coil", "x", "", "hr hr", "40001"])
texts = st.one_of(
    st.builds(
        lambda w, a, sep, b: f"{w}:{a}{sep}{b}", words, numbers, st.sampled_from(["", "-", "+", " - ", "--"]), numbers
    ),
    st.text(max_size=30),
)


@settings(max_examples=EXAMPLES, deadline=None)
@given(texts)
def test_a_raw_range_is_in_the_address_space_or_a_value_error(text):
    try:
        rng = parse_raw_range(text)
    except ValueError:
        return
    assert rng.table in ("holding", "input", "coil", "discrete")
    assert 0 <= rng.first <= rng.last <= MAX_ADDRESS
    assert parse_raw_range(str(rng)) == rng


ranges = st.builds(
    lambda table, first, size: RawRange(table, first, min(first + size - 1, MAX_ADDRESS)),
    st.sampled_from(["holding", "input", "coil", "discrete"]),
    st.integers(0, MAX_ADDRESS),
    st.integers(1, 300),
)


@settings(max_examples=EXAMPLES, deadline=None)
@given(st.lists(ranges, min_size=1, max_size=3), st.sampled_from(sorted(AS_TYPES)))
def test_the_values_of_ranges_cover_exactly_their_registers(found, as_type):
    try:
        functions = raw_functions(found, as_type)
    except ValueError:
        width = AS_TYPES[as_type][1]
        words = [r for r in found if r.table in ("holding", "input")]
        firsts = [(r.table, r.first) for r in words]
        assert any(r.count % (width or r.count) or r.count > 125 for r in words) or (
            as_type == "string" and len(set(firsts)) < len(firsts)
        )
        return
    covered = {(lay.table, a) for fn in functions for lay in [layout(fn)] for a in lay.addresses}
    assert covered == {(r.table, a) for r in found for a in range(r.first, r.last + 1)}


@settings(max_examples=EXAMPLES, deadline=None)
@given(st.text(max_size=30), st.text(alphabet="0123456789, ", max_size=20), st.text(max_size=20))
def test_probe_options_parse_or_say_what_is_wrong(span, bauds, tables):
    for parse in (
        lambda: parse_span(span),
        lambda: parse_bauds(bauds),
        lambda: parse_list(tables, "a table", RAW_TABLES),
    ):
        try:
            parse()
        except ValueError:
            pass
