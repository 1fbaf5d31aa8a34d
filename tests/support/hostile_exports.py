"""Hostile text for every export (issue 27), and each export read back with the format's own parser: the shared
part of tests/unit/exports/test_hostile_exports.py, tests/fuzz/test_fuzz_exports.py and
tests/engines/test_export_esphome.py."""

from __future__ import annotations

import configparser
import csv
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml

from mdl.device.output import capability
from mdl.exports.ha_units import ha_unit
from mdl.formats.loading import load_resolved
from mdl.formats.wise.read import read_wise
from support.common import MDL_NS
from support.fleet_checks import check_esphome, check_thingsboard
from support.run import cli

tomllib = pytest.importorskip("tomllib" if __import__("sys").version_info >= (3, 11) else "tomli")


# texts that end a comment, a string, a line or a cell early in one format or another
HOSTILE = [
    "a\nb",
    "a\rb",
    "a\r\nb",
    "a\x85b",
    "a\u2028b",
    "a\u2029b",
    'say "hi"',
    "back\\slash",
    "end ]]",
    "[[outputs.exec]]",
    "# hash",
    "=x",
    "k = v",
    "a;b",
    "x,y",
    "tab\there",
    "del\x7f",
    "csi\x9b",
    "'quoted'",
    "!secret pw",
    "{{ states('x') }}",
    "bom\ufeff",
    "rlo\u202e",
    "\\u0041",
    "%(x)s",
    "---",
    "... end",
    "[Platform]",
    "- item",
    "&amp;",
]


# a device name that, written raw into a header comment, would add a Telegraf output and a Home Assistant
# shell command, a WISE section and an INI key
INJECTING_NAME = (
    'Evil\n[[outputs.exec]]\n  commands = ["touch /tmp/pwned"]\nshell_command:\n  pwn: touch /tmp/pwned'
    "\r[Coils]\u2028numberOfB=1\u2029B0=0,x\x85# done"
)


FORMULA = ("=", "+", "-", "@", "\t", "\r")


def xml_text(text: str) -> str:
    """`text` as MDL XML writes it: ASCII, everything else (and markup, controls) as character references."""
    return "".join(ch if ch.isascii() and ch.isprintable() and ch not in "&<>" else f"&#x{ord(ch):X};" for ch in text)


@dataclass
class Fn:
    name: str
    description: str = "plain"
    units: str | None = None
    values: dict[int, str] = field(default_factory=dict)


def write_device(path: Path, name: str, functions: list[Fn]) -> Path:
    """A 1.0 description: each function one holding UINT16 register, at addresses 0, 1, 2..."""
    body = ""
    for address, fn in enumerate(functions):
        body += (
            f"  <function>\n    <name>{xml_text(fn.name)}</name>\n"
            f"    <description>{xml_text(fn.description)}</description>\n"
            f"    <addresses>{address}</addresses>\n    <format>UINT16</format>\n"
        )
        if fn.units is not None:
            body += f"    <units>{xml_text(fn.units)}</units>\n"
        if fn.values:
            inner = "".join(f'<value key="{k}">{xml_text(v)}</value>' for k, v in fn.values.items())
            body += f"    <values>{inner}</values>\n"
        body += "  </function>\n"
    path.write_text(
        f'<?xml version="1.0" encoding="US-ASCII"?>\n<device xmlns="{MDL_NS}" version="1.0">\n'
        f"  <name>{xml_text(name)}</name>\n  <description>hostile</description>\n{body}</device>\n",
        encoding="ascii",
    )
    return path


def export(path: Path, fmt: str, *extra: object):
    proc = cli("export", path, "--to", fmt, "--host", "192.0.2.1", *extra)
    assert "Traceback" not in proc.stderr
    return proc


def only_newlines(text: str) -> None:
    """The text breaks lines at its own \\n only: no \\r, NEL, U+2028... that a reader could take as one."""
    assert text.splitlines() == text.split("\n")[:-1] and text.endswith("\n"), [
        line for line in text.split("\n") if len(line.splitlines()) > 1
    ]


def check_telegraf(path: Path, text: str) -> None:
    resolved = load_resolved(path)
    only_newlines(text)
    doc = tomllib.loads(text)
    assert set(doc) <= {"inputs", "processors"} and list(doc["inputs"]) == ["modbus"], sorted(doc)
    (plugin,) = doc["inputs"]["modbus"]
    assert plugin["name"] == resolved.name
    assert set(doc.get("processors", {})) <= {"enum"}
    labels = {
        (m["field"], k): v
        for p in doc.get("processors", {}).get("enum", [])
        for m in p["mapping"]
        for k, v in m["value_mappings"].items()
    }
    assert labels == {(f.ident, str(k)): v for f in resolved.functions for k, v in (f.fn.values or {}).items()}
    fields = [fld["name"] for req in plugin["request"] for fld in req["fields"] if "name" in fld]
    assert sorted(fields) == sorted(f.ident for f in resolved.functions)


def check_homeassistant(path: Path, text: str) -> None:
    resolved = load_resolved(path)
    only_newlines(text)
    doc = yaml.safe_load(text)
    assert isinstance(doc, list) and len(doc) == 1  # the list of hubs that `modbus: !include` reads
    hub = doc[0]
    assert set(hub) == {"name", "type", "host", "port", "timeout", "sensors"}, sorted(hub)
    assert [(s["name"], s.get("unit_of_measurement")) for s in hub["sensors"]] == [
        (f.name, ha_unit(f.fn.units).unit if f.fn.units else None) for f in resolved.functions
    ]


