"""XML -> model, and the checks an XSD cannot make (names, layouts, fragments)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from lxml import etree

from mdl.diagnostics import Diagnostic, MdlError
from mdl.model import Device, Function, Scenario, ScenarioInput
from mdl.resolve.checks import check_device
from mdl.sources.mdlxml.parse import NS, parse_file, schema_errors

if TYPE_CHECKING:
    from _typeshed import StrPath

_FLOATS = ("multiplier", "offset", "minimum", "maximum")
_STRINGS = ("length", "format", "units", "read_function_code", "write_function_code",
            "register_type", "byte_order", "word_order", "access")


# elements the XSDs give a default: empty, they take it, as the model does for an absent one
_DEFAULTED = ("length", "count", "format", "multiplier", "register_type", "byte_order", "word_order", "offset",
              "immutable", "system")
_MAX_DIGITS = 18  # more than any address, count or key of MDL needs; int() refuses over 4300


def _q(name: str) -> str:
    """The qualified name of an MDL element."""
    return f"{{{NS}}}{name}"


def _text(el: etree._Element) -> str:
    return el.text or ""


def _float(text: str) -> float:
    t = text.strip()
    return float({"INF": "inf", "-INF": "-inf", "NaN": "nan"}.get(t, t))


class _Reader:
    """Elements -> model objects; MdlError at the element for an integer too long to be one MDL can use."""

    def __init__(self, source: str | None):
        self.source = source

    def integer(self, text: str | None, el: etree._Element, what: str) -> int:
        t = (text or "").strip()
        digits = t.lstrip("+-").lstrip("0")  # leading zeros count towards int()'s limit too
        if len(digits) > _MAX_DIGITS:
            raise MdlError(Diagnostic(self.source, el.sourceline, None,
                                      f"{what} '{t[:20]}...' is too large ({len(digits)} digits)"))
        return -int(digits or "0") if t.startswith("-") else int(digits or "0")

    def function(self, el: etree._Element) -> Function:
        kw: dict[str, Any] = {"block_labels": [], "line": el.sourceline}
        for child in el:
            if not isinstance(child.tag, str):
                continue
            tag = etree.QName(child).localname
            text = _text(child)
            if tag in _DEFAULTED and not text.strip():
                continue
            if tag in ("name", "description"):
                kw[tag] = text
            elif tag == "addresses":
                kw["addresses"] = [self.integer(a, child, "address") for a in text.split()]
            elif tag == "count":
                kw["count"] = self.integer(text, child, "count")
            elif tag == "block_label":
                kw["block_labels"].append(text)
            elif tag in _FLOATS:
                kw[tag] = _float(text)
            elif tag in _STRINGS:
                kw[tag] = text.strip() if tag not in ("units", "read_function_code", "write_function_code") else text
            elif tag == "not_implemented":
                kw["not_implemented"] = text.split()
            elif tag == "values":
                kw["values"] = {self.integer(v.get("key"), v, "key"): _text(v) for v in child if isinstance(v.tag, str)}
            elif tag == "expression":
                kw["expression"] = text
                kw["expression_line"] = child.sourceline
            elif tag in ("immutable", "system"):
                kw[tag] = text.strip() in ("true", "1")
            elif tag == "fetch_group":
                kw["fetch_group"] = text
        return Function(**kw)

    def scenario(self, el: etree._Element) -> Scenario:
        sc = Scenario(el.get("id"), line=el.sourceline)
        for child in el:
            if not isinstance(child.tag, str):
                continue
            tag = etree.QName(child).localname
            if tag == "description":
                sc.description = _text(child)
            elif tag == "input":
                address = self.integer(child.get("address"), child, "address")
                sc.inputs.append(ScenarioInput(child.get("register_type", "holding"), address, _text(child).split()))
            elif tag == "expect":
                values = [_text(v) for v in child if isinstance(v.tag, str)]
                sc.expected[child.get("function")] = values or None
        return sc


def tree_to_device(tree: etree._ElementTree, source: str | None = None) -> Device:
    """The model of a document that passed the XSD; MdlError for an integer too long to be used."""
    read = _Reader(source)
    root = tree.getroot()
    name = root.find(_q("name"))
    desc = root.find(_q("description"))
    functions = [read.function(el) for el in root.findall(_q("function"))]
    tests = root.find(_q("tests"))
    scenarios = [read.scenario(t) for t in tests.findall(_q("test"))] if tests is not None else []
    limit = root.get("max_registers")
    max_registers = read.integer(limit, root, "max_registers") if limit else None
    return Device(_text(name), _text(desc), functions, root.get("version"), max_registers, scenarios, source)


def validate_file(path: StrPath, version: str = "1.0") -> tuple[Device | None, list[Diagnostic]]:
    """(device, diagnostics): every problem of the file; device is None if it did not load."""
    try:
        tree = parse_file(path)
    except MdlError as exc:
        return None, exc.diagnostics
    errors = schema_errors(tree, path, version)
    if errors:
        return None, errors
    try:
        device = tree_to_device(tree, str(path))
    except MdlError as exc:
        return None, exc.diagnostics
    return device, check_device(device, str(path))


def load_device(path: StrPath, version: str = "1.0") -> Device:
    device, diagnostics = validate_file(path, version)
    errors = [d for d in diagnostics if d.severity == "error"]
    if errors or device is None:
        raise MdlError(errors)
    return device
