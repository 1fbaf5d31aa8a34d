"""SPEC 12's proof: pysunspec2's own client scans `mdl sim` of every model it ships, reads every point
equal to `mdl read`, and its writes (scaled set points included) land as `mdl read` then reads them.

One `mdl sim` serves all of them, each chain (1 + that model) at a unit of its own, plus the inverter chain
1+103+120+121+122+123+160 (--repeat 2). Non-trivial raw values (negative numbers, scale factors from -3 to
+2, enumeration keys, filled strings) go in with --registers, written here with struct, not with mdl's
codec, so the two sides share nothing but the register image.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from support.run import run_mdl
from support.sunspec import (
    COMPARED,
    _text,
    differences,
    function_names,
    mdl_value,
    raw_image,
    same,
)

sunspec_client = pytest.importorskip("sunspec2.modbus.client")
from mdl.formats.sunspec.models import shipped_ids  # noqa: E402

INVERTER = ["103", "120", "121", "122", "123", "160"]


def _new_value(point, name: str, k: int):
    """A value to write to the writable point (the scaled value for a scaled one) and what mdl read
    should then say."""
    kind, symbols = point.pdef["type"], point.pdef.get("symbols", [])
    if kind == "string":
        text = _text("w" + name, min(2 * point.len - 1, 40))
        return text, text
    if kind.startswith("enum") and symbols:
        s = symbols[(k + 1) % len(symbols)]
        return s["value"], s["name"]
    if kind == "sunssf":
        return -1, -1
    if kind in ("float32", "float64"):
        return 3.25 + k, 3.25 + k
    if kind == "eui48":
        return "01:02:03:04:05:06", "01:02:03:04:05:06"
    if kind == "ipv6addr":
        v = "20010DB8:00000000:00000000:00000001"
        return v, v
    raw = -(5 + k % 50) if kind.startswith("int") else 7 + k % 50
    sf = _exponent(point)
    if sf is None:
        return raw, raw
    return raw * 10.0**sf, raw * 10.0**sf


def _exponent(point) -> int | None:
    """The point's scale factor as the device now holds it (None: not scaled)."""
    if not point.sf_required:
        return None
    if point.sf is None:
        return point.sf_value
    factor = point.group.points.get(point.sf) or point.model.points.get(point.sf)
    return factor.value


def write_all(device) -> dict[str, object]:
    """Write every writable point through pysunspec2 (scale factors first, so that the scaled points
    after them use the exponents the device then holds); the value each function should read back."""
    expected: dict[str, object] = {}
    counts = set()
    for mid, models in device.models.items():
        if isinstance(mid, int):
            for model in models:
                counts |= {g["count"] for g in _groups(model.gdef) if isinstance(g.get("count"), str)}
    points = [
        (name, p)
        for mid, models in device.models.items()
        if isinstance(mid, int)
        for model in models
        for name, p in function_names(model).items()
        if p.pdef.get("access") == "RW" and p.pdef["name"] not in counts
    ]
    points.sort(key=lambda item: item[1].pdef["type"] != "sunssf")
    for k, (name, point) in enumerate(points):
        value, shown = _new_value(point, name, k)
        if point.sf_required and point.pdef["type"] != "sunssf":
            point.cvalue = value
        else:
            point.value = value
        # pysunspec2 makes the points of a repeating group plain Points, without write(): their group writes them
        point.write() if hasattr(point, "write") else point.group.write()
        expected[name] = shown
    COMPARED["written"] += len(expected)
    return expected


def _groups(gdef: dict) -> list[dict]:
    out = []
    for g in gdef.get("groups", []):
        out += [g, *_groups(g)]
    return out


def mdl_read(xml: Path, sim, unit: int) -> dict:
    proc = run_mdl("read", xml, *sim.connection, "--unit", unit, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_every_shipped_model_scans_reads_and_writes_through_pysunspec2(tmp_path, sim_factory):
    chains = [[str(mid)] for mid in shipped_ids()] + [INVERTER]
    files, images = [], []
    for i, models in enumerate(chains):
        xml = tmp_path / f"chain{i}.xml"
        repeat = ["--repeat", "2"] if models == INVERTER else []
        proc = run_mdl("import", "--from", "sunspec", *models, *repeat, "-o", xml)
        assert proc.returncode == 0, proc.stderr
        image = tmp_path / f"chain{i}.json"
        image.write_text(json.dumps(raw_image(xml)))
        files.append(xml)
        images += ["--registers", image]
    sim = sim_factory(files, *images)
    passed, failed = [], {}
    for unit, (xml, models) in enumerate(zip(files, chains, strict=True), start=1):
        device = sunspec_client.SunSpecModbusClientDeviceTCP(slave_id=unit, ipaddr=sim.host, ipport=sim.port)
        try:
            device.scan()
            found = [mid for mid in device.models if isinstance(mid, int)]
            ids = [int(m) for m in models]
            problems = [] if found == ([] if 1 in ids else [1]) + ids else [f"scan found {found}"]
            problems += [
                f"model {m.model_id}: {m.error_info}" for ms in device.models.values() for m in ms if m.error_info
            ]
            problems += differences(device, mdl_read(xml, sim, unit))
            expected = write_all(device)
            after = mdl_read(xml, sim, unit)
            for name, shown in expected.items():
                point = function_names_all(device)[name]
                if not same(mdl_value(point, after, name), shown):
                    problems.append(f"wrote {name} = {shown!r}, mdl read {mdl_value(point, after, name)!r}")
            for ms in device.models.values():
                for m in ms:
                    m.read()
            problems += differences(device, after)
        finally:
            device.close()
        if problems:
            failed["+".join(models)] = problems[:5]
        else:
            passed.append("+".join(models))
    print(
        f"SunSpec through pysunspec2: {len(passed)} of {len(chains)} chains with 0 differences "
        f"({COMPARED['points']} point readings compared, {COMPARED['written']} points written)"
    )
    assert not failed, failed
    assert len(passed) == len(shipped_ids()) + 1


def function_names_all(device) -> dict[str, object]:
    out: dict[str, object] = {}
    for mid, models in device.models.items():
        if isinstance(mid, int):
            for model in models:
                out.update(function_names(model))
    return out
