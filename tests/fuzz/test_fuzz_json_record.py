"""A json record's values (issue 29): `output._json_values` writes out json_value for a function without
labels (a poll's cost); for every value and function it must give what json_value gives, NaN and the
infinities as text, labels where the enumeration names the value."""

from __future__ import annotations

import json
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device import output
from mdl.model import Function

VALUES = (
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**64)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.sampled_from([0.0, -0.0, 1.0, 2.0, 230.1, math.nan, math.inf, -math.inf])
    | st.text(max_size=4)
    | st.lists(st.text(max_size=3), max_size=2)
)
FUNCTIONS = st.sampled_from(
    [
        Function("plain", "", [0], format="UINT16"),
        Function("float", "", [0], format="FLOAT32"),
        Function("labels", "", [0], format="UINT16", values={0: "Off", 1: "On", 2: "Auto"}),
        Function("scaled", "", [0], format="INT16", multiplier=0.1),
    ]
)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(FUNCTIONS, VALUES), max_size=6))
def test_json_values_are_json_value_of_each(pairs):
    functions, values = [], {}
    for i, (fn, value) in enumerate(pairs):
        fn = Function(f"{fn.name}{i}", "", [i], format=fn.format, multiplier=fn.multiplier, values=fn.values)
        functions.append(fn)
        values[fn.name] = value
    expected = {fn.name: output.json_value(fn, values[fn.name]) for fn in functions}
    got = output._json_values(functions, values)
    assert json.dumps(got) == json.dumps(expected)  # NaN-safe: compared as the text they print
