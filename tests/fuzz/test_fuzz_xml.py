"""Fuzzing MDL XML: mutations of tests/data/all_tables.xml (element texts, attributes, elements removed,
repeated or added, raw bytes cut or inserted). `mdl validate` says valid, or gives errors that name the
file and line, never a traceback; a document that validates loads, plans its reads (SPEC section 8)
and writes back to MDL that validates again."""

from __future__ import annotations

import copy
import re
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from lxml import etree

from mdl.diagnostics import Diagnostic
from mdl.formats.mdl import device_to_xml, load_device, validate_file
from mdl.plan import plan_reads, split_request
from mdl.resolver import resolve
from support.common import DATA, MDL_NS
from support.run import assert_clean_error, run_mdl

BASE = (DATA / "all_tables.xml").read_bytes()
# a function's elements in schema order
FUNCTION_TAGS = [
    "name",
    "description",
    "addresses",
    "length",
    "count",
    "format",
    "block_label",
    "multiplier",
    "units",
    "read_function_code",
    "write_function_code",
    "register_type",
    "byte_order",
    "word_order",
    "offset",
    "access",
    "minimum",
    "maximum",
    "not_implemented",
    "values",
    "expression",
    "immutable",
    "system",
    "fetch_group",
]
NUMBERS = [
    "0",
    "1",
    "-1",
    "0.1",
    "INF",
    "-INF",
    "NaN",
    "1e38",
    "1e39",
    "1e308",
    "1e309",
    "-0",
    "4.9e-324",
    "",
    "x",
    "1,5",
    " 2 ",
]
BIG = ["99999999999", "9" * 5000, "0" * 5000 + "1", "+3", "\u0663"]
TEXTS: dict[str, list[str]] = {
    "name": ["x", "", "a b", "1abc", "pump", "setpoint", "\u00e9t\u00e9", "x" * 300, "class", "_"],
    "description": ["", "text", "x" * 1000],
    "addresses": [
        "0",
        "65535",
        "65536",
        "0 1",
        "1 0",
        "5 5",
        "100 102",
        "-1",
        "",
        " ",
        "0x10",
        "1.5",
        "0 " * 200,
        *BIG,
    ],
    "count": ["1", "0", "-1", "2", "4", "125", "126", "2000", "", *BIG],
    "format": [
        "INT8",
        "UINT8",
        "INT16",
        "UINT16",
        "INT32",
        "UINT32",
        "INT64",
        "UINT64",
        "FLOAT32",
        "FLOAT64",
        "STRING",
        "BIT",
        "",
        "int16",
    ],
    "length": ["Full word", "Lower byte", "Upper byte", "x"],
    "multiplier": NUMBERS,
    "offset": NUMBERS,
    "minimum": NUMBERS,
    "maximum": NUMBERS,
    "units": ["", "\u00b0C", " V "],
    "read_function_code": [
        "arg = r1 * 2;",
        "arg = (r1 >> 3) & 1;",
        "arg = r1 / 0;",
        "arg = r9;",
        "(",
        "",
        "arg = (float)r1 / 10.0f;",
        "arg = " + "(" * 300 + "r1" + ")" * 300 + ";",
    ],
    "write_function_code": ["r1 = (uint16_t)(arg * 10.0f);", "r1 = arg;", "r2 = arg;", ")", ""],
    "register_type": ["holding", "input", "coil", "discrete", "x"],
    "byte_order": ["big", "little", "x"],
    "word_order": ["big", "little", "x"],
    "access": ["read", "write", "read_write", "x"],
    "not_implemented": ["0xFFFF", "0xFFFFFFFF", "0x" + "F" * 16, "0x" + "F" * 17, "", "FFFF"],
    "expression": [
        "int16(hr:0)",
        "uint32(hr:0#2)",
        "hr:0",
        "int16(hr:0; 0xDE 0xAD)",
        "utf8(hr:0#200)",
        "utf8(hr:1..hr:3000000000)",
        "enum(hr:0 ; ; 1 -> 'a')",
        "bitset(c:0#2000 ; ; 0 -> 'x')",
        "pump + 1",
        "setpoint * 2",
        "(",
        "1/0",
        "concat(label, 1)",
        "x" * 300,
        "",
    ],
    "immutable": ["true", "false", "1", "x"],
    "system": ["true", "0"],
    "fetch_group": ["a", ""],
    "value": ["Off", "", "1.5", "x"],
    "input": ["0001", "FFFF ----", "xxxx", "0 1", "12345", ""],
}
ATTRIBUTES = {
    "version": ["1.0", "0.9b", "2"],
    "max_registers": ["1", "125", "126", "0", *BIG],
    "key": ["0", "-1", "65536", *BIG],
    "id": ["t", "", "x" * 300],
    "address": ["0", "100", "65536", *BIG],
    "function": ["setpoint", "pump", "nosuch", ""],
    "register_type": ["holding", "coil", "x"],
}
TESTS = (
    f'<tests xmlns="{MDL_NS}"><test id="t"><input address="100">0001</input>'
    '<expect function="setpoint"><value>0.1</value></expect></test></tests>'
)

