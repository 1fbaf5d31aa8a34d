"""Hostile text through the esphome and thingsboard exports (issue 27, SPEC 11): each export read back with its
format's parser must have the structure meant, every function once, and every text back exactly, or
changed with a warning naming the function (ESPHome expands `$` and `<%` and refuses `/` in names).
Shared by tests/unit/exports/test_hostile_exports.py and tests/fuzz/test_fuzz_exports.py."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from mdl.diagnostics import one_line
from mdl.exports.esphome_names import display_name, object_id
from mdl.formats.loading import load_resolved

ESPHOME_KEYS = {"esphome", "esp32", "uart", "modbus", "modbus_controller"}
ESPHOME_PLATFORMS = ("sensor", "binary_sensor", "text_sensor", "number", "switch", "select")
RENAMED = "ESPHome: its name is written as ESPHome keeps it"


def _strings(node: Any):
    if isinstance(node, dict):
        for key, value in node.items():
            yield str(key)
            yield from _strings(value)
    elif isinstance(node, list):
        for value in node:
            yield from _strings(value)
    elif isinstance(node, str):
        yield node


def _lines(text: str) -> None:
    assert text.splitlines() == text.split("\n")[:-1] and text.endswith("\n")


def check_esphome(path: Path, text: str, warnings: str) -> None:
    resolved = load_resolved(path)
    _lines(text)
    node = yaml.safe_load(text)
    assert ESPHOME_KEYS <= set(node) <= ESPHOME_KEYS | set(ESPHOME_PLATFORMS), sorted(node)
    for string in _strings(node):  # nothing ESPHome's substitution pass would expand
        assert "$" not in string and "<%" not in string, string
    assert node["esphome"]["friendly_name"] == display_name(resolved.name)[0]
    names = []
    for platform in ESPHOME_PLATFORMS:
        ids = [object_id(entity["name"]) for entity in node.get(platform, [])]
        assert len(ids) == len(set(ids)), (platform, ids)  # ESPHome refuses two of one object id
        names += [entity["name"] for entity in node.get(platform, [])]
        for entity in node.get(platform, []):
            assert entity["platform"] == "modbus_controller"
            for label in entity.get("optionsmap", {}):
                assert label == display_name(label)[0]
    assert len(names) == len(resolved.functions)  # every function once (the hostile devices hold plain registers)
    for f in resolved.functions:
        if f.name not in names:  # changed: said, naming the function
            said = [line for line in warnings.splitlines() if RENAMED in line and f"'{one_line(f.name)}'" in line]
            assert said, (f.name, warnings)


def check_thingsboard(path: Path, text: str) -> None:
    resolved = load_resolved(path)
    _lines(text)
    doc = json.loads(text)
    assert list(doc) == ["master"] and list(doc["master"]) == ["slaves"]
    slaves = doc["master"]["slaves"]
    assert slaves and all(slave["deviceName"] == resolved.name for slave in slaves)
    keys = [point["tag"] for slave in slaves for kind in ("timeseries", "attributes") for point in slave[kind]]
    assert sorted(keys) == sorted(f.name for f in resolved.functions)  # every tag back exactly
    for slave in slaves:
        for point in slave["timeseries"] + slave["attributes"]:
            labels = resolved.by_name[point["tag"]].fn.values or {}
            assert point.get("variants", {}) == {str(k): v for k, v in labels.items()}


def fn(name: str, address: str, fmt: str, extra: str = "", length: str = "") -> str:
    return (
        f"<function><name>{name}</name><description>{name}</description><addresses>{address}</addresses>"
        f"{length}<format>{fmt}</format>{extra}</function>"
    )


LITTLE = "<word_order>little</word_order>"


LOWER = "<length>Lower byte</length>"


# every value type and bitmask the export writes, with the registers `mdl sim` serves for them
WIDE = [
    fn("u16", "0", "UINT16"),
    fn("s16", "1", "INT16", "<multiplier>0.01</multiplier><units>A</units>"),
    fn("u32", "2", "UINT32"),
    fn("s32r", "4", "INT32", LITTLE),
    fn("u64", "6", "UINT64"),
    fn("s64r", "10", "INT64", LITTLE),
    fn("f32r", "14", "FLOAT32", "<units>Hz</units>" + LITTLE),
    fn("bit_reg", "16", "BIT", "<access>read</access>"),
    fn("bit_switch", "17", "BIT"),
    fn("s8", "18", "INT8", "<access>read</access>", LOWER),
    fn("u8_write", "19", "UINT8", "", LOWER),
    fn("flag32", "20", "UINT32", "<bits>3</bits>"),
    fn("field32r", "22", "UINT32", LITTLE + "<bits>12-19</bits>"),
    fn("flag16", "24", "UINT16", "<bits>9</bits>"),
    fn("mode", "25", "UINT16", '<values><value key="0">off</value><value key="7">on</value></values>'),
    fn("scaled", "26", "UINT16", "<multiplier>0.1</multiplier><units>degC</units><offset>-20</offset>"),
    fn("setpoint", "27", "INT16", "<multiplier>0.5</multiplier><minimum>-10</minimum><maximum>40</maximum>"),
    fn("missing", "28", "INT16", "<access>read</access><not_implemented>0x8000 0x7FFF</not_implemented>"),
    fn(
        "present",
        "29",
        "UINT16",
        "<multiplier>0.1</multiplier><access>read</access><not_implemented>0xFFFF</not_implemented>",
    ),
    fn("flag8", "30", "UINT16", "<access>read</access><bits>8</bits>"),
    fn("in_u16", "0", "UINT16", "<register_type>input</register_type>"),
    fn("in_f32", "1", "FLOAT32", "<register_type>input</register_type>"),
]


WIDE_HOLDING = (  # addresses 0, 1, 2...
    "BEEF FF85 0102 0304 FFFE FFFF 0012 3456 789A BCDE 0001 0002 0003 F004 0FDB 4049 0001 0001 00F0 0042 "
    "A5A5 000C 1234 5678 0200 0007 020B FFF6 8000 0005 0100"
)


WIDE_RAW = {
    "holding": {str(address): int(word, 16) for address, word in enumerate(WIDE_HOLDING.split())},
    "input": {"0": 4242, "1": 0xC2F6, "2": 0xE979},
}
