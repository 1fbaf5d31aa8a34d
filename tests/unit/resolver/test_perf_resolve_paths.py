"""The fast paths of reading and resolving (issue 29) held to the plain code they replace: each
reference below is that code as it was, and the fast one must give the same answer (or the same
error) for any input."""

from __future__ import annotations

import unicodedata
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.ir import steps as ir
from mdl.ir.build import units
from mdl.model import BIT_TABLES, LENGTHS, ORDERS, READ_ONLY_TABLES, REGISTER_TYPES, Function
from mdl.model.layout import (
    FORMAT_BITS,
    MAX_ADDRESS,
    MAX_BITS,
    MAX_REGISTERS,
    UNIT_FOR_LENGTH,
    Layout,
    LayoutError,
    address_runs,
    layout,
)
from mdl.model.names import identifier
from mdl.plan import TABLE_ORDER, Request, plan_reads, split_request
from mdl.resolver import cached_property

# -- references: the code as it was


def ref_layout(fn: Function) -> Layout:
    fmt = fn.eff_format
    table = fn.table
    bit_table = table in BIT_TABLES
    if bit_table and fmt != "BIT" and fn.format is not None:
        raise LayoutError(f"a {table} holds one bit; format {fmt} needs registers (use BIT)")
    if bit_table or fmt == "BIT":
        unit = "bit" if bit_table else "word"
        needed = 1
    else:
        unit = UNIT_FOR_LENGTH[fn.eff_length]
        unit_bits = 16 if unit == "word" else 8
        needed = max(fn.eff_count, -(-FORMAT_BITS[fmt] // unit_bits))
    if not fn.addresses:
        raise LayoutError("no address")
    n = len(fn.addresses) if len(fn.addresses) > 1 else needed
    limit = MAX_BITS if unit == "bit" else MAX_REGISTERS
    if n > limit:
        raise LayoutError(f"the value needs {n} registers; one request reads at most {limit}")
    if len(fn.addresses) > 1:
        if len(fn.addresses) < needed:
            raise LayoutError(f"needs {needed} registers but lists {len(fn.addresses)} addresses")
        if len(set(fn.addresses)) != len(fn.addresses):
            raise LayoutError("an address is listed twice")
        addresses = tuple(fn.addresses)
    else:
        addresses = tuple(range(fn.addresses[0], fn.addresses[0] + needed))
    too_high = [a for a in addresses if a > MAX_ADDRESS]
    if too_high:
        raise LayoutError(f"address {too_high[0]} is over {MAX_ADDRESS}")
    if bit_table or fmt == "BIT":
        if n != 1:
            raise LayoutError("a BIT value is one coil or discrete input")
        return Layout(table, addresses, unit, "bool", 1, False, "big", "big")  # type: ignore[arg-type]
    span = n * (16 if unit == "word" else 8)
    byte_order, word_order = fn.eff_byte_order, fn.eff_word_order
    if fmt == "STRING":
        return Layout(table, addresses, unit, "string", span, False, byte_order, word_order)  # type: ignore[arg-type]
    if fmt.startswith("FLOAT"):
        if span != FORMAT_BITS[fmt]:
            raise LayoutError(f"{fmt} needs exactly {FORMAT_BITS[fmt]} bits; the function spans {span}")
        return Layout(table, addresses, unit, "float", span, True, byte_order, word_order)  # type: ignore[arg-type]
    bits = FORMAT_BITS[fmt] if (unit == "word" and n == 1 and FORMAT_BITS[fmt] == 8) else span
    if bits > 64:
        raise LayoutError(f"an integer of {bits} bits is wider than 64 (format {fmt}, {n} units)")
    return Layout(table, addresses, unit, "int", bits, not fmt.startswith("U"), byte_order, word_order)  # type: ignore[arg-type]


def ref_split_request(request: Request, layouts: dict[str, Layout]) -> list[Request]:
    names_of: dict[tuple[int, int], list[str]] = {}
    for name in request.functions:
        lay = layouts[name]
        for run in address_runs(sorted({a for a in lay.addresses if request.start <= a < request.end})):
            names = names_of.setdefault(run, [])
            if name not in names:
                names.append(name)
    return [Request(request.table, start, count, tuple(names)) for (start, count), names in names_of.items()]


def ref_plan_reads(functions: list[Function], limit: int, layouts: dict[str, Layout]) -> list[Request]:
    defined: dict[str, set[int]] = {t: set() for t in TABLE_ORDER}
    for fn in functions:
        defined[layouts[fn.name].table].update(layouts[fn.name].addresses)
    needed: dict[str, dict[int, list[str]]] = {t: {} for t in TABLE_ORDER}
    for fn in functions:
        if not fn.readable:
            continue
        lay = layouts[fn.name]
        for a in lay.addresses:
            needed[lay.table].setdefault(a, []).append(fn.name)
    requests = []
    for table in TABLE_ORDER:
        most = MAX_BITS if table in ("coil", "discrete") else limit
        points = sorted(needed[table])
        there = defined[table]
        i = 0
        while i < len(points):
            start = end = points[i]
            names_in: dict[str, None] = {}
            while (
                i < len(points)
                and points[i] - start < most
                and (points[i] == end + 1 or all(a in there for a in range(end + 1, points[i] + 1)))
            ):
                end = points[i]
                names_in.update(dict.fromkeys(needed[table][end]))
                i += 1
            requests.append(Request(table, start, end - start + 1, tuple(names_in)))
    return requests


def ref_identifier(name: str) -> str:
    import re

    from mdl.model.names import RESERVED

    folded = unicodedata.normalize("NFKD", name).encode("ascii", "ignore").decode("ascii")
    ident = re.sub(r"[^a-z0-9]+", "_", folded.lower()).strip("_")
    if not ident:
        ident = "unnamed"
    if ident[0].isdigit():
        ident = "f_" + ident
    if ident in RESERVED:
        ident += "_"
    return ident


def ref_units(lay: Layout) -> tuple[ir.Unit, ...]:
    n = len(lay.addresses)
    order = range(n) if lay.word_order == "big" else reversed(range(n))
    part = ("word" if lay.byte_order == "big" else "swap") if lay.unit == "word" else lay.unit
    unit_bits = 16 if lay.unit == "word" else 8
    return tuple(ir.Unit(i, part, unit_bits * (n - 1 - pos)) for pos, i in enumerate(order))  # type: ignore[arg-type]


# -- strategies

maybe = st.none() | st.just("")
floats = st.none() | st.sampled_from([0.0, -0.0, 1.0, 1, 0, 0.1, -40.0]) | st.floats(allow_nan=True)
function_kw = st.fixed_dictionaries(
    {
        "name": st.text(max_size=6),
        "description": st.just(""),
        "addresses": st.lists(st.integers(-3, MAX_ADDRESS + 3) | st.integers(0, 12), max_size=5),
    },
    optional={
        "length": maybe | st.sampled_from(LENGTHS),
        "count": st.none() | st.integers(-2, 130) | st.just(2001),
        "format": maybe | st.sampled_from(list(FORMAT_BITS)),
        "register_type": maybe | st.sampled_from(REGISTER_TYPES),
        "byte_order": maybe | st.sampled_from(ORDERS),
        "word_order": maybe | st.sampled_from(ORDERS),
        "access": maybe | st.sampled_from(["read", "write", "read_write", "bogus"]),
        "expression": st.none() | st.just("1"),
        "multiplier": floats,
        "offset": floats,
    },
)


def outcome(call: Any, *args: Any) -> tuple[str, Any]:
    try:
        return "ok", call(*args)
    except LayoutError as exc:
        return "error", str(exc)


@settings(max_examples=1500, deadline=None)
@given(function_kw)
def test_layout_and_properties_are_the_plain_ones(kw):
    fn = Function(**kw)
    if fn.expression is None:
        assert outcome(layout, fn) == outcome(ref_layout, fn)
    assert fn.readable == (fn.eff_access in ("read", "read_write"))
    assert fn.writable == (
        fn.eff_access in ("write", "read_write") and fn.table not in READ_ONLY_TABLES and fn.expression is None
    )
    assert fn.scales == (fn.eff_multiplier != 1.0 or fn.eff_offset != 0.0)


layouts_st = st.builds(
    Layout,
    table=st.just("holding"),
    addresses=st.lists(st.integers(0, 40), max_size=6).map(tuple)
    | st.tuples(st.integers(0, 30), st.integers(1, 6)).map(lambda p: tuple(range(p[0], p[0] + p[1]))),
    unit=st.sampled_from(["word", "low", "high", "bit"]),
    kind=st.just("int"),
    bits=st.just(16),
    signed=st.booleans(),
    byte_order=st.sampled_from(ORDERS),
    word_order=st.sampled_from(ORDERS),
)


@settings(max_examples=1500, deadline=None)
@given(st.lists(layouts_st, min_size=1, max_size=6), st.integers(0, 40), st.integers(0, 45))
def test_split_request_is_the_plain_one(lays, start, count):
    layouts = {f"f{i}": lay for i, lay in enumerate(lays)}
    request = Request("holding", start, count, tuple(layouts))
    assert split_request(None, request, layouts) == ref_split_request(request, layouts)  # type: ignore[arg-type]


@settings(max_examples=1000, deadline=None)
@given(st.lists(function_kw, max_size=8), st.integers(1, 125))
def test_plan_reads_is_the_plain_one(kws, limit):
    from mdl.model import Device

    functions, layouts = [], {}
    for i, kw in enumerate(kws):
        fn = Function(**{**kw, "name": f"f{i}", "expression": None})
        try:
            layouts[fn.name] = layout(fn)
        except LayoutError:
            continue
        functions.append(fn)
    device = Device("d", "", functions, max_registers=limit)
    assert plan_reads(device, layouts=layouts) == ref_plan_reads(functions, limit, layouts)


@settings(max_examples=1000, deadline=None)
@given(st.text() | st.text(alphabet="aZ_ -.09éﬁ²Ⅻ"))
def test_identifier_is_the_plain_one(name):
    assert identifier(name) == ref_identifier(name)


@given(layouts_st)
def test_units_are_the_plain_ones(lay):
    assert units(lay) == ref_units(lay)
    assert repr(units(lay)) == repr(ref_units(lay))


@pytest.mark.parametrize(
    "step",
    [
        ir.Scale(10, 0.1, -0.0),
        ir.Scale(None, 1, 0.0),
        ir.Compose((ir.Unit(0, "word", 16), ir.Unit(1, "swap", 0))),
        ir.CheckRange(None, -0.0),
        ir.RoundInt(0, 1, 1, False, 1),
        ir.Merge((0xFF,), True),
        ir.ToBool(),
    ],
)
def test_ir_repr_is_dataclass_repr(step):
    """The IR's repr (decode_shape) is dataclass's, field by field: 0.0 and -0.0, 1 and 1.0 told apart."""
    shown = ", ".join(f"{name}={getattr(step, name)!r}" for name in step.__record_fields__)
    expected = f"{type(step).__qualname__}({shown})"
    assert repr(step) == expected


def test_cached_property_keeps_its_value():
    class Thing:
        calls = 0

        @cached_property
        def value(self) -> int:
            """The doc."""
            Thing.calls += 1
            return 7

    thing = Thing()
    assert thing.value == 7 and thing.value == 7 and Thing.calls == 1
    assert thing.__dict__["value"] == 7
    assert Thing.__dict__["value"].__doc__ == "The doc."


def ref_address_runs(addresses: list[int]) -> tuple[tuple[int, int], ...]:
    out: list[tuple[int, int]] = []
    for a in addresses:
        if out and a == out[-1][0] + out[-1][1]:
            out[-1] = (out[-1][0], out[-1][1] + 1)
        else:
            out.append((a, 1))
    return tuple(out)


@settings(max_examples=500, deadline=None)
@given(
    st.one_of(
        st.lists(st.integers(0, 40), max_size=8),
        st.builds(lambda a, n: list(range(a, a + n)), st.integers(0, 65535), st.integers(1, 130)),
    )
)
def test_address_runs_is_the_plain_one(addresses):
    """A layout's addresses (a tuple) in one run are told at once; any other are walked."""
    assert address_runs(tuple(addresses)) == address_runs(addresses) == ref_address_runs(addresses)
