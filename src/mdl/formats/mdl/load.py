"""XML -> model: the XSD, then the elements read into the document model, each function's texts
with their positions in the file. The checks an XSD cannot make are mdl.resolver's."""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, Any

from lxml import etree

from mdl.diagnostics import Collector, Diagnostic, MdlError, TextSpan, defer_spans, record_span
from mdl.formats.mdl.parse import (
    NS,
    StartTag,
    decoded,
    element_tags,
    parse_source,
    schema_errors,
    secure_parser,
)
from mdl.model import IDENTITY_FIELDS, Device, Function, Scenario, ScenarioInput

if TYPE_CHECKING:
    from _typeshed import StrPath

_FLOATS = ("multiplier", "offset", "minimum", "maximum")
_STRINGS = (
    "length",
    "format",
    "units",
    "read_function_code",
    "write_function_code",
    "register_type",
    "byte_order",
    "word_order",
    "access",
)


# elements the XSDs give a default: empty, they take it, as the model does for an absent one
_DEFAULTED = (
    "length",
    "count",
    "format",
    "multiplier",
    "register_type",
    "byte_order",
    "word_order",
    "offset",
    "immutable",
    "system",
    "write_multiple",
)
_CODE = ("expression", "read_function_code", "write_function_code")  # texts whose errors point inside them
_NAMED = ("bits", "scale_exponent", "scale_by", "role")  # texts kept without the spaces around them
_SPANNED = _CODE + _FLOATS + _NAMED + ("initial",)  # the texts mdl.resolver may point at
# sets of the above, for the loop over every child of every function
_DEFAULTED_SET = frozenset(_DEFAULTED)
_SPANNED_SET = frozenset(_SPANNED)
_FLOATS_SET = frozenset(_FLOATS)
_STRINGS_SET = frozenset(_STRINGS)
_KEPT_AS_IS = frozenset(("units", "read_function_code", "write_function_code"))  # strings not stripped
_MAX_DIGITS = 18  # more than any address, count or key of MDL needs; int() refuses over 4300


def _q(name: str) -> str:
    """The qualified name of an MDL element."""
    return f"{{{NS}}}{name}"


@functools.lru_cache(maxsize=256)
def _local(tag: str) -> str:
    """An element's name without its namespace (`{ns}name` -> `name`), worked out once per spelling:
    etree.QName for each element of a large file cost a third of reading it."""
    name: str = etree.QName(tag).localname
    return name


def _text(el: etree._Element) -> str:
    return el.text or ""


def _float(text: str) -> float:
    t = text.strip()
    return float({"INF": "inf", "-INF": "-inf", "NaN": "nan"}.get(t, t))


