"""What the WoT tests share (tests/unit/exports/test_export_wot_td.py, tests/unit/formats/test_wot_import.py,
tests/fuzz/test_fuzz_wot.py, tests/engines/test_export_wot.py): the export's warnings taken apart, the mdl:
terms applied as docs/wot.md tells a consumer to, and the devices the engine test reads and writes."""

from __future__ import annotations

import json
import re
from typing import Any

from mdl.ir.build import divisor_of
from support.common import DATA, EXAMPLE, ROOT
from support.fleet_checks import fn

ARGS = ("--host", "192.0.2.10", "--port", "502", "--unit", "1", "--interval", "60")
# every description the round trip and the schema check take: the examples' MDL and the table of every table
DESCRIPTIONS = [*sorted((ROOT / "examples").glob("*/*.xml")), DATA / "all_tables.xml"]
TEMCO = EXAMPLE / "temco_tstat.xml"
ALL_TABLES = DATA / "all_tables.xml"

_WARNING = re.compile(r"^.*?: (?P<severity>warning|note): (?P<subject>functions? .*?): WoT: (?P<kind>.*)$")


def kinds(stderr: str) -> dict[str, list[str]]:
    """Each kind of loss the WoT export said -> the functions it names (details dropped), in order."""
    out: dict[str, list[str]] = {}
    for line in stderr.splitlines():
        m = _WARNING.match(line)
        if m:
            subject = re.sub(r" \([^()]*\)", "", m["subject"].split(" ", 1)[1])
            assert m["kind"] not in out, f"a kind said twice: {m['kind']}"
            out[m["kind"]] = re.findall(r"'([^']*)'", subject)
    return out


def named_in(stderr: str, fragment: str) -> list[str]:
    """The functions of the warning whose kind holds `fragment` ([] where none does)."""
    found = [names for kind, names in kinds(stderr).items() if fragment in kind]
    assert len(found) <= 1, (fragment, found)
    return found[0] if found else []


def described(prop: dict[str, Any], raw: Any, others: dict[str, Any] | None = None) -> Any:
    """A property's value as the description means it: the mdl: terms applied to what the binding read, as
    docs/wot.md says (bits, then raw x multiplier + offset, mdl dividing by d where the multiplier is 1/d;
    a 'not implemented' register value is null; a scale register's value from `others`: name -> (the
    property, what the binding read of it)), then the label `oneOf` gives it."""
    if isinstance(raw, dict):  # an error node-wot gave
        return raw
    length = int(re.search(r"length=(\d+)", prop["forms"][0]["contentType"])[1])
    if prop.get("mdl:notImplemented") and isinstance(raw, int):
        n = length // 2
        unsigned = raw & ((1 << (8 * length)) - 1)
        for token in prop["mdl:notImplemented"]:
            word = int(token, 16)
            pattern = int(f"{word:04x}" * n, 16) if len(token) <= 6 else word
            if unsigned == pattern:
                return None
    value = raw
    if "mdl:bits" in prop:
        low, _, high = prop["mdl:bits"].partition("-")
        low, high = int(low), int(high or low)
        value = ((raw & ((1 << (8 * length)) - 1)) >> low) & ((1 << (high - low + 1)) - 1)
        if low == high:
            return bool(value)
    m, o = prop.get("mdl:multiplier", 1.0), prop.get("mdl:offset", 0.0)
    factor = prop.get("mdl:scaleExponent", prop.get("mdl:scaleBy"))
    if "mdl:multiplier" in prop or "mdl:offset" in prop or factor is not None:
        d = divisor_of(m)
        value = float(value) / d if d is not None else (float(value) * m if m != 1.0 else float(value))
        if factor is not None:
            assert others is not None, "a scale register needs the other properties' values"
            f = described(*others[factor], others)
            if f is None:
                return None
            if "mdl:scaleExponent" in prop:
                p = 1.0
                for _ in range(abs(int(f))):
                    p *= 10.0
                value = value / p if int(f) < 0 else value * p
            else:
                value = value * float(f)
        value = value + o if o != 0.0 else value
    for label in prop.get("oneOf", []):
        if label["const"] == value and type(label["const"]) is type(value):
            return label["title"]
    return value