xml_text = st.text(st.characters(blacklist_categories=("Cs", "Cc")) | st.sampled_from("\t\n"), max_size=12)
MUTATIONS = ("field", "field", "field", "field", "text", "remove", "repeat", "attribute", "tests", "raw")
mutations = st.lists(
    st.tuples(st.sampled_from(MUTATIONS), st.integers(0, 10**6), st.integers(0, 10**6), st.booleans(), xml_text),
    min_size=1,
    max_size=4,
)


def _q(tag: str) -> str:
    return f"{{{MDL_NS}}}{tag}"


def _local(el: etree._Element) -> str:
    return etree.QName(el).localname


def _pool(name: str, pick: int, own: bool, text: str) -> str:
    """A value from the pool for `name` (or the drawn text)."""
    pool = TEXTS.get(name) or ATTRIBUTES.get(name)
    return pool[pick % len(pool)] if pool and own else text


def _field(root: etree._Element, where: int, pick: int, own: bool, text: str) -> None:
    """Give a function's element (added in schema order if missing) a value from its pool."""
    functions = root.findall(_q("function"))
    if not functions:
        return
    fn = functions[where % len(functions)]
    tag = FUNCTION_TAGS[pick % len(FUNCTION_TAGS)]
    el = fn.find(_q(tag))
    if el is None:
        rank = {name: i for i, name in enumerate(FUNCTION_TAGS)}
        later = [i for i, child in enumerate(fn) if rank.get(_local(child), 0) > rank[tag]]
        el = etree.Element(_q(tag))
        fn.insert(later[0] if later else len(fn), el)
    if tag == "values":
        el.clear()
        etree.SubElement(el, _q("value"), key=_pool("key", pick, own, "0")).text = _pool("value", pick, own, text)
    else:
        el.text = _pool(tag, pick // len(FUNCTION_TAGS), own, text)


def mutate(ops: list[tuple[str, int, int, bool, str]]) -> bytes:
    """all_tables.xml with the mutations `ops` applied, in order."""
    tree = etree.fromstring(BASE).getroottree()
    root = tree.getroot()
    raw: list[tuple[int, int, str]] = []
    for op, where, pick, own, text in ops:
        elements = [el for el in root.iter() if isinstance(el.tag, str)]
        el = elements[where % len(elements)]
        if op == "text" and len(el) == 0:
            el.text = _pool(_local(el), pick, own, text)
        elif op == "remove" and el is not root:
            el.getparent().remove(el)
        elif op == "repeat" and el is not root:
            el.addnext(copy.deepcopy(el))
        elif op == "field":
            _field(root, where, pick, own, text)
        elif op == "attribute":
            name = list(ATTRIBUTES)[pick % len(ATTRIBUTES)]
            target = root if name in ("version", "max_registers") else el
            target.set(name, _pool(name, pick // 7, own, text))
        elif op == "tests" and root.find(_q("tests")) is None:
            root.append(etree.fromstring(TESTS))
        elif op == "raw":
            raw.append((where, pick, text))
    data = etree.tostring(tree, encoding="US-ASCII", xml_declaration=True)
    for where, pick, text in raw:  # cut a slice out, or put text in, anywhere
        at, size = where % len(data), pick % 40
        data = data[:at] + (text.encode() if size % 2 else b"") + data[at + size :]
    return data


def assert_positioned(path: Path, diagnostics: list[Diagnostic]) -> None:
    for diag in diagnostics:
        assert diag.file == str(path) and diag.message, str(diag)
        assert diag.severity != "error" or diag.line, str(diag)
        assert re.match(r"^.+?:\d+(:\d+)?: (error|warning): \S", str(diag)), str(diag)


def check(folder: Path, data: bytes) -> None:
    """`mdl validate` in process; for a valid document: load, plan, write back, validate again."""
    path = folder / "device.xml"
    path.write_bytes(data)
    device, diagnostics = validate_file(path)
    assert_positioned(path, diagnostics)
    errors = [d for d in diagnostics if d.severity == "error"]
    if device is None or errors:
        event(re.sub(r"'.*?'|\d+", "_", errors[0].message)[:50] if errors else "no device")
        return
    event("valid")
    device = load_device(path)
    layouts = resolve(device, str(path)).layouts  # an expression's layout needs its compiled expression
    for request in plan_reads(device, layouts=layouts):
        split_request(device, request, layouts)
    for fn in device.functions:
        if fn.readable:
            plan_reads(device, [fn], layouts=layouts)
    again = folder / "again.xml"
    again.write_text(device_to_xml(device), encoding="ascii")
    again_device, again_diagnostics = validate_file(again)
    assert again_device is not None and not [d for d in again_diagnostics if d.severity == "error"], again_diagnostics


@settings(max_examples=2000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutations)
# crashes the fuzzer found, or that its pools were built to find, fixed since ("field", function, tag, False,
# text) gives the first function's element `tag` the text):
@example([("field", 0, FUNCTION_TAGS.index("count"), False, "")])  # empty: the XSD's default, 1
@example([("field", 0, FUNCTION_TAGS.index("multiplier"), False, "")])
@example([("field", 0, FUNCTION_TAGS.index("offset"), False, "")])
@example([("field", 0, FUNCTION_TAGS.index("count"), False, "9" * 5000)])  # more digits than int() takes
@example([("field", 0, FUNCTION_TAGS.index("count"), False, "0" * 5000 + "1")])  # leading zeros count
@example([("field", 0, FUNCTION_TAGS.index("addresses"), False, "1 " + "9" * 5000)])
@example([("attribute", 0, list(ATTRIBUTES).index("max_registers"), False, "0" * 5000 + "7")])
def test_validate_gives_valid_or_positioned_errors(ops):
    with tempfile.TemporaryDirectory() as folder:
        check(Path(folder), mutate(ops))


HOSTILE = {  # a handful through the command line
    "nul": BASE.replace(b"<name>pump", b"<name>pu\x00mp"),
    "long_key": BASE.replace(b'<value key="0">', b'<value key="' + b"9" * 5000 + b'">'),
    "long_input_address": BASE.replace(
        b"</device>", TESTS.replace('address="100"', 'address="' + "1" * 5000 + '"').encode() + b"</device>"
    ),
    "doctype": BASE.replace(b"<device", b'<!DOCTYPE d [<!ENTITY a "aaaa">]>\n<device', 1),
    "long_count": BASE.replace(b"<count>4</count>", b"<count>" + b"9" * 5000 + b"</count>"),
    "deep": BASE.replace(b"</device>", b"<x>" * 10000 + b"</x>" * 10000 + b"</device>"),
    "truncated": BASE[: len(BASE) // 2],
}


@pytest.mark.parametrize("case", HOSTILE)
def test_cli_on_hostile_documents(case, tmp_path):
    (tmp_path / "device.xml").write_bytes(HOSTILE[case])
    proc = run_mdl("validate", tmp_path / "device.xml")
    assert_clean_error(proc, 1)
    for line in proc.stderr.splitlines():
        assert re.match(r"^.+?:\d+(:\d+)?: (error|warning): \S", line), line
