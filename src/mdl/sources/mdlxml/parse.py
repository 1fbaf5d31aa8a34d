"""Parse XML with entity resolution, DTDs and network access off; validate against our XSDs."""

from __future__ import annotations

import re
from functools import cache
from typing import TYPE_CHECKING

from lxml import etree

from mdl.diagnostics import Diagnostic, MdlError
from mdl.fileio import read_bytes
from mdl.resources import schema_path

if TYPE_CHECKING:
    from _typeshed import StrPath

NS = "http://www.ornl.gov/ModbusXMLSchema"
SCHEMA_VERSIONS = ("0.9b", "1.0")


def secure_parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, dtd_validation=False,
        huge_tree=False, remove_comments=False,
    )


def parse_file(path: StrPath) -> etree._ElementTree:
    data = read_bytes(path)
    try:
        tree = etree.fromstring(data, secure_parser()).getroottree()
    except etree.XMLSyntaxError as exc:
        line, col = exc.position if exc.position else (None, None)
        msg = re.sub(r", line \d+, column \d+$", "", str(exc.msg))
        raise MdlError(Diagnostic(str(path), line, col, f"malformed XML: {msg}")) from None
    if tree.docinfo.internalDTD is not None or tree.docinfo.doctype:
        raise MdlError(Diagnostic(str(path), 1, None, "a DOCTYPE (DTD, entity declarations) is not allowed in MDL"))
    return tree


@cache
def schema(version: str) -> etree.XMLSchema:
    return etree.XMLSchema(etree.parse(str(schema_path(version)), secure_parser()))


def _clean(message: str) -> str:
    message = message.replace("{" + NS + "}", "")
    return re.sub(r"\{[^}]*\}", "", message) if "{http" in message else message


def schema_errors(tree: etree._ElementTree, path: StrPath, version: str) -> list[Diagnostic]:
    xsd = schema(version)
    if xsd.validate(tree):
        return []
    out: list[Diagnostic] = []
    for entry in xsd.error_log:
        message = _clean(entry.message)
        if "No matching global declaration" in message:
            root = etree.QName(tree.getroot())
            if root.namespace != NS:
                message = (
                    f"root element '{root.localname}' is not in the MDL namespace; "
                    f'add xmlns="{NS}"'
                )
        out.append(Diagnostic(str(path), entry.line or None, entry.column or None, message))
    return out
