"""Fuzzing `mdl import --from sunspec` of model JSON files: any JSON, and model-shaped JSON with random
points, groups, counts and scale factors, is a clean MdlError or a chain that resolves and validates,
every register of it one function's, its L matching its points.

A longer run by hand: MDL_FUZZ_SUNSPEC=2000 python -m pytest tests/fuzz/test_sunspec_fuzz.py --exhaustive
"""

from __future__ import annotations

import json
import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.diagnostics import MdlError
from mdl.formats.mdl.load import read_device
from mdl.formats.sunspec.build import build_chain
from mdl.formats.sunspec.models import TYPE_REGISTERS, parse_model
from mdl.resolver import resolve
from support.run import run_mdl

pytest.importorskip("sunspec2")

EXAMPLES = int(os.environ.get("MDL_FUZZ_SUNSPEC", "150"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
NAMES = st.text("ABCWxyz_1", min_size=1, max_size=4)
JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**40), 2**40) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(["id", "group", "name", "type",
        "points", "groups", "count", "sf", "size", "symbols", "value", "access"]), inner, max_size=5),
    max_leaves=25,
)  # fmt: skip


def _point(draw, names: list[str], factors: list[str]) -> dict:
    kind = draw(st.sampled_from(sorted(TYPE_REGISTERS)))
    point: dict = {"name": draw(NAMES.filter(lambda n: n not in names and n not in ("ID", "L"))), "type": kind}
    if kind == "string":
        point["size"] = draw(st.integers(1, 300))
    if factors and kind != "sunssf" and draw(st.booleans()):
        point["sf"] = draw(st.sampled_from(factors))
    elif draw(st.integers(0, 5)) == 0:
        point["sf"] = draw(st.integers(-3, 3))
    if draw(st.booleans()):
        point["access"] = "RW"
    if kind.startswith(("enum", "bitfield")):
        values = st.integers(0, 15) | st.integers(-(2**70), 2**70)  # a bit's number, a raw value, or neither
        point["symbols"] = [{"name": f"S{i}", "value": v} for i, v in enumerate(draw(st.sets(values, max_size=3)))]
    return point


@st.composite
def models(draw) -> dict:
    mid = draw(st.integers(2, 65000))
    top: list[dict] = [{"name": "ID", "type": "uint16", "value": mid}, {"name": "L", "type": "uint16"}]
    factors = [p["name"] for p in top if p["type"] == "sunssf"]
    for _ in range(draw(st.integers(0, 5))):
        top.append(_point(draw, [p["name"] for p in top], factors))
        factors = [p["name"] for p in top if p["type"] == "sunssf"]
    groups = []
    for g in range(draw(st.integers(0, 2))):
        points: list[dict] = []
        for _ in range(draw(st.integers(1, 3))):
            points.append(_point(draw, [p["name"] for p in points], factors))
        group = {"name": f"g{g}", "type": "group", "points": points}
        counts = [p["name"] for p in top if p["type"] in ("count", "uint16") and p["name"] not in ("ID", "L")]
        choice = draw(st.sampled_from(["fixed", "legacy", *(["named"] if counts else [])]))
        if choice == "legacy":
            group["count"] = 0
        elif choice == "named":
            group["count"] = draw(st.sampled_from(counts))
        groups.append(group)
    return {"id": mid, "group": {"name": "m", "type": "group", "points": top, "groups": groups}}


@SETTINGS
@given(JSON)
def test_any_json_is_a_model_or_a_clean_error(value):
    try:
        model = parse_model(json.dumps(value).encode(), "fuzz.json")
    except MdlError as exc:
        assert all(d.file == "fuzz.json" for d in exc.diagnostics)
        return
    try:
        resolve(build_chain([(model, 1)]))
    except MdlError:
        pass


@SETTINGS
@given(models(), st.integers(0, 3), st.sampled_from([0, 40000, 50000]))
def test_model_shaped_json_builds_a_whole_chain(model, repeat, base):
    try:
        checked = parse_model(json.dumps(model).encode(), "fuzz.json")
    except MdlError as exc:  # pysunspec2's own validator may refuse what the strategy makes; cleanly
        assert exc.diagnostics and all("not a SunSpec model" in d.message for d in exc.diagnostics)
        return
    try:
        device = build_chain([(checked, repeat)], base)
    except MdlError as exc:
        assert "does not fit the address space" in str(exc)
        return
    resolved = resolve(device)
    fns = {fn.name: fn for fn in device.functions}
    layouts = [f.layout for f in resolved.functions]
    used = sorted(a for lay in layouts for a in lay.addresses)
    assert used == list(range(base, base + len(used)))  # every register once, no gap
    length = fns[f"{model['id']}_L"].initial
    assert length == [len(used) - 6]  # all but SunS (2), ID, L and the end marker (2)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(models())
def test_model_files_import_through_the_cli(tmp_path, model):
    src = tmp_path / "model.json"
    src.write_text(json.dumps(model))
    out = tmp_path / "out.xml"
    out.unlink(missing_ok=True)
    proc = run_mdl("import", "--from", "sunspec", src, "-o", out)
    assert "Traceback" not in proc.stderr
    if proc.returncode == 0:  # an import never writes MDL that `mdl validate` refuses
        assert read_device(out).functions[0].name == "SunS"
        assert run_mdl("validate", out).returncode == 0
    else:
        assert proc.returncode == 1 and "error:" in proc.stderr and not out.exists()
