"""SunSpec model definitions (SPEC 12): a model id (read from the installed pysunspec2 package, never a
copy of it) or the path of a model JSON file -> the definition as a checked dict, or a clean error naming
the file (and line and column for JSON syntax) and what is wrong.

The check is structural, what building a chain relies on (points with a known type, strings with a
size, scale factors and counts naming points that exist), then pysunspec2's own `validate_model_def`.
"""

from __future__ import annotations

import importlib
import json
import re
from importlib import resources
from pathlib import Path
from typing import Any

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.fileio import decode_text, input_path, read_bytes

# SunSpec point type -> registers it takes (None: a string's `size`)
TYPE_REGISTERS: dict[str, int | None] = {
    "int16": 1, "uint16": 1, "count": 1, "acc16": 1, "enum16": 1, "bitfield16": 1, "pad": 1, "sunssf": 1,
    "int32": 2, "uint32": 2, "acc32": 2, "enum32": 2, "bitfield32": 2, "ipaddr": 2, "float32": 2,
    "int64": 4, "uint64": 4, "acc64": 4, "float64": 4, "eui48": 4,
    "ipv6addr": 8, "string": None,
}  # fmt: skip
# the values a symbol of an enum (the raw value) or a bitfield (the bit's number) can take
SYMBOL_RANGE: dict[str, tuple[int, int, str]] = {
    "enum16": (0, 0xFFFF, "raw values"),
    "enum32": (0, 0xFFFFFFFF, "raw values"),
    "bitfield16": (0, 15, "bit numbers"),
    "bitfield32": (0, 31, "bit numbers"),
}
MAX_FILE_BYTES = 4 * 1024 * 1024  # the largest shipped model is under 200 kB
MAX_GROUP_DEPTH = 16  # groups in groups; every step of a chain's build is then bounded
SHOWN_PROBLEMS = 10  # problems of one definition said in full
_MODEL_ID = re.compile(r"[0-9]{1,6}")

ModelDef = dict[str, Any]


def models_dir() -> Path:
    """The folder of the model JSON files pysunspec2 ships."""
    return Path(str(resources.files("sunspec2") / "models" / "json"))


def shipped_ids() -> list[int]:
    """Every model id pysunspec2 ships, ascending."""
    ids = (p.stem.removeprefix("model_") for p in models_dir().glob("model_*.json"))
    return sorted(int(i) for i in ids if i.isdigit())


def load_model(spec: str) -> ModelDef:
    """The definition `spec` names (a model id such as `103`, or a JSON file's path, `-` standard input);
    MdlError when there is no such model or the definition is not one."""
    if _MODEL_ID.fullmatch(spec):
        path = models_dir() / f"model_{int(spec)}.json"
        if not path.is_file():
            ids = shipped_ids()
            raise error(
                f"unknown SunSpec model {int(spec)}: pysunspec2 ships models {ids[0]}..{ids[-1]} "
                f"({len(ids)} of them, e.g. 1, 101, 103, 160); give a model id it ships or a model JSON file",
                spec,
            )
        return parse_model(read_bytes(path, limit=MAX_FILE_BYTES), str(path))
    path = input_path(spec)  # `-`: standard input
    return parse_model(read_bytes(path, limit=MAX_FILE_BYTES), str(path))


def parse_model(data: bytes, where: str) -> ModelDef:
    """The checked definition in the JSON text `data` (`where` names it in messages)."""
    text = decode_text(data, where)
    try:
        model = json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"not valid JSON: {exc.msg}", where, exc.lineno, exc.colno) from None
    except RecursionError:
        raise error("not a SunSpec model: the JSON nests too deeply", where) from None
    try:
        problems = structure_problems(model) or pysunspec_problems(model)
    except RecursionError:
        problems = ["its groups nest too deeply"]
    if problems:
        shown = problems[:SHOWN_PROBLEMS]
        if len(problems) > len(shown):
            shown.append(f"and {len(problems) - len(shown)} more problems")
        raise MdlError([Diagnostic(where, None, None, f"not a SunSpec model definition: {p}") for p in shown])
    return dict(model)


def pysunspec_problems(model: ModelDef) -> list[str]:
    """What pysunspec2's own validator says of the definition (one problem a line)."""
    mdef: Any = importlib.import_module("sunspec2.mdef")
    try:
        result = str(mdef.validate_model_def(model))
    except (TypeError, AttributeError, KeyError, ValueError) as exc:  # shapes our own check did not foresee
        return [f"pysunspec2 cannot validate it ({type(exc).__name__}: {exc})"]
    return [line for line in result.replace("Duplicate", "\nDuplicate").splitlines() if line.strip()]