class _Reader:
    """Elements -> model objects; MdlError at the element for an integer too long to be one MDL can
    use, and an error in `problems` for each number that is not finite. Where each function's texts start in the
    file (for the messages of mdl.resolver) is found only when a message asks for it (`record_spans`):
    scanning every start tag of a large file costs more than reading it."""

    def __init__(self, source: str | None, root: etree._Element | None = None, data: bytes | None = None):
        self.source = source
        self.root = root
        self.data = data
        self.text = ""
        self._tags: dict[etree._Element, StartTag] | None = None if data is not None else {}
        self.problems = Collector(source)
        self.pending: list[tuple[etree._Element, object, str]] = []  # (element, owner, key) to record

    @property
    def tags(self) -> dict[etree._Element, StartTag]:
        """Each element's start tag in the source text, once scanned (empty if they cannot be matched)."""
        if self._tags is None:
            assert self.root is not None and self.data is not None
            self.text = decoded(self.root.getroottree(), self.data)
            self._tags = element_tags(self.root, self.text)
        return self._tags

    def where(self, el: etree._Element, inside: bool = True) -> tuple[int | None, int | None]:
        """(line, column) of the element's text (inside) or of its start tag."""
        tag = self.tags.get(el)
        if tag is None:
            return el.sourceline, None
        return (tag.text_line, tag.text_col) if inside else (tag.line, tag.col)

    def spans(self, owner: object, elements: list[tuple[etree._Element, str]]) -> None:
        """Remember that `owner`'s text `key` ("": its own element) is each element; they are recorded
        when a message asks for one."""
        self.pending += [(el, owner, key) for el, key in elements]
        defer_spans(owner, self.record_spans)

    def record_spans(self) -> None:
        pending, self.pending = self.pending, []
        tags = self.tags
        for el, owner, key in pending:
            tag = tags.get(el)
            if tag is None:
                continue
            if key:
                end = self.text.find("<", tag.text_start)
                raw = self.text[tag.text_start : end if end >= 0 else len(self.text)] if key in _CODE else ""
                record_span(owner, key, TextSpan(tag.text_line, tag.text_col, raw))
            else:
                record_span(owner, key, TextSpan(tag.line, tag.col))

    def integer(self, text: str | None, el: etree._Element, what: str, inside: bool = True) -> int:
        """An integer of the element's text (inside) or of one of its attributes."""
        if text is not None and len(text) <= _MAX_DIGITS and text.isascii() and text.isdigit():
            return int(text)  # the usual address or count: plain digits, too few to be too many
        t = (text or "").strip()
        digits = t.lstrip("+-").lstrip("0")  # leading zeros count towards int()'s limit too
        if len(digits) > _MAX_DIGITS:
            raise MdlError(
                Diagnostic(
                    self.source, *self.where(el, inside), f"{what} '{t[:20]}...' is too large ({len(digits)} digits)"
                )
            )
        return -int(digits or "0") if t.startswith("-") else int(digits or "0")

    def number(self, text: str, el: etree._Element, tag: str, owner: str | None) -> float:
        value = _float(text)
        if not math.isfinite(value):
            line, col = self.where(el)
            if col is not None:
                lead = len(text) - len(text.lstrip())
                line, col = TextSpan(line or 1, col, text).at(lead)
            subject = f"function '{owner}': " if owner is not None else ""
            self.problems.error(f"{subject}<{tag}> {text.strip()[:40]} is not a finite number", line, col)
        return value

    def function(self, el: etree._Element) -> Function:
        kw: dict[str, Any] = {"block_labels": [], "line": el.sourceline}
        spans: list[tuple[etree._Element, str]] = [(el, "")]
        for child in el:
            qualified = child.tag  # read once: lxml builds the string at each read
            if not isinstance(qualified, str):
                continue
            tag = _local(qualified)
            text = child.text or ""
            if tag in _SPANNED_SET:
                spans.append((child, tag))
            if tag in _DEFAULTED_SET and not text.strip():
                continue
            if tag in ("name", "description"):
                kw[tag] = text
            elif tag == "addresses":
                kw["addresses"] = [self.integer(a, child, "address") for a in text.split()]
            elif tag == "count":
                kw["count"] = self.integer(text, child, "count")
            elif tag == "block_label":
                kw["block_labels"].append(text)
            elif tag in _FLOATS_SET:
                kw[tag] = self.number(text, child, tag, kw.get("name"))
            elif tag in _STRINGS_SET:
                kw[tag] = text if tag in _KEPT_AS_IS else text.strip()
            elif tag == "not_implemented":
                kw["not_implemented"] = text.split()
            elif tag == "values":
                kw["values"] = {
                    self.integer(v.get("key"), v, "key", False): _text(v) for v in child if isinstance(v.tag, str)
                }
            elif tag == "expression":
                kw["expression"] = text
                kw["expression_line"] = child.sourceline
            elif tag in ("immutable", "system", "write_multiple"):
                kw[tag] = text.strip() in ("true", "1")
            elif tag == "marker":
                kw["marker"] = [self.integer(m, child, "marker") for m in text.split()]
            elif tag == "precision":
                kw["precision"] = self.integer(text, child, "precision")
            elif tag == "fetch_group":
                kw["fetch_group"] = text
            elif tag in _NAMED:
                kw[tag] = text.strip()
            elif tag == "initial":
                kw["initial"] = [int(w, 16) if w[:2] in ("0x", "0X") else int(w) for w in text.split()]
        fn = Function(**kw)
        self.spans(fn, spans)
        return fn

    def scenario(self, el: etree._Element) -> Scenario:
        sc = Scenario(el.get("id"), line=el.sourceline)
        self.spans(sc, [(el, "")])
        for child in el:
            if not isinstance(child.tag, str):
                continue
            tag = _local(child.tag)
            if tag == "description":
                sc.description = _text(child)
            elif tag == "input":
                address = self.integer(child.get("address"), child, "address", False)
                sc.inputs.append(ScenarioInput(child.get("register_type", "holding"), address, _text(child).split()))
            elif tag == "expect":
                values = [_text(v) for v in child if isinstance(v.tag, str)]
                sc.expected[child.get("function")] = values or None
        return sc


