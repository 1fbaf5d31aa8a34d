"""Printing values read from a device: table, json, csv, senml; once (`render`) or as a poll's records
(`record_header` once, then `record` per poll)."""

from __future__ import annotations

import csv
import io
import json
import math
from datetime import datetime, timezone
from typing import Any, TypedDict

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


def _json_values(functions: list[Function], values: dict[str, Value]) -> dict[str, Value]:
    return {fn.name: _json_value(shown(fn, values[fn.name])) for fn in functions}


def _csv_line(cells: list[str]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(cells)
    return buf.getvalue()


def _cell(value: Value) -> str:
    return "" if value is None else _text(value)


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
    if fmt == "json":
        return json.dumps(_json_values(functions, values), indent=2, ensure_ascii=False) + "\n"
    if fmt == "csv":
        rows = [[fn.name, _cell(shown(fn, values[fn.name])), (fn.units or "").strip()] for fn in functions]
        return "".join(_csv_line(row) for row in [["name", "value", "units"], *rows])
    return _table([(fn.name, _text(shown(fn, values[fn.name])), (fn.units or "").strip()) for fn in functions])


def _table(rows: list[tuple[str, str, str]]) -> str:
    """Lines `name  value units`, names padded to the longest."""
    width = max((len(name) for name, _, _ in rows), default=4)
    lines = [f"{name:<{width}}  {text}{' ' + units if units else ''}" for name, text, units in rows]
    return "\n".join(lines) + ("\n" if lines else "")


TIME_KEY = "time"  # the key (json), column (csv) and first row (table) of a poll record's time


def iso_time(when: datetime) -> str:
    """ISO 8601 UTC to the millisecond: 2026-11-23T05:00:00.123Z."""
    when = when.astimezone(timezone.utc)
    return f"{when:%Y-%m-%dT%H:%M:%S}.{when.microsecond // 1000:03d}Z"


def record_header(functions: list[Function], fmt: str) -> str:
    """What a poll prints once before its records: csv's header (time, then the function names)."""
    return _csv_line([TIME_KEY, *(fn.name for fn in functions)]) if fmt == "csv" else ""


def record(functions: list[Function], values: dict[str, Value], fmt: str, when: datetime,
           device_name: str = "") -> str:
    """One poll's record, ending with a newline: json one object on one line, time first; csv one row, time
    first; table a block (a time row, the values, a blank line); senml one document on one line, each
    block with `bt`, the time in seconds since 1970 (UTC)."""
    if fmt == "senml":
        bt = round(when.timestamp(), 3)
        doc: dict[str, Any] = {label: {"bn": block["bn"], "bt": bt, "e": block["e"]}
                               for label, block in senml(functions, values, device_name).items()}
        return json.dumps(doc, ensure_ascii=False) + "\n"
    if fmt == "json":
        return json.dumps({TIME_KEY: iso_time(when), **_json_values(functions, values)}, ensure_ascii=False) + "\n"
    if fmt == "csv":
        return _csv_line([iso_time(when), *(_cell(shown(fn, values[fn.name])) for fn in functions)])
    rows = [(fn.name, _text(shown(fn, values[fn.name])), (fn.units or "").strip()) for fn in functions]
    return _table([(TIME_KEY, iso_time(when), ""), *rows]) + "\n"
