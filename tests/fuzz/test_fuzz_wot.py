"""Fuzzing the Thing Description reader (`mdl import --from wot`, issue 38): any JSON, and TDs mdl wrote with their
properties' terms replaced by random JSON, is read into a device (which then resolves, exports to a TD again and
writes as MDL) or refused with an MdlError whose every message names the file; never another exception, and never
MDL that would not validate (check_written's "internal error").

A longer run by hand: MDL_FUZZ_WOT=2000 python -m pytest tests/fuzz/test_fuzz_wot.py --exhaustive"""

from __future__ import annotations

import json
import os
import tempfile
from functools import cache
from pathlib import Path

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mdl.diagnostics import MdlError
from mdl.exchange.export import Settings
from mdl.exports.wot import export_wot
from mdl.formats.mdl import device_to_xml
from mdl.formats.mdl.load import check_written
from mdl.formats.wot.read import read_wot
from mdl.resolver import resolve
from support.run import cli
from support.wot import ALL_TABLES, ARGS

EXAMPLES = int(os.environ.get("MDL_FUZZ_WOT", "120"))

SCALARS = (
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=12)
    | st.sampled_from(["modbus+tcp://h:502/1/0", "0xFFFF", "4-6", "Coil", "HoldingRegister", "integer", "number"])
)
JSON = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)
TERMS = [
    "type",
    "unit",
    "minimum",
    "maximum",
    "enum",
    "oneOf",
    "readOnly",
    "writeOnly",
    "description",
    "title",
    "ex:bitOffset",
    "ex:bitLength",
    "mdl:multiplier",
    "mdl:offset",
    "mdl:bits",
    "mdl:scaleExponent",
    "mdl:scaleBy",
    "mdl:notImplemented",
    "forms",
]
FORM_TERMS = [
    "href",
    "contentType",
    "modv:entity",
    "modv:function",
    "modv:address",
    "modv:quantity",
    "modv:unitID",
    "modv:mostSignificantByte",
    "modv:mostSignificantWord",
    "modv:zeroBasedAddressing",
]
CONTENT = st.sampled_from(["application/octet-stream", "application/json", ""]).flatmap(
    lambda media: st.lists(
        st.sampled_from(
            [
                "length=2",
                "length=4",
                "length=x",
                "signed=false",
                "signed=maybe",
                "byteSeq=LITTLE_ENDIAN",
                "byteSeq=BIG_ENDIAN_BYTE_SWAP",
                "byteSeq=WRONG",
                "=",
                ";",
            ]
        ),
        max_size=4,
    ).map(lambda params: ";".join([media, *params]))
)
HREFS = st.sampled_from(
    [
        "modbus+tcp://h:502/1/0",
        "modbus+tcp://h:x/1/0",
        "modbus+tcp://[::1/1/2",
        "modbus+tcp://h/1",
        "1/5?quantity=2",
        "modbus+tcp://h:502/1/65535?quantity=200",
        "http://h/",
        "modbus+tcp://h:502//?quantity=0",
        "modbus+tcp://h:502/a/b",
    ]
)


@cache
def exported() -> dict:
    proc = cli("export", ALL_TABLES, "--to", "wot", *ARGS)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def check(data: bytes) -> None:
    """The reader's contract on one file: a device that goes on through every stage, or a clean refusal."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "thing.td.json"
        path.write_bytes(data)
        try:
            device = read_wot(path)
            resolved = resolve(device, str(path))
        except MdlError as exc:
            event("refused")
            assert exc.diagnostics and all(d.file == str(path) for d in exc.diagnostics if d.file), exc
            return
        event("read")
        assert all(d.file == str(path) for d in device.notes)
        try:
            xml = check_written(device_to_xml(resolved.device), "import")
        except MdlError as exc:
            assert "internal error" not in str(exc), exc  # only text XML cannot carry is refused here
            return
        assert xml.startswith("<?xml")
        try:
            export_wot(resolved, Settings())
        except MdlError as exc:
            assert "WoT can hold none" in str(exc), exc


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(JSON)
def test_any_json_is_read_or_refused_cleanly(doc):
    check(json.dumps(doc).encode())


@settings(
    max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large]
)
@given(st.data())
def test_a_mutated_td_is_read_or_refused_cleanly(data):
    doc = json.loads(json.dumps(exported()))
    names = list(doc["properties"])
    for _ in range(data.draw(st.integers(1, 6))):
        prop = doc["properties"][data.draw(st.sampled_from(names))]
        where = data.draw(st.sampled_from(["prop", "form", "href", "content", "drop"]))
        if where == "prop":
            prop[data.draw(st.sampled_from(TERMS))] = data.draw(JSON)
        elif where == "drop":
            prop.pop(data.draw(st.sampled_from(TERMS)), None)
        elif isinstance(prop.get("forms"), list) and prop["forms"] and isinstance(prop["forms"][0], dict):
            form = prop["forms"][0]
            if where == "form":
                form[data.draw(st.sampled_from(FORM_TERMS))] = data.draw(JSON)
            elif where == "href":
                form["href"] = data.draw(HREFS)
            else:
                form["contentType"] = data.draw(CONTENT)
    if data.draw(st.booleans()):
        doc["base"] = data.draw(st.sampled_from(["modbus+tcp://h:502/", "x", 5]))
    check(json.dumps(doc).encode())


@settings(max_examples=EXAMPLES, deadline=None)
@given(st.binary(max_size=64) | st.text(max_size=64).map(str.encode))
def test_any_bytes_are_read_or_refused_cleanly(data):
    check(data)