def tree_to_device(tree: etree._ElementTree, source: str | None = None, data: bytes | None = None) -> Device:
    """The model of a document that passed the XSD (with `data`, the bytes it was parsed from, every
    function's texts get their positions); MdlError for an integer too long to be used or a number
    that is not finite."""
    root = tree.getroot()
    read = _Reader(source, root, data)
    name = root.find(_q("name"))
    desc = root.find(_q("description"))
    functions = [read.function(el) for el in root.findall(_q("function"))]
    tests = root.find(_q("tests"))
    scenarios = [read.scenario(t) for t in tests.findall(_q("test"))] if tests is not None else []
    limit = root.get("max_registers")
    max_registers = read.integer(limit, root, "max_registers", False) if limit else None
    if read.problems.failed:
        raise MdlError(read.problems.diagnostics())
    device = Device(_text(name), _text(desc), functions, root.get("version"), max_registers, scenarios, source)
    for tag in IDENTITY_FIELDS:
        el = root.find(_q(tag))
        if el is not None:
            setattr(device, tag, _text(el))
    return device


def read_device(path: StrPath, version: str = "1.0") -> Device:
    """The model of an MDL file: well-formed, valid against the XSD, numbers usable. Nothing more is
    checked here: `mdl.resolver.resolve` runs the checks of SPEC 2 (see mdl.formats.loading)."""
    tree, data = parse_source(path)
    errors = schema_errors(tree, path, version, data)
    if errors:
        raise MdlError(errors)
    return tree_to_device(tree, str(path), data)


def validate_file(path: StrPath, version: str = "1.0") -> tuple[Device | None, list[Diagnostic]]:
    """(device, diagnostics) as `mdl validate` reports them: the XSD, then the checks resolve runs
    (validating needs no value IR, so it stops there); device is None if the file did not load."""
    from mdl.resolver.checks import check_device

    try:
        device = read_device(path, version)
    except MdlError as exc:
        return None, exc.diagnostics
    return device, check_device(device, str(path))


def load_device(path: StrPath, version: str = "1.0") -> Device:
    """`read_device`, resolved (MdlError with every error): for tests and scripts that want a checked
    model. Commands use mdl.formats.loading.load_resolved."""
    from mdl.resolver import resolve

    return resolve(read_device(path, version), str(path)).device


def text_problems(xml: str, where: str, *, model: bool = True) -> list[Diagnostic]:
    """The errors `mdl validate` finds in MDL text: the XSD, then (with `model`) the model's numbers and
    the checks of SPEC 2; `where` names the text in them."""
    from mdl.resolver.checks import check_device

    data = xml.encode("ascii")
    try:
        tree = etree.fromstring(data, secure_parser()).getroottree()
        problems = schema_errors(tree, where, "1.0", data)  # as `mdl validate` checks by default
        if model and not problems:
            problems = [d for d in check_device(tree_to_device(tree, where, data), where) if d.severity == "error"]
    except etree.XMLSyntaxError as exc:
        problems = [Diagnostic(where, None, None, str(exc))]
    except MdlError as exc:
        problems = list(exc.diagnostics)
    return problems


def check_written(xml: str, what: str) -> str:
    """MDL a command made (an import, csv2xml) read back as `mdl validate` reads a file: the XSD, the
    model, the checks of SPEC 2. A problem is mdl's own (a converter let through what MDL cannot say),
    so it is refused as an internal error before anything is written: nothing invalid is ever written.
    Returns `xml`."""
    problems = text_problems(xml, f"<{what} output>")
    if problems:
        raise MdlError(
            [
                Diagnostic(d.file, d.line, d.col, f"internal error, the output would not validate: {d.message}")
                for d in problems
            ]
        )
    return xml
