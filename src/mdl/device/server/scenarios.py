"""`mdl test`: run the scenarios embedded in a device (raw registers in, expected values out)
and compare like the Modbus Schema Toolkit: doubles at 3 decimals, [] = null, bitsets as lists."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final, Literal, TypeAlias

from mdl.device.evaluate import Evaluator, evaluate
from mdl.dsl.expr.pyhelpers import _x_text
from mdl.model import Device, Scenario, Value

ReadError: TypeAlias = Literal["error"]
READ_ERROR: Final[ReadError] = "error"
Given: TypeAlias = dict[tuple[str, int], int | ReadError | None]


def scenario_registers(sc: Scenario) -> Given:
    """(table, address) -> register/bit value, None for "----", READ_ERROR for "xxxx"."""
    raw: Given = {}
    for item in sc.inputs:
        address = item.address
        for word in item.values:
            if item.table in ("coil", "discrete"):  # one character a bit: 0, 1, - (no value), x (error)
                for ch in word:
                    raw[(item.table, address)] = int(ch) if ch in "01" else (None if ch == "-" else READ_ERROR)
                    address += 1
                continue
            if word == "----":
                raw[(item.table, address)] = None
            elif word.lower() == "xxxx":
                raw[(item.table, address)] = READ_ERROR
            else:
                raw[(item.table, address)] = int(word, 16)
            address += 1
    return raw


def _number(text: str) -> float | None:
    t = text.strip()
    special = {
        "nan": math.nan,
        "+infinite": math.inf,
        "infinite": math.inf,
        "infinity": math.inf,
        "+infinity": math.inf,
        "-infinite": -math.inf,
        "-infinity": -math.inf,
    }
    if t.lower() in special:
        return special[t.lower()]
    try:
        return float(t)
    except ValueError:
        return None


def matches(actual: Value, expected: list[str] | None) -> bool:
    if not expected:
        return actual is None or actual == []
    if actual is None:
        return False
    if isinstance(actual, list):
        return actual == expected
    if len(expected) != 1:
        return False
    want = expected[0]
    if isinstance(actual, bool):
        return want.strip().lower() == ("true" if actual else "false")
    if isinstance(actual, (int, float)):
        number = _number(want)
        if number is None:
            return False
        if math.isnan(actual) or math.isnan(number):
            return math.isnan(actual) and math.isnan(number)
        if math.isinf(actual) or math.isinf(number):
            return actual == number
        return f"{actual:.3f}" == f"{number:.3f}" or actual == number
    return actual == want


def shown(value: Value) -> str:
    if value is None:
        return "[]"
    if isinstance(value, list):
        return "[" + ", ".join(repr(v) for v in value) + "]"
    return "[" + repr(_x_text(value)) + "]"


@dataclass
class Failure:
    scenario: str
    function: str
    expected: list[str] | None
    got: Value

    def __str__(self) -> str:
        want = "[]" if not self.expected else "[" + ", ".join(repr(v) for v in self.expected) + "]"
        return f"test '{self.scenario}': {self.function}: expected {want}, got {shown(self.got)}"


def run_scenario(device: Device | Evaluator, sc: Scenario) -> list[Failure]:
    """The scenario's failures. Given one Evaluator for all of a device's scenarios (as `mdl test` does),
    the device is resolved and compiled once, so that each scenario takes time in proportion to what it
    names, not to the device's size."""
    raw = scenario_registers(sc)

    def lookup(table: str, address: int) -> int | None:
        value = raw.get((table, address))
        return None if value == READ_ERROR else value

    names = list(sc.expected)
    values = device.values(names, lookup) if isinstance(device, Evaluator) else evaluate(device, names, lookup)
    return [
        Failure(sc.id, name, want, values[name])
        for name, want in sc.expected.items()
        if not matches(values[name], want)
    ]


def find_scenario(device: Device, scenario_id: str) -> Scenario:
    from mdl.diagnostics import error

    for sc in device.tests:
        if sc.id == scenario_id:
            return sc
    known = ", ".join(repr(s.id) for s in device.tests[:10]) or "none"
    raise error(f"no test scenario '{scenario_id}' (scenarios: {known})", device.source)
