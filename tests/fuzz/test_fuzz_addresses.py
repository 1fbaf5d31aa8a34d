"""Fuzzing the address notations: any text names a register, or is refused with an AddressError
(or, inside an expression, an ExprError with a column), never another exception; runs are sized
before they are built, so no answer ever holds more addresses than one request can read."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.dsl.expr.nodes import ExprError, Registers
from mdl.dsl.expr.parser import Parser
from mdl.model.addressing import AddressError, address_range, address_run, match_address, parse_address
from mdl.model.layout import MAX_ADDRESS, MAX_BITS

PREFIXES = [
    "hr:",
    "HR :",
    "holding-register:",
    "holding_register:",
    "ir:",
    "input-register:",
    "c:",
    "coil:",
    "di:",
    "discrete-input:",
    "4x",
    "3X",
    "1x",
    "0x",
    "2x",
    "4",
    "3",
    "0",
    "1",
    "x:",
    "",
]
numbers = st.one_of(
    st.integers(0, 70000).map(str),
    st.integers(0, 10**40).map(str),
    st.integers(0, 5).map(lambda n: "0" * n + "1"),
    st.just("9" * 5000),
    st.text(alphabet="0123456789\u0663\u00b2 ", max_size=12),
)
addresses = st.one_of(st.builds(str.__add__, st.sampled_from(PREFIXES), numbers), st.text(max_size=30))
register_sets = st.lists(
    st.tuples(addresses, st.sampled_from(["", "#", "..", " # "]), numbers | addresses), min_size=1, max_size=6
).map(lambda parts: ", ".join(a + sep + (b if sep else "") for a, sep, b in parts))


@settings(max_examples=1500, deadline=None)
@given(addresses)
def test_an_address_is_a_register_or_an_address_error(text):
    try:
        table, address = parse_address(text)
    except AddressError:
        return
    assert table in ("holding", "input", "coil", "discrete") and 0 <= address <= MAX_ADDRESS


@settings(max_examples=1500, deadline=None)
@given(st.text(max_size=30), st.integers(0, 40), st.booleans(), st.booleans())
def test_match_address_anywhere_in_a_text(text, pos, modicon_digits, x_coils):
    try:
        found = match_address(text, pos, modicon_digits, x_coils)
    except AddressError:
        return
    if found is not None:
        assert 0 <= found[1] <= MAX_ADDRESS and pos < found[2] <= len(text)


@settings(max_examples=1500, deadline=None)
@given(st.integers(-10, 10**12), st.integers(-10, 10**12))
def test_runs_are_checked_before_they_are_built(first, other):
    first = min(first, MAX_ADDRESS) if first >= 0 else 0
    for build in (address_run, address_range):
        try:
            run = build(first, other)
        except AddressError:
            continue
        assert 1 <= len(run) <= MAX_BITS and run[-1] <= MAX_ADDRESS


@settings(max_examples=1500, deadline=None)
@given(register_sets)
def test_register_sets_of_an_expression(text):
    parser = Parser(text)
    try:
        node = parser.registers()
    except ExprError as exc:
        assert exc.col is not None and 1 <= exc.col <= len(text) + 1
        return
    if isinstance(node, Registers):  # else a constant "0x.." or a swap, which the text may also start with
        assert 1 <= len(node.addresses) <= MAX_ADDRESS + 1 and all(0 <= a <= MAX_ADDRESS for a in node.addresses)