def td_of(text: str) -> dict[str, Any]:
    return json.loads(text)


# Registers that scale others (SunSpec's sf points, VOLTTRON's scale_reg), with what `mdl sim` serves
SCALED = [
    fn("w_sf", "0", "INT16", "<access>read</access>"),
    fn("w", "1", "INT16", "<access>read</access><scale_exponent>w_sf</scale_exponent>"),
    fn("up_sf", "2", "INT16", "<access>read</access>"),
    fn("up", "3", "UINT16", "<access>read</access><scale_exponent>up_sf</scale_exponent>"),
    fn("gain", "4", "UINT16", "<access>read</access>"),
    fn("a", "5", "INT16", "<multiplier>0.1</multiplier><access>read</access><scale_by>gain</scale_by>"),
]
SCALED_RAW = {"holding": {"0": 0xFFFE, "1": 1234, "2": 3, "3": 7, "4": 3, "5": 0xFFF6}}

# A device of every width and order node-wot is asked to write, with what node-wot does to each (the engine test)
WRITES = [
    fn("s16_le", "0", "INT16", "<byte_order>little</byte_order>"),
    fn("u16_le", "1", "UINT16", "<byte_order>little</byte_order>"),
    fn("u32_cdab", "2", "UINT32", "<word_order>little</word_order>"),
    fn("u32_badc", "4", "UINT32", "<byte_order>little</byte_order>"),
    fn("s32_dcba", "6", "INT32", "<byte_order>little</byte_order><word_order>little</word_order>"),
    fn("f32", "8", "FLOAT32"),
    fn("f32_cdab", "10", "FLOAT32", "<word_order>little</word_order>"),
    fn("f64_le", "12", "FLOAT64", "<byte_order>little</byte_order><word_order>little</word_order>"),
    fn("bit_reg", "16", "BIT"),
    fn("setpoint", "17", "INT16", "<multiplier>0.5</multiplier><minimum>-10</minimum><maximum>40</maximum>"),
    fn("single", "18", "UINT16", "<write_multiple>true</write_multiple>"),
    fn("text", "19", "STRING", "", "<count>2</count>"),
    fn("s32", "21", "INT32"),
    fn("u16", "23", "UINT16"),
    fn("u48", "24", "UINT16", "", "<count>3</count>"),
    fn("low", "27", "INT8", "", "<length>Lower byte</length>"),
    fn("high", "28", "UINT8", "", "<length>Upper byte</length>"),
    fn("word8", "29", "INT8"),
    fn("flag", "30", "UINT16", "<bits>3</bits>"),
    fn("u64", "31", "UINT64"),
    fn("mode", "35", "UINT16", '<values><value key="0">off</value><value key="7">on</value></values>'),
    fn("coil", "0", "BIT", "<register_type>coil</register_type>"),
]
# name -> (the value node-wot writes, whether it lands as mdl reads it: False where the export warns it does not)
WRITTEN = {
    "s16_le": (-2, True),
    "u16_le": (0x1234, True),
    "u32_cdab": (0x12345678, False),
    "u32_badc": (0x12345678, False),
    "s32_dcba": (-305419896, True),
    "f32": (3.5, True),
    "f32_cdab": (-1.25, False),
    "f64_le": (1.0e10, True),
    "bit_reg": (True, True),
    "setpoint": (43, True),  # the register value: 21.5
    "single": (0x1234, True),
    "text": ("ABCD", True),
    "s32": (-7, True),
    "u16": (65000, True),
    "u48": (0xABCDEF012345, False),
    "low": (-3, True),
    "high": (200, False),
    "word8": (-5, True),
    "flag": (8, True),  # the register value: bit 3 set (the whole register written, warned)
    "mode": (7, True),
    "coil": (True, True),
}
