"""Hostile text through the esphome and thingsboard exports (issue 27, SPEC 11): each export read back with its
format's parser must have the structure meant, every function once, and every text back exactly, or
changed with a warning naming the function (ESPHome expands `$` and `<%` and refuses `/` in names).
Shared by tests/test_hostile_exports.py and tests/fuzz/test_fuzz_exports.py."""

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