def spreadsheet(text: str) -> str:
    return "'" + text if text.startswith(FORMULA) else text


def check_volttron(path: Path, folder: Path, warnings: str) -> None:
    resolved = load_resolved(path)
    stem = resolved.stem
    assert sorted(p.name for p in folder.iterdir()) == sorted([f"{stem}.config", f"{stem}.csv", f"{stem}_map.csv"])
    config = json.loads((folder / f"{stem}.config").read_text(encoding="utf-8"))
    only_newlines((folder / f"{stem}.config").read_text(encoding="utf-8"))
    assert config["driver_config"]["name"] == resolved.name
    with open(folder / f"{stem}_map.csv", newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    with open(folder / f"{stem}.csv", newline="", encoding="utf-8") as handle:
        registry = list(csv.reader(handle))
    assert rows[0][0] == "Register Name" and all(len(row) == 10 for row in rows), rows
    assert registry[0] == ["Volttron Point Name", "Register Name"] and all(len(row) == 2 for row in registry)
    fns = resolved.functions
    assert [row[0] for row in rows[1:]] == [f.ident for f in fns]
    assert [row[3] for row in rows[1:]] == [spreadsheet(f.fn.units or "") for f in fns]
    assert [row[9] for row in rows[1:]] == [spreadsheet(" ".join(f.fn.description.split())) for f in fns]
    assert registry[1:] == [[spreadsheet(f.name), f.ident] for f in fns]
    for f in fns:  # every cell changed is said, naming the function
        for column, text in (
            ("Units", f.fn.units or ""),
            ("Description", " ".join(f.fn.description.split())),
            ("Volttron Point Name", f.name),
        ):
            if text.startswith(FORMULA):
                said = f"VOLTTRON: its {column} cell starts with {text[0]!r}"
                assert any(
                    _quoted(f.name) in line.split(": VOLTTRON: ")[0] and said in line for line in warnings.splitlines()
                ), (f.name, said, warnings)
    for row in rows[1:] + registry[1:]:
        assert not any(cell.startswith(FORMULA) for cell in row), row


def _quoted(name: str) -> str:
    from mdl.diagnostics import one_line

    return f"'{one_line(name)}'"


def check_senml(path: Path, text: str) -> None:
    resolved = load_resolved(path)
    only_newlines(text)
    assert json.loads(text) == capability([f.fn for f in resolved.functions], resolved.name)


WISE_BREAKS = re.compile(r'[,"\x00-\x1f\x7f-\x9f\u2028\u2029]')


def check_wise(path: Path, out: Path, warnings: str) -> None:
    resolved = load_resolved(path)
    text = out.read_text(encoding="utf-8")
    only_newlines(text)
    parser = configparser.RawConfigParser(strict=True, delimiters=("=",), comment_prefixes=("#", ";"))
    parser.optionxform = str  # type: ignore[assignment,method-assign]
    parser.read_string(text)
    assert parser.sections() == ["Platform", "Holding Registers"], parser.sections()
    assert set(parser["Holding Registers"]) == {"numberOfR", *(f"R{i}" for i in range(len(resolved.functions)))}
    device = read_wise(out)
    assert device.notes is not None and not [d for d in device.notes if d.severity == "warning"], device.notes
    want_name = re.sub(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]", " ", resolved.name).strip()
    assert (device.name if want_name else "") == want_name
    if want_name != resolved.name:
        assert f"the device name is written as {want_name!r}" in warnings, warnings
    got = [fn.name for fn in device.functions]
    assert len(got) == len(resolved.functions)
    for f, name in zip(resolved.functions, got, strict=True):
        if name != f.name:  # only the characters a line cannot hold are changed, and that is said
            assert name == (WISE_BREAKS.sub("_", f.name).strip() or "unnamed") or re.fullmatch(r".*_[0-9]+", name), (
                f.name,
                name,
            )
            assert f"{_quoted(f.name)} (as {_quoted(name)})" in warnings, (f.name, name, warnings)
    for key, row in parser["Holding Registers"].items():
        if key != "numberOfR":
            assert row.count(",") == 6, row  # offset,name,min,max,precision,unit,datatype: no column shifted


def run_all(path: Path, tmp: Path) -> None:
    """Every text export of `path`, each read back by its format's parser and checked."""
    texts = (("telegraf", check_telegraf), ("homeassistant", check_homeassistant), ("senml", check_senml))
    for fmt, check in (*texts, ("thingsboard", check_thingsboard)):
        proc = export(path, fmt)
        assert proc.returncode == 0, (fmt, proc.stderr)
        check(path, proc.stdout)
    proc = export(path, "esphome")
    assert proc.returncode == 0, proc.stderr
    check_esphome(path, proc.stdout, proc.stderr)
    folder = tmp / "volttron"
    proc = export(path, "volttron", "-o", folder, "--force")
    assert proc.returncode == 0, proc.stderr
    check_volttron(path, folder, proc.stderr)
    out = tmp / "Modbus.ini"
    proc = export(path, "wise", "-o", out)
    assert proc.returncode == 0, proc.stderr
    check_wise(path, out, proc.stderr)
