"""A poll's records (issue 29): `output.record` prints json, csv, table and senml from a plan worked out
once per list of functions, and writes out the JSON of a poll of finite numbers itself; for any functions
and values it must print what the plain construction from the one-value helpers prints (`json_value`,
`shown`, `_cell`, `shown_text`, `_csv_line`, `_table`, `senml`, with json.dumps), and a second record of
the same list (the plan reused) what a fresh list prints."""

from __future__ import annotations

import json
import math
from datetime import datetime, timezone

from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device import output
from mdl.model import Function

VALUES = (
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**64)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.sampled_from([0.0, -0.0, 1.0, 2.0, 230.1, 230.10000610351562, math.nan, math.inf, -math.inf])
    | st.text(max_size=4)
    | st.lists(st.text(max_size=3), max_size=2)
)
TEXT = st.text(alphabet=st.sampled_from('ab ,"\n\r.°'), max_size=4)


@st.composite
def function(draw: st.DrawFn, i: int) -> Function:
    return Function(
        draw(st.sampled_from([f"f{i}", f"Block.f{i}", f"Other.x{i % 2}"])),
        "",
        [i],
        format=draw(st.sampled_from(["UINT16", "INT16", "FLOAT32"])),
        multiplier=draw(st.sampled_from([None, 0.1])),
        values=draw(st.sampled_from([None, {0: "Off", 1: "On, really"}])),
        precision=draw(st.sampled_from([None, 1, -1])),
        units=draw(st.one_of(st.none(), TEXT)),
        minimum=draw(st.sampled_from([None, 0.0, -5.5])),
        block_labels=draw(st.sampled_from([[], ["Block"], ["Other"]])),
        access=draw(st.sampled_from([None, "read"])),
    )


def oracle(functions: list[Function], values: dict, fmt: str, when: datetime, name: str) -> str:
    if fmt == "json":
        doc = {
            output.TIME_KEY: output.iso_time(when),
            **{fn.name: output.json_value(fn, values[fn.name]) for fn in functions},
        }
        return json.dumps(doc, ensure_ascii=False) + "\n"
    if fmt == "senml":
        bt = round(when.timestamp(), 3)
        doc = {k: {"bn": b["bn"], "bt": bt, "e": b["e"]} for k, b in output.senml(functions, values, name).items()}
        return json.dumps(doc, ensure_ascii=False) + "\n"
    if fmt == "csv":
        return output._csv_line(
            [output.iso_time(when), *(output._cell(output.shown(fn, values[fn.name])) for fn in functions)]
        )
    rows = [(fn.name, output.shown_text(fn, values[fn.name]), (fn.units or "").strip()) for fn in functions]
    return output._table([(output.TIME_KEY, output.iso_time(when), ""), *rows]) + "\n"


@settings(max_examples=600, deadline=None)
@given(st.data(), st.integers(0, 6), st.sampled_from(["json", "csv", "table", "senml"]))
def test_records_print_what_the_plain_construction_prints(data, n, fmt):
    functions: list[Function] = []
    for i in range(n):
        fn = data.draw(function(i))
        if fn.name not in {f.name for f in functions}:
            functions.append(fn)
    when = datetime(2026, 11, 26, 12, 0, 0, 123000, tzinfo=timezone.utc)
    for _ in range(2):  # the second record reuses the plan with other values
        values = {fn.name: data.draw(VALUES) for fn in functions}
        expected = oracle(functions, values, fmt, when, "Dev")
        assert output.record(functions, values, fmt, when, "Dev") == expected


def test_a_list_changed_in_place_is_planned_again():
    a = Function("a", "", [0], format="UINT16", units="A")
    b = Function("b", "", [1], format="UINT16", units="V")
    functions = [a, b]
    when = datetime(2026, 11, 26, tzinfo=timezone.utc)
    assert output.record(functions, {"a": 1, "b": 2}, "csv", when) == "2026-11-26T00:00:00.000Z,1,2\n"
    functions.reverse()
    assert output.record(functions, {"a": 1, "b": 2}, "csv", when) == "2026-11-26T00:00:00.000Z,2,1\n"
    functions[0] = a
    assert output.record(functions, {"a": 1, "b": 2}, "csv", when) == "2026-11-26T00:00:00.000Z,1,1\n"


def test_a_function_listed_twice_keeps_one_json_key():
    """`mdl read FILE a a`: the json record is a JSON object, one key per name (as json.dumps of a dict)."""
    a = Function("a", "", [0], format="UINT16")
    when = datetime(2026, 11, 26, tzinfo=timezone.utc)
    assert output.record([a, a], {"a": 7}, "json", when) == '{"time": "2026-11-26T00:00:00.000Z", "a": 7}\n'


# few values, so that the records of one list repeat them (the plan's texts printed before are taken again),
# of every type that compares equal to another while printing otherwise
REPEATED = st.sampled_from([0, 0.0, -0.0, 1, 1.0, True, False, 230.1, 230.10000610351562, 2.5, math.nan, math.inf, "1"])


@settings(max_examples=400, deadline=None)
@given(st.data(), st.integers(1, 4), st.sampled_from(["json", "csv", "table", "senml"]))
def test_records_of_values_read_before_print_what_the_plain_construction_prints(data, n, fmt):
    functions: list[Function] = []
    for i in range(n):
        fn = data.draw(function(i))
        if fn.name not in {f.name for f in functions}:
            functions.append(fn)
    when = datetime(2026, 11, 26, 12, 0, 0, 123000, tzinfo=timezone.utc)
    for _ in range(20):  # past output.AFRESH_POLLS: the memos given up on new values, and taken up again
        values = {fn.name: data.draw(REPEATED) for fn in functions}
        assert output.record(functions, values, fmt, when, "Dev") == oracle(functions, values, fmt, when, "Dev")
