"""Parse XML with entity resolution, DTDs and network access off; validate against our XSDs."""

from __future__ import annotations

import re
from bisect import bisect_right
from functools import cache
from typing import TYPE_CHECKING

from lxml import etree

from mdl.diagnostics import Diagnostic, MdlError
from mdl.fileio import read_bytes
from mdl.formats.sniff import not_xml, starts_with_markup
from mdl.records import record
from mdl.resources import schema_path

if TYPE_CHECKING:
    from _typeshed import StrPath

NS = "http://www.ornl.gov/ModbusXMLSchema"
SCHEMA_VERSIONS = ("0.9b", "1.0")


def secure_parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False,
        no_network=True,
        load_dtd=False,
        dtd_validation=False,
        huge_tree=False,
        remove_comments=False,
    )


def parse_file(path: StrPath) -> etree._ElementTree:
    return parse_source(path)[0]


def parse_source(path: StrPath) -> tuple[etree._ElementTree, bytes]:
    """The parsed document and the bytes it was parsed from (for positions: see `start_tags`)."""
    data = read_bytes(path)
    try:
        tree = etree.fromstring(data, secure_parser()).getroottree()
    except etree.XMLSyntaxError as exc:
        line, col = exc.position if exc.position else (None, None)
        if not starts_with_markup(data):  # another kind of file: say which, and the command that reads it
            raise MdlError(Diagnostic(str(path), line, col, not_xml(data, path))) from None
        msg = re.sub(r", line \d+, column \d+$", "", str(exc.msg))
        raise MdlError(Diagnostic(str(path), line, col, f"malformed XML: {msg}")) from None
    if tree.docinfo.internalDTD is not None or tree.docinfo.doctype:
        raise MdlError(Diagnostic(str(path), 1, None, "a DOCTYPE (DTD, entity declarations) is not allowed in MDL"))
    return tree, data


# markup that holds no element (comments, CDATA, processing instructions, declarations), or a tag
_MARKUP = re.compile(
    r"<!--.*?-->|<!\[CDATA\[.*?\]\]>|<\?.*?\?>|<![^>]*>"
    r"|<(/?)((?:[^\s/>:]+:)?([^\s/>]+))((?:[^>\"']|\"[^\"]*\"|'[^']*')*)>",
    re.S,
)


@record
class StartTag:
    """An element's start tag in the source text: where the tag and where its text begin (1-based)."""

    localname: str
    line: int
    col: int
    text_line: int
    text_col: int
    text_start: int  # index of the text in the decoded source


def start_tags(text: str) -> list[StartTag]:
    """Every element's start tag, in document order (the order of `root.iter()` over elements).

    lxml gives an element's line (where its start tag ends) but no column; an error inside an
    expression or fragment needs the column where the element's text starts."""
    line_starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def where(index: int) -> tuple[int, int]:
        line = bisect_right(line_starts, index)
        return line, index - line_starts[line - 1] + 1

    out = []
    for m in _MARKUP.finditer(text):
        if m.group(2) is None or m.group(1):
            continue
        out.append(StartTag(m.group(3), *where(m.start()), *where(m.end()), m.end()))
    return out


def element_tags(root: etree._Element, text: str) -> dict[etree._Element, StartTag]:
    """Each element under (and with) `root` -> its start tag in `text`, the source it was parsed from;
    empty if the two cannot be matched one to one."""
    elements = [el for el in root.iter() if isinstance(el.tag, str)]
    found = start_tags(text)
    matched = len(found) == len(elements) and all(
        etree.QName(el).localname == tag.localname for el, tag in zip(elements, found, strict=True)
    )
    return dict(zip(elements, found, strict=True)) if matched else {}


def decoded(tree: etree._ElementTree, data: bytes) -> str:
    """The source text as characters (positions count characters, not bytes)."""
    encoding = tree.docinfo.encoding or "utf-8"
    try:
        return data.decode(encoding, errors="replace")
    except LookupError:
        return data.decode("utf-8", errors="replace")


@cache
def schema(version: str) -> etree.XMLSchema:
    return etree.XMLSchema(etree.parse(str(schema_path(version)), secure_parser()))


def _clean(message: str) -> str:
    message = message.replace("{" + NS + "}", "")
    return re.sub(r"\{[^}]*\}", "", message) if "{http" in message else message


def schema_errors(tree: etree._ElementTree, path: StrPath, version: str, data: bytes | None = None) -> list[Diagnostic]:
    """The XSD's errors, each with its line and column: libxml2's column where it knows one, else (with
    `data`, the bytes the tree was parsed from) the column of the start tag of the element it is about."""
    xsd = schema(version)
    if xsd.validate(tree):
        return []
    out: list[Diagnostic] = []
    tags: dict[etree._Element, StartTag] | None = None
    for entry in xsd.error_log:
        line, col = entry.line or None, entry.column or None
        if col is None and data is not None:
            if tags is None:
                tags = element_tags(tree.getroot(), decoded(tree, data))
            tag = _tag_of(tree, entry.path, tags)
            if tag is not None:
                line, col = tag.line, tag.col
        message = _clean(entry.message)
        if "No matching global declaration" in message:
            root = etree.QName(tree.getroot())
            if root.namespace != NS:
                message = f"root element '{root.localname}' is not in the MDL namespace; add xmlns=\"{NS}\""
        out.append(Diagnostic(str(path), line, col, message))
    return out


def _tag_of(tree: etree._ElementTree, xpath: str | None, tags: dict[etree._Element, StartTag]) -> StartTag | None:
    """The start tag of the element an XSD error's path (`/*/*[7]/*[4]`) names."""
    if not xpath:
        return None
    try:
        found = tree.xpath(xpath)
    except etree.XPathError:
        return None
    return tags.get(found[0]) if isinstance(found, list) and found and isinstance(found[0], etree._Element) else None
