"""Fuzzing WISE-Agent register lines with quotes, commas, spaces and empty fields (issue 28): mdl reads a
line into the same columns as the agent (C `strtok(str, ",")`: every comma splits, quotes are not special,
empty fields are skipped) and so the same name, type, scaling, range and unit, or refuses it with the
line and a column; never another exception.

The agent's side is written here from its source (Modbus_Handler.cpp), not taken from the reader: tokens
are the non-empty pieces between commas; offset, name, min, max, precision (0 or absent: 1), unit and
datatype (atoi) in that order; the eighth token is the Lua column."""

from __future__ import annotations

import math
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.diagnostics import MdlError
from mdl.formats.wise.read import read_wise
from mdl.formats.wise.sections import DATA_TYPES

NAMES = ["Temp", 'Temp "a', '"quoted"', 'a"b"c', " spaced ", '"', "x'y", "T\\1"]
NUMBERS = ["0", "5", "100", "-3", "0.1", "1e2", " 7 ", "0.001", " "]
UNITS = ["V", "C", " ", "kWh", '"u"']
TYPES = ["0", "1", "2", "4", "5", "8", "9", "x"]
# the agent's eighth token -> the scaling it applies (a, b), or None: no conversion; absent: kept, not applied
LUA = [
    '"modbus_val*2"',
    "modbus_val+1",
    '""',
    '"math.floor(modbus_val)"',
    '"math.pow(modbus_val,2)"',
    '"modbus_val*2,5"',
    '""modbus_val*2"',
    '" "',
    '"""',
]
PLAIN = {'"modbus_val*2"': (2.0, 0.0), "modbus_val+1": (1.0, 1.0), '""': None}
PIECES = NAMES + NUMBERS + UNITS + TYPES + LUA + ["", "", ",", ",,", '"', ' "a,b" ']


@st.composite
def register_lines(draw: st.DrawFn) -> str:
    """`offset,name,min,max,precision,unit,datatype[,lua]` mostly well formed, with pieces swapped in."""
    fields = [
        "0",
        draw(st.sampled_from(NAMES)),
        draw(st.sampled_from(NUMBERS)),
        draw(st.sampled_from(NUMBERS)),
        draw(st.sampled_from(NUMBERS)),
        draw(st.sampled_from(UNITS)),
        draw(st.sampled_from(TYPES)),
        draw(st.sampled_from(LUA)),
    ]
    fields = fields[: draw(st.integers(2, len(fields)))]
    for _ in range(draw(st.integers(0, 3))):
        fields[draw(st.integers(0, len(fields) - 1))] = draw(st.sampled_from(PIECES))
    return ",".join(fields).strip()


def _agent(value: str) -> dict:
    """What the agent reads from an entry's value."""
    tokens = [t for t in value.split(",") if t]

    def tok(i: int) -> str | None:
        return tokens[i] if len(tokens) > i else None

    def atof(i: int) -> float:  # C's atof of a token mdl took as a number: spaces alone are 0
        return float((tok(i) or "").strip() or 0)

    low, high = atof(2), atof(3)
    return {
        "name": (tok(1) or "").strip(),
        "low": min(low, high),
        "high": max(low, high),
        "precision": atof(4) or 1.0,
        "unit": (tok(5) or "").strip() or None,
        "type": DATA_TYPES[int((tok(6) or "").strip() or 0)],
        "lua": _lua(tok(7)),
    }


def _lua(token: str | None) -> str | None:
    """The Lua token as LuaConversion takes it: one of at most two characters holding a quote is none."""
    return None if token is None or ('"' in token and len(token) <= 2) else token


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(register_lines())
def test_register_lines_read_as_the_agent_reads_them_or_are_refused(tmp_path_factory, value):
    path = Path(tmp_path_factory.mktemp("wise")) / "Modbus.ini"
    path.write_text(f"[Platform]\nName=F\n[Holding Registers]\nnumberOfR=1\nR0={value}\n", encoding="utf-8")
    try:
        device = read_wise(path)
    except MdlError as exc:
        assert exc.diagnostics, value
        assert all(d.file == str(path) and d.line == 5 and d.col and d.col >= 4 for d in exc.diagnostics), (
            value,
            [str(d) for d in exc.diagnostics],
        )
        return
    [fn] = device.functions
    agent = _agent(value)
    assert fn.name == agent["name"], value
    assert (fn.format, fn.byte_order or "big", fn.word_order or "big") == (
        agent["type"].format,
        agent["type"].byte_order,
        agent["type"].word_order,
    ), value
    assert fn.units == agent["unit"], value
    if fn.minimum is None:
        assert agent["low"] == agent["high"] == 0, value
    else:
        assert (fn.minimum, fn.maximum) == (agent["low"], agent["high"]), value
    lua = agent["lua"]
    warned = any("Lua column" in d.message and d.severity == "warning" for d in device.notes)
    if lua is not None and lua not in PLAIN:
        assert warned, value  # a conversion mdl does not apply is said
        return
    a, b = PLAIN.get(lua) or (1.0, 0.0) if lua is not None else (1.0, 0.0)
    assert not warned, value
    assert math.isclose(fn.multiplier or 1.0, a * agent["precision"]), value
    assert math.isclose(fn.offset or 0.0, b * agent["precision"], abs_tol=1e-12), value
