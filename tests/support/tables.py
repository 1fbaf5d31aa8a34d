"""Reading what csv2xml wrote: the functions of an MDL text, and the values a served table reads."""

from __future__ import annotations

from lxml import etree

from support.common import MDL_NS

NS = {"m": MDL_NS}


def functions(xml_text: str) -> dict[str, dict]:
    root = etree.fromstring(xml_text.encode())
    out = {}
    for fn in root.findall("m:function", NS):
        out[fn.findtext("m:name", namespaces=NS)] = {etree.QName(c).localname: c.text for c in fn}
    return out
