"""Model -> MDL XML: US-ASCII, everything else as character references, defaults not written."""

from __future__ import annotations

import math

from lxml import etree

from mdl.diagnostics import error
from mdl.exchange.text import unwritable
from mdl.formats.mdl.parse import NS
from mdl.model import EXTENSION_FIELDS, IDENTITY_FIELDS, Device

_ORDER = (  # a function's elements in schema order: 0.9b's, then the 1.0 extensions (one list, in the model)
    *("name", "description", "addresses", "length", "count", "format", "block_labels", "multiplier", "units"),
    *("read_function_code", "write_function_code"),
    *EXTENSION_FIELDS,
)


def format_float(x: float) -> str:
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "INF" if x > 0 else "-INF"
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def _checked(text: str, what: str) -> str:
    bad = unwritable(text)
    if bad:
        raise error(f"{what} would hold the character {bad}, which XML cannot carry")
    return text


def _sub(parent: etree._Element, tag: str, text: str | None) -> etree._Element:
    el = etree.SubElement(parent, f"{{{NS}}}{tag}")
    if text:
        owner = parent.findtext(f"{{{NS}}}name") if parent.tag == f"{{{NS}}}function" else None
        el.text = _checked(text, f"function '{owner}': <{tag}>" if owner else f"<{tag}>")
    return el


def device_to_xml(device: Device) -> str:
    root = etree.Element(f"{{{NS}}}device", nsmap={None: NS})
    if device.version:
        root.set("version", device.version)
    if device.max_registers is not None:
        root.set("max_registers", str(device.max_registers))
    _sub(root, "name", device.name)
    _sub(root, "description", device.description)
    for tag in IDENTITY_FIELDS:
        value = getattr(device, tag)
        if value is not None:
            _sub(root, tag, value)
    for fn in device.functions:
        el = etree.SubElement(root, f"{{{NS}}}function")
        for attr in _ORDER:
            value = getattr(fn, attr)
            if value is None:
                continue
            if attr == "addresses":
                _sub(el, attr, " ".join(str(a) for a in value))
            elif attr == "block_labels":
                for label in value:
                    _sub(el, "block_label", label)
            elif attr in ("not_implemented", "marker", "initial"):
                _sub(el, attr, " ".join(str(v) for v in value))
            elif attr == "values":
                values = _sub(el, "values", None)
                for key, label in value.items():
                    _sub(values, "value", label).set("key", str(key))
            elif isinstance(value, bool):
                _sub(el, attr, "true" if value else "false")
            elif isinstance(value, float):
                _sub(el, attr, format_float(value))
            else:
                _sub(el, attr, str(value))
    if device.tests:
        tests = _sub(root, "tests", None)
        for sc in device.tests:
            test = etree.SubElement(tests, f"{{{NS}}}test", id=_checked(sc.id, "a test's id"))
            if sc.description is not None:
                _sub(test, "description", sc.description)
            for item in sc.inputs:
                inp = _sub(test, "input", " ".join(item.values))
                if item.table != "holding":
                    inp.set("register_type", item.table)
                inp.set("address", str(item.address))
            for name, values in sc.expected.items():
                expect = etree.SubElement(test, f"{{{NS}}}expect", function=_checked(name, f"test '{sc.id}': <expect>"))
                for v in values or ():
                    _sub(expect, "value", v)
    etree.indent(root, space="  ")
    xml: bytes = etree.tostring(root, encoding="US-ASCII", xml_declaration=True)
    return xml.decode("ascii") + "\n"
