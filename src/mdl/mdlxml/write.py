"""Model -> MDL XML: US-ASCII, everything else as character references, defaults not written."""

from __future__ import annotations

import math

from lxml import etree

from mdl.mdlxml.parse import NS
from mdl.model import Device

_ORDER = ("name", "description", "addresses", "length", "count", "format", "block_labels",
          "multiplier", "units", "read_function_code", "write_function_code", "register_type",
          "byte_order", "word_order", "offset", "access", "minimum", "maximum",
          "not_implemented", "values")


def format_float(x: float) -> str:
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "INF" if x > 0 else "-INF"
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def _sub(parent, tag: str, text: str):
    el = etree.SubElement(parent, f"{{{NS}}}{tag}")
    el.text = text
    return el


def device_to_xml(device: Device) -> str:
    root = etree.Element(f"{{{NS}}}device", nsmap={None: NS})
    if device.version:
        root.set("version", device.version)
    _sub(root, "name", device.name)
    _sub(root, "description", device.description)
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
            elif attr == "not_implemented":
                _sub(el, attr, " ".join(value))
            elif attr == "values":
                values = _sub(el, "values", None)
                for key, label in value.items():
                    _sub(values, "value", label).set("key", str(key))
            elif isinstance(value, float):
                _sub(el, attr, format_float(value))
            else:
                _sub(el, attr, str(value))
    etree.indent(root, space="  ")
    return etree.tostring(root, encoding="US-ASCII", xml_declaration=True).decode("ascii") + "\n"
