"""Printing values read from a device: table, json, csv."""

from __future__ import annotations

import csv
import io
import json
import math
from typing import TypedDict

from mdl.model import Function, Value


class Block(TypedDict):
    """One SenML record pack: the block's name and its entries."""

    bn: str
    e: list[dict[str, Value]]


def shown(fn: Function, value: Value) -> Value:
    """The value as users see it: enumeration text where `values` names it."""
    if fn.values and isinstance(value, (int, float)) and not isinstance(value, bool):
        if float(value).is_integer() and int(value) in fn.values:
            return fn.values[int(value)]
    return value


def _json_value(value: Value) -> Value:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def _text(value: Value) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return ", ".join(value)
    return str(value)


def senml(functions: list[Function], values: dict[str, Value], device_name: str) -> dict[str, Block]:
    """The WISE-Agent guide's JSON: one object per block label, {"bn": block, "e": [entries]}."""
    out: dict[str, Block] = {}
    for fn in functions:
        block = fn.block or device_name
        entry: dict[str, Value] = {"n": fn.name}
        value = shown(fn, values[fn.name])
        if isinstance(value, bool):
            entry["bv"] = value
        elif isinstance(value, (int, float)):
            entry["v"] = _json_value(value)
        elif isinstance(value, list):
            entry["sv"] = ", ".join(value)
        elif value is not None:
            entry["sv"] = value
        if fn.units and fn.units.strip():
            entry["u"] = fn.units.strip()
        for key in ("minimum", "maximum"):
            if getattr(fn, key) is not None:
                entry[key[:3]] = getattr(fn, key)
        entry["asm"] = "rw" if fn.writable else "r"
        out.setdefault(block, {"bn": block, "e": []})["e"].append(entry)
    return out


def render(functions: list[Function], values: dict[str, Value], fmt: str, device_name: str = "") -> str:
    if fmt == "senml":
        return json.dumps(senml(functions, values, device_name), indent=2, ensure_ascii=False) + "\n"
    rows = [(fn, shown(fn, values[fn.name])) for fn in functions]
    if fmt == "json":
        return json.dumps({fn.name: _json_value(v) for fn, v in rows}, indent=2, ensure_ascii=False) + "\n"
    if fmt == "csv":
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["name", "value", "units"])
        for fn, v in rows:
            writer.writerow([fn.name, "" if v is None else _text(v), (fn.units or "").strip()])
        return buf.getvalue()
    width = max((len(fn.name) for fn, _ in rows), default=4)
    lines = []
    for fn, v in rows:
        text = _text(v)
        units = (fn.units or "").strip()
        lines.append(f"{fn.name:<{width}}  {text}{' ' + units if units else ''}")
    return "\n".join(lines) + ("\n" if lines else "")