def structure_problems(model: object) -> list[str]:
    """What a chain cannot be built from: each problem with the JSON path of the element."""
    if not isinstance(model, dict):
        return ["the file holds no JSON object"]
    mid = model.get("id")
    if not isinstance(mid, int) or isinstance(mid, bool) or not 1 <= mid <= 65534:
        return ["'id' must be an integer model id from 1 to 65534"]
    group = model.get("group")
    if not isinstance(group, dict):
        return ["'group' (the model's top-level group) is missing or not an object"]
    problems: list[str] = []
    _check_group(group, "group", [], problems)
    points = group.get("points")
    top = [(p.get("name"), p.get("type")) for p in points if isinstance(p, dict)] if isinstance(points, list) else []
    if top[:2] != [("ID", "uint16"), ("L", "uint16")]:
        problems.append("the top-level group must start with the uint16 points ID and L")
    return problems


def _check_group(group: dict[str, Any], path: str, scopes: list[dict[str, object]], problems: list[str]) -> None:
    if not isinstance(group.get("name"), str) or not group["name"]:
        problems.append(f"{path}: a group needs a 'name'")
    points, groups = group.get("points", []), group.get("groups", [])
    if not isinstance(points, list) or not isinstance(groups, list):
        problems.append(f"{path}: 'points' and 'groups' must be lists")
        return
    if len(scopes) > MAX_GROUP_DEPTH:
        problems.append(f"{path}: groups nest deeper than {MAX_GROUP_DEPTH} levels (the shipped models: 3)")
        return
    names = {p["name"]: p.get("type") for p in points if isinstance(p, dict) and isinstance(p.get("name"), str)}
    if scopes and not points:  # a group of no registers: its repeats would fill nothing, without end
        problems.append(f"{path}: a group needs at least one point")
    inner = [*scopes, names]
    for i, p in enumerate(points):
        _check_point(p, f"{path}.points[{i}]", inner, problems)
    for i, g in enumerate(groups):
        where = f"{path}.groups[{i}]"
        if not isinstance(g, dict):
            problems.append(f"{where}: a group must be an object")
            continue
        count = g.get("count")
        if isinstance(count, str) and inner[0].get(count) not in ("count", "uint16"):
            problems.append(f"{where}: count '{count}' is no count or uint16 point of the model's top-level group")
        elif count is not None and not isinstance(count, str) and (not isinstance(count, int) or count < 0):
            problems.append(f"{where}: 'count' must be a point name or a non-negative integer")
        _check_group(g, where, inner, problems)


def _check_point(p: object, where: str, scopes: list[dict[str, object]], problems: list[str]) -> None:
    if not isinstance(p, dict) or not isinstance(p.get("name"), str) or not p["name"]:
        problems.append(f"{where}: a point must be an object with a 'name'")
        return
    kind = p.get("type")
    if kind not in TYPE_REGISTERS:
        problems.append(f"{where} ({p['name']}): unknown point type {kind!r}")
    elif kind == "string":
        size = p.get("size")
        if not isinstance(size, int) or isinstance(size, bool) or not 1 <= size <= 65535:
            problems.append(f"{where} ({p['name']}): a string needs a 'size' from 1 to 65535 registers")
    sf = p.get("sf")
    if isinstance(sf, str) and not any(s.get(sf) == "sunssf" for s in scopes):
        problems.append(f"{where} ({p['name']}): scale factor '{sf}' is not defined as a sunssf point")
    elif sf is not None and not isinstance(sf, str) and (not isinstance(sf, int) or not -10 <= sf <= 10):
        problems.append(f"{where} ({p['name']}): 'sf' must be a point name or an integer from -10 to 10")
    symbols = p.get("symbols", [])
    if not isinstance(symbols, list) or not all(
        isinstance(s, dict) and isinstance(s.get("name"), str) and isinstance(s.get("value"), int) for s in symbols
    ):
        problems.append(f"{where} ({p['name']}): 'symbols' must be a list of objects with a name and an integer value")
    elif symbols and kind in SYMBOL_RANGE:
        low, high, what = SYMBOL_RANGE[kind]
        for s in symbols:
            if isinstance(s["value"], bool) or not low <= s["value"] <= high:
                value = str(s["value"])
                value = value if len(value) <= 12 else f"{value[:12]}... ({len(value)} digits)"
                problems.append(
                    f"{where} ({p['name']}): symbol {s['name']!r} = {value} is outside {low}..{high}, "
                    f"the {what} of {kind}"
                )
                break
