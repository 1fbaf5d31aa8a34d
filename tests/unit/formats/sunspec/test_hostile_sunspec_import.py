"""`mdl import --from sunspec` of hostile model files (issue 34): a symbol whose value the point cannot
hold is refused with the point named, and whatever an import writes, `mdl validate` accepts."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from support.run import assert_clean_error, run_mdl

pytest.importorskip("sunspec2")


def _model(kind: str, value: int) -> dict:
    point = {"name": "St", "type": kind, "symbols": [{"name": "OFF", "value": value}, {"name": "ON", "value": 1}]}
    top = [{"name": "ID", "type": "uint16", "value": 64001}, {"name": "L", "type": "uint16"}, point]
    return {"id": 64001, "group": {"name": "hostile", "type": "group", "points": top}}


@pytest.mark.parametrize(
    ("kind", "value", "shown"),
    [
        ("enum16", 12345678901234567890, "123456789012... (20 digits) is outside 0..65535"),
        ("enum16", 65536, "65536 is outside 0..65535, the raw values of enum16"),
        ("enum16", -1, "-1 is outside 0..65535"),
        ("enum32", 2**32, "4294967296 is outside 0..4294967295"),
        ("bitfield16", 16, "16 is outside 0..15, the bit numbers of bitfield16"),
        ("bitfield32", 10**20, "is outside 0..31, the bit numbers of bitfield32"),
    ],
)
def test_a_symbol_the_point_cannot_hold_is_refused(tmp_path: Path, kind: str, value: int, shown: str) -> None:
    src = tmp_path / "model.json"
    src.write_text(json.dumps(_model(kind, value)))
    out = tmp_path / "out.xml"
    proc = run_mdl("import", "--from", "sunspec", src, "-o", out)
    assert_clean_error(
        proc, 1, f"{src}: error: not a SunSpec model definition: group.points[2] (St): symbol 'OFF'", shown
    )
    assert not out.exists()


@pytest.mark.parametrize("kind", ["enum16", "enum32", "bitfield16", "bitfield32"])
def test_the_largest_symbol_a_point_holds_imports_and_validates(tmp_path: Path, kind: str) -> None:
    largest = {"enum16": 0xFFFE, "enum32": 0xFFFFFFFE, "bitfield16": 15, "bitfield32": 31}[kind]
    src = tmp_path / "model.json"
    src.write_text(json.dumps(_model(kind, largest)))
    out = tmp_path / "out.xml"
    assert run_mdl("import", "--from", "sunspec", src, "-o", out).returncode == 0
    proc = run_mdl("validate", out)
    assert proc.returncode == 0, proc.stderr
