"""Fuzzing the expression language: any text either compiles to a value the Python translation
computes, or is refused with an ExprError naming a column (which `mdl` reports as
FILE:LINE:COL: error), never another exception, however deep or large the text."""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mdl.device.evaluate import evaluate
from mdl.dsl.expr import pyemit
from mdl.dsl.expr.fields import Compiled, compile_device
from mdl.dsl.expr.lower import lower
from mdl.dsl.expr.nodes import ExprError
from mdl.dsl.expr.parser import MAX_DEPTH, parse
from mdl.model import BIT_TABLES, Device, Function

FIELDS = ("A", "B c")
TOKENS = [
    "int16(",
    "uint16(",
    "int32(",
    "uint32(",
    "int64(",
    "uint64(",
    "ieee754_32(",
    "ieee754_64(",
    "utf8(",
    "hexstring(",
    "eui48(",
    "ipv4addr(",
    "ipv6addr(",
    "enum(",
    "bitset(",
    "bitsetbit(",
    "boolean(",
    "concat(",
    "swapbytes(",
    "swapendian(",
    "nosuch(",
    "hr:0",
    "hr:1",
    "hr:65535",
    "ir:2",
    "c:0",
    "di:3",
    "4x0001",
    "40001",
    "300001",
    "0x1",
    "#",
    "#2",
    "#0",
    "#4",
    "#3000000000",
    "..",
    "..hr:3",
    ",",
    ";",
    "0xDEAD",
    "0x8000",
    "0xFFFF",
    " ",
    "->",
    "-1 ->",
    "'a'",
    "'b'",
    "'",
    '"',
    '"0x1234"',
    '"0x0001 0x0002"',
    "(",
    ")",
    "+",
    "-",
    "*",
    "/",
    "^",
    "0",
    "1",
    "2.5",
    ".5",
    "1e308",
    "1e309",
    "9223372036854775807",
    "9223372036854775808",
    "65536",
    "A",
    "B c",
    "B",
    "true",
    "false",
    "\t",
    "\u00b2",
    "\u0663",
]
OPENERS = ["(", "-", "concat(", "boolean(", "int16(swapbytes(", "2^", "1+", "1*", "+"]

token_soup = st.lists(st.sampled_from(TOKENS), max_size=40).map("".join)
nested = st.builds(
    lambda opener, n, inner: opener * n + inner + ")" * (n * opener.count("(")),
    st.sampled_from(OPENERS),
    st.integers(0, 3 * MAX_DEPTH),
    st.sampled_from(["1", "A", "hr:0", "c:0"]),
)
leaves = st.sampled_from(
    [
        "0",
        "1",
        "-7",
        "2.5",
        "1e300",
        "A",
        "B c",
        "true",
        "'t'",
        "int16(hr:0)",
        "uint64(hr:0#4)",
        "ieee754_32(hr:2#2; 0xDEAD 0xDEAD)",
        "ieee754_64(swapendian(hr:0#4))",
        "utf8(hr:4#3)",
        "enum(hr:7; 1 -> 'a'; 0xFFFF -> 'b')",
        "bitset(hr:8; 0 -> 'x')",
        "bitsetbit(hr:8; 3)",
        "int32(hr:9, hr:8)",
        'int16("0x8000")',
        "hexstring(hr:1..hr:3)",
    ]
)
well_formed = st.recursive(
    leaves,
    lambda inner: st.one_of(
        st.builds("{} {} {}".format, inner, st.sampled_from(["+", "-", "*", "/", "^"]), inner),
        st.builds("({})".format, inner),
        st.builds("-{}".format, inner),
        st.builds("{}({})".format, inner, inner),
        st.builds("concat({}, {})".format, inner, inner),
    ),
    max_leaves=12,
)
expressions = st.one_of(st.text(max_size=60), token_soup, nested, well_formed)


def _device(expression: str) -> Device:
    device = Device("fuzz", "fuzz", version="1.0")
    device.functions = [
        Function("A", "A", [], block_labels=["M"], expression="int16(hr:5)"),
        Function("B c", "B c", [], block_labels=["M"], expression="ieee754_32(hr:6#2)"),
        Function("F", "F", [], block_labels=["M"], expression=expression),
    ]
    return device


def _register(table: str, address: int) -> int:
    return (address * 7919 + 3) & (1 if table in BIT_TABLES else 0xFFFF)


@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(expressions)
def test_parse_gives_a_tree_or_an_error_with_a_column(text):
    try:
        parse(text, FIELDS)
    except ExprError as exc:
        assert exc.col is not None and 1 <= exc.col <= len(text) + 1, (exc, exc.col)


@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(expressions)
def test_compiled_expressions_compute_a_value(text):
    device = _device(text)
    compiled: dict[str, Compiled] = {}
    if compile_device(device, compiled):
        event("refused")
        return  # problems, each with its message: what `mdl` reports
    event("compiled")
    for fn in device.functions:
        fn.addresses = list(compiled[fn.name].lowered.addresses)
        fn.register_type = compiled[fn.name].lowered.table
    evaluate(device, ["F"], _register)


# field ids that begin alike: a reference is always the longest field id written there
NAMED = ["A", "A b", "A b c", "A_b", "Ab", "b", "Tempé", "Temp"]


def _refs(node) -> list[str]:
    from dataclasses import fields

    from mdl.dsl.expr.nodes import Node, Ref

    if isinstance(node, Ref):
        return [node.name]
    out = []
    for f in fields(node):
        value = getattr(node, f.name)
        for child in value if isinstance(value, list) else [value]:
            if isinstance(child, Node):
                out += _refs(child)
    return out


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(NAMED), min_size=1, max_size=8), st.sampled_from([" + ", "+", " * ", "-"]))
def test_references_are_the_longest_field_ids_written(names, op):
    assert _refs(parse(op.join(names), NAMED)) == names


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(well_formed, min_size=1, max_size=4), st.integers(0, 60))
def test_expressions_of_one_shape_share_their_operations_and_nothing_else(texts, shift):
    """Lowering with the shapes lowered before (as compile_device does for a whole device) gives
    exactly what lowering each expression alone gives, errors and their columns included: the same
    expressions with their registers moved take the operations of the first ones."""
    moved = [re.sub(r"hr:(\d+)", lambda m: f"hr:{int(m.group(1)) + shift}", text) for text in texts]
    types = {"A": "long", "B c": "double"}
    done: dict = {}
    for text in texts + moved:
        try:
            alone = lower(parse(text, FIELDS), types)
        except ExprError as exc:
            with pytest.raises(ExprError) as shared_error:
                lower(parse(text, FIELDS), types, done=done)
            assert (str(shared_error.value), shared_error.value.col) == (str(exc), exc.col)
            continue
        shared = lower(parse(text, FIELDS), types, done=done)
        event(
            "operations shared"
            if any(shared.ops is other.ops for other in done.values() if other is not shared)
            else "lowered"
        )
        assert repr(shared.ops) == repr(alone.ops)  # repr: 0.0 and -0.0 differ
        assert pyemit.body(shared) == pyemit._body(alone)  # printed once per shape: as it prints alone
        assert (shared.result, shared.type, shared.table, shared.addresses, shared.refs, shared.shape) == (
            alone.result,
            alone.type,
            alone.table,
            alone.addresses,
            alone.refs,
            alone.shape,
        )
