"""`mdl import --from wot TD.json` (SPEC 11.1, issue 38): a Thing Description with Modbus forms back to MDL. The round
trip of every export is identical (export -> import -> export, the TD and the Thing Model alike); a TD written by
hand or by another tool (node-wot's own examples' forms) reads as node-wot reads it; what MDL cannot hold, and a
property without a Modbus form, is a warning naming the property; what is not a TD is a clean error naming the
file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mdl import formats
from mdl.diagnostics import MdlError
from mdl.formats.loading import load_resolved
from mdl.formats.wot import read as wot_read
from mdl.formats.wot.read import read_wot
from support.fleet_checks import WIDE
from support.run import assert_clean_error, cli
from support.wot import ARGS, DESCRIPTIONS, SCALED, WRITES

CONTEXT = ["https://www.w3.org/2022/wot/td/v1.1", {"modv": "https://www.w3.org/2019/wot/modbus#"}]


def export(path, *extra) -> str:
    proc = cli("export", path, "--to", "wot", *extra)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.mark.parametrize("extra", [ARGS, ("--tm",)], ids=["td", "tm"])
@pytest.mark.parametrize("path", DESCRIPTIONS, ids=lambda p: p.stem)
def test_the_round_trip_of_every_export_is_identical(tmp_path, path, extra):
    first = export(path, *extra)
    td = tmp_path / "device.td.json"
    td.write_text(first, encoding="utf-8")
    back = tmp_path / "back.xml"
    proc = cli("import", td, "-o", back)  # the format guessed from the file
    assert proc.returncode == 0, proc.stderr
    assert export(back, *extra) == first


@pytest.mark.parametrize("functions", [WIDE, SCALED, WRITES], ids=["wide", "scaled", "writes"])
def test_the_round_trip_of_every_width_order_and_term(tmp_path, write_device, functions):
    path = write_device("".join(functions))
    for extra in (ARGS, ("--tm",)):
        first = export(path, *extra)
        td = tmp_path / "device.td.json"
        td.write_text(first, encoding="utf-8")
        back = tmp_path / "back.xml"
        proc = cli("import", td, "-o", back)
        assert proc.returncode == 0, proc.stderr
        assert export(back, *extra) == first


def td_file(tmp_path: Path, properties: dict, name: str = "thing.json", **top) -> Path:
    doc = {"@context": CONTEXT, "title": "Thing", **top, "properties": properties}
    path = tmp_path / name
    path.write_text(json.dumps(doc, indent=2), encoding="utf-8")
    return path


def prop(form: dict, type_: str = "integer", **extra) -> dict:
    return {"type": type_, **extra, "forms": [form]}


def modbus(address: int, quantity: int | None = None, content: str | None = None, **terms) -> dict:
    href = f"modbus+tcp://127.0.0.1:60000/1/{address}" + (f"?quantity={quantity}" if quantity else "")
    return {"href": href, **({"contentType": content} if content else {}), **terms}


def read(path: Path):
    device = read_wot(path)
    return {fn.name: fn for fn in device.functions}, [str(d) for d in device.notes]


def test_node_wot_s_own_forms_read_as_node_wot_reads_them(tmp_path):
    """The forms of node-wot's binding README and the Modbus binding's vocabulary as other tools write it."""
    path = td_file(
        tmp_path,
        {
            "in8": prop(
                modbus(8, content="application/octet-stream;length=2", **{"modv:function": "readInputRegister"})
            ),
            "hr8": prop(modbus(8, content="application/octet-stream;length=2", **{"modv:entity": "HoldingRegister"})),
            "light": prop(modbus(0, **{"modv:entity": "Coil"}), "boolean"),
            "u32": prop(
                modbus(
                    10,
                    2,
                    "application/octet-stream;length=4;signed=false;byteSeq=LITTLE_ENDIAN",
                    **{"modv:entity": "HoldingRegister"},
                ),
                readOnly=True,
            ),
            "f32": prop(modbus(20, 2, **{"modv:entity": "InputRegister", "modv:mostSignificantWord": False}), "number"),
            "old": prop({"href": "modbus+tcp://h:502/1/30", "modbus:function": 3}, readOnly=True),
            "text": prop(
                modbus(
                    40, 3, "application/octet-stream;byteSeq=BIG_ENDIAN_BYTE_SWAP", **{"modv:entity": "HoldingRegister"}
                ),
                "string",
                writeOnly=True,
            ),
        },
    )
    fns, notes = read(path)
    assert (fns["in8"].format, fns["in8"].register_type, fns["in8"].addresses) == ("INT16", "input", [8])
    assert (fns["hr8"].format, fns["hr8"].register_type, fns["hr8"].access) == ("INT16", None, None)
    assert (fns["light"].format, fns["light"].register_type) == ("BIT", "coil")
    u32 = fns["u32"]
    assert (u32.format, u32.byte_order, u32.word_order, u32.access) == ("UINT32", "little", "little", "read")
    f32 = fns["f32"]
    assert (f32.format, f32.byte_order, f32.word_order) == ("FLOAT32", None, "little")
    assert (fns["old"].format, fns["old"].addresses) == ("INT16", [30])
    text = fns["text"]
    assert (text.format, text.count, text.byte_order, text.access) == ("STRING", 3, "little", "write")
    assert any("the forms name modbus+tcp://127.0.0.1:60000 unit 1" in note for note in notes), notes


def test_what_mdl_cannot_hold_is_a_warning_naming_the_property(tmp_path):
    holding = {"modv:entity": "HoldingRegister"}
    path = td_file(
        tmp_path,
        {
            "ok": prop(modbus(0, **holding)),
            "web": prop({"href": "http://example.com/ok", "op": "readproperty"}),
            "both": {"type": "integer", "forms": [{"href": "https://x/y"}, modbus(1, **holding)]},
            "half": prop(modbus(2, 1, **holding), "number"),
            "wide": prop(modbus(3, 5, **holding)),
            "which": prop(modbus(9)),
            "coils": prop(modbus(10, 2, **{"modv:entity": "Coil"}), "boolean"),
            "json": prop(modbus(11, content="application/json", **holding)),
            "thing": prop(modbus(12, **holding), "object"),
            "input": prop(modbus(13, **{"modv:entity": "InputRegister"}), readOnly=False),
            "noforms": {"type": "integer"},
            "far": prop(modbus(70000, **holding)),
            "order": prop(modbus(14, content="application/octet-stream;byteSeq=MIDDLE", **holding)),
        },
    )
    fns, notes = read(path)
    assert set(fns) == {"ok", "both", "input"}
    said = "\n".join(notes)
    for name, why in {
        "web": "no Modbus form (forms of http)",
        "half": "a 16-bit float",
        "wide": "a 80-bit integer",
        "which": "its form names no Modbus table",
        "coils": "2 coils as one value",
        "json": "content type application/json",
        "thing": "type 'object'",
        "noforms": "no forms",
        "far": "address 70000",
        "order": "byteSeq MIDDLE",
    }.items():
        assert f"property '{name}': {why}" in said and said.count(f"property '{name}'") == 1, (name, said)
    assert "property 'both': its forms other than Modbus (https) are not part of MDL" in said
    assert "property 'input': a input register cannot be written: read-only" in said
    assert f"{path}:" in said and ": warning: property" in said  # the file and the property's line


def test_the_warnings_reach_mdl_import(tmp_path):
    path = td_file(
        tmp_path, {"ok": prop(modbus(0, **{"modv:entity": "Coil"}), "boolean"), "web": prop({"href": "http://x/"})}
    )
    proc = cli("import", path, "--from", "wot")
    assert proc.returncode == 0, proc.stderr
    assert "warning: property 'web': no Modbus form" in proc.stderr and "<name>ok</name>" in proc.stdout
    proc = cli("import", path, "--from", "wot", "--fail-on-warning")
    assert proc.returncode == 1


def test_the_mdl_terms_and_limits_come_back(tmp_path):
    holding = {"modv:entity": "HoldingRegister"}
    path = td_file(
        tmp_path,
        {
            "sp": prop(modbus(0, **holding), minimum=50, maximum=350, **{"mdl:multiplier": 0.1}),
            "neg": prop(modbus(1, **holding), minimum=-8, maximum=20, **{"mdl:multiplier": -0.5}),
            "t": prop(modbus(2, **holding), **{"mdl:multiplier": 0.5, "mdl:offset": -40}),
            "f": prop(modbus(3, **holding), minimum=1, **{"mdl:bits": "4-6"}),
            "ni": prop(modbus(4, **holding), **{"mdl:notImplemented": ["0x8000", "0x7FFF"]}),
            "e": prop(modbus(5, **holding), readOnly=True),
            "w": prop(modbus(6, **holding), **{"mdl:scaleExponent": "e"}),
            "mode": prop(
                modbus(7, **holding), enum=[0, 7], oneOf=[{"const": 0, "title": "off"}, {"const": 7, "title": "on"}]
            ),
            "bare": prop(modbus(8, **holding), enum=[1, 2]),
            "on": prop(
                modbus(9, **{"modv:entity": "Coil"}),
                "boolean",
                oneOf=[{"const": False, "title": "no"}, {"const": True, "title": "yes"}],
            ),
            "lo": prop(
                modbus(10, content="application/octet-stream;length=2;signed=true", **holding),
                **{"ex:bitOffset": 8, "ex:bitLength": 8},
            ),
            "hi": prop(
                modbus(
                    11, content="application/octet-stream;length=2;signed=false;byteSeq=BIG_ENDIAN_BYTE_SWAP", **holding
                ),
                **{"ex:bitOffset": 8, "ex:bitLength": 8},
            ),
            "zero": prop(modbus(12, **holding, **{"modv:zeroBasedAddressing": False})),
        },
    )
    fns, notes = read(path)
    assert (fns["sp"].multiplier, fns["sp"].minimum, fns["sp"].maximum) == (0.1, 5.0, 35.0)  # 50 / 10: mdl's rule
    assert (fns["neg"].minimum, fns["neg"].maximum) == (-10.0, 4.0)
    assert (fns["t"].multiplier, fns["t"].offset) == (0.5, -40.0)
    assert fns["f"].bits == "4-6" and fns["f"].minimum is None
    assert any("property 'f': minimum and maximum of its register value are not part of MDL" in n for n in notes)
    assert fns["ni"].not_implemented == ["0x8000", "0x7FFF"]
    assert fns["w"].scale_exponent == "e"
    assert fns["mode"].values == {0: "off", 7: "on"} and fns["bare"].values == {1: "1", 2: "2"}
    assert fns["on"].values == {0: "no", 1: "yes"}
    assert (fns["lo"].length, fns["lo"].format) == ("Lower byte", "INT8")
    assert (fns["hi"].length, fns["hi"].format) == ("Upper byte", "UINT8")  # swapped first: the first byte
    assert fns["zero"].addresses == [11]
    load_resolved(path)  # and it resolves: the scale register is a property of the TD


def test_a_relative_href_takes_the_base(tmp_path):
    path = td_file(
        tmp_path,
        {"x": prop({"href": "1/40?quantity=2", "modv:entity": "InputRegister"}, "number")},
        base="modbus+tcp://192.0.2.1:502/",
    )
    fns, _ = read(path)
    assert (fns["x"].addresses, fns["x"].format, fns["x"].register_type) == ([40], "FLOAT32", "input")


def test_the_format_is_guessed_from_a_td(tmp_path):
    td = td_file(tmp_path, {"x": prop(modbus(0, **{"modv:entity": "Coil"}), "boolean")})
    assert formats.guess_format(td) == "wot"
    other = tmp_path / "other.jsonld"
    other.write_text("{}")
    assert formats.guess_format(other) == "wot"  # the name decides: the reader then says what is wrong
    raw = tmp_path / "raw.json"
    raw.write_text(json.dumps({"holding": {"0": 1}}))
    assert formats.guess_format(raw) is None
    assert_clean_error(cli("import", other), 1, "not a Thing Description with properties")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{", "not JSON: Expecting property name"),
        ("[1, 2]", "the document is not a JSON object"),
        ('{"title": "x"}', "no 'properties' object"),
        ('{"properties": {"a": NaN}}', "NaN is not JSON"),
        ('{"properties": {"a": ' + "[" * 100_000 + "]" * 100_000 + "}}", "nested too deeply"),
        ('{"properties": {"a": ' + "9" * 5000 + "}}", "not JSON mdl reads"),
        ('{"properties": {"a": {"forms": [{"href": "http://x"}]}}}', "no property has a Modbus form MDL can hold"),
        (
            '{"properties": {"a\\u0000": {"forms": [{"href": "modbus+tcp://h:1/1/0", "modv:entity": "Coil"}]}}}',
            "holds the character U+0000",
        ),
        (b"\xff\xfe{}", "cannot decode byte 0xff as utf-8"),
    ],
)
def test_what_is_not_a_td_is_a_clean_error(tmp_path, text, message):
    path = tmp_path / "bad.json"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    with pytest.raises(MdlError) as caught:
        read_wot(path)
    said = str(caught.value)
    assert str(path) in said and message in said, said
    assert_clean_error(cli("import", path, "--from", "wot"), 1, message)


def test_a_td_is_read_up_to_its_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(wot_read, "MAX_BYTES", 100)
    path = td_file(tmp_path, {f"p{i}": prop(modbus(i, **{"modv:entity": "Coil"}), "boolean") for i in range(10)})
    with pytest.raises(MdlError, match="larger than 100 bytes"):
        read_wot(path)
