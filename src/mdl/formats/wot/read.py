"""A W3C WoT Thing Description with Modbus forms -> MDL 1.0 (`mdl import --from wot TD.json`, SPEC 11.1;
docs/wot.md, "Import").

Each property with a Modbus form (`modbus+tcp://HOST:PORT/UNIT/ADDRESS?quantity=N`, relative to `base`
where there is one) becomes a function named after it: the table from `modv:entity` (or `modv:function`),
the address and register count from the href (node-wot's rule: the href wins over `modv:address` and
`modv:quantity`; `modv:zeroBasedAddressing: false` counts from 1), the format from the property's `type`
and the form's `contentType` (`length`, `signed`, `byteSeq`, as node-wot's octet-stream codec reads them;
`modv:mostSignificantByte`/`Word` where there is no byteSeq), one byte of a register from node-wot's
`ex:bitOffset`/`ex:bitLength`, writable unless `readOnly`, write-only where `writeOnly`, `unit`,
`minimum`/`maximum` (register values: made the description's with the mdl: terms) and `enum` with
`oneOf` labels; and the `mdl:` terms mdl export writes (vocabulary.MDL_TERMS) back as MDL's elements.
What MDL cannot hold, and a property without a Modbus form, is a warning naming the property, which is
left out; the connection of the forms is not part of MDL (a note names it). The file is read up to
MAX_BYTES, parsed by Python's json (NaN and Infinity refused) and every value checked before it is used:
anything else is an MdlError naming the file, never another exception.
"""

from __future__ import annotations

import bisect
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import parse_qs, urljoin, urlsplit

from mdl.diagnostics import Collector, Diagnostic, MdlError, error, line_order, message_kind, shown
from mdl.exchange.text import unwritable
from mdl.fileio import decode_text, is_stdin, read_bytes
from mdl.formats.wot import vocabulary as v
from mdl.ir.build import divisor_of
from mdl.model import Device, Function, parse_bits
from mdl.model.layout import MAX_ADDRESS, MAX_BITS, MAX_REGISTERS

if TYPE_CHECKING:
    from _typeshed import StrPath

MAX_BYTES = 16 * 1024 * 1024  # a TD of some 20,000 properties
SHOWN_PER_KIND = 5  # messages of one kind said in full before the rest are summed up
_HEX = re.compile(r"0[xX][0-9A-Fa-f]{1,16}")
_BYTE_SEQS = tuple(v.ORDERS)


class _LeftOut(Exception):
    """A property MDL cannot hold: why (the warning names the property)."""


@dataclass
class _Reader:
    path: str
    lines: dict[str, int] = field(default_factory=dict)  # property name -> the line of its key
    diagnostics: list[Diagnostic] = field(default_factory=list)
    connections: list[str] = field(default_factory=list)

    def say(self, name: str | None, message: str, severity: str = "warning") -> None:
        line = self.lines.get(name) if name is not None else None
        subject = f"property {shown(name)}: " if name is not None else ""
        self.diagnostics.append(Diagnostic(self.path, line, None, subject + message, severity))


def read_wot(path: StrPath) -> Device:
    """The device a Thing Description describes; MdlError for what is not a TD (or holds nothing MDL can)."""
    source = "<stdin>" if is_stdin(path) else str(path)
    text = decode_text(read_bytes(path, MAX_BYTES), path, ("utf-8-sig",)).lstrip("\ufeff")
    doc = _parse(text, source)
    reader = _Reader(source, _property_lines(text))
    if not isinstance(doc, dict):
        raise error("not a Thing Description: the document is not a JSON object", source)
    properties = doc.get("properties")
    if not isinstance(properties, dict) or not properties:
        raise error("not a Thing Description with properties: no 'properties' object, or an empty one", source)
    title = doc.get("title")
    if not isinstance(title, str) or not title.strip():
        title = Path(source).stem if source != "<stdin>" else "Thing"
        reader.say(None, f"the TD has no title: the device is named '{title}'")
    description = doc.get("description")
    description = description if isinstance(description, str) else ""
    _writable_text(title, "the TD's title", source)
    _writable_text(description, "the TD's description", source)
    base = doc.get("base") if isinstance(doc.get("base"), str) else None
    functions = []
    for name, prop in properties.items():
        try:
            functions.append(_function(name, prop, base, reader))
        except _LeftOut as exc:
            reader.say(name, f"{exc}: left out")
    if reader.connections:
        reader.say(
            None,
            f"the forms name {reader.connections[0]}: a connection is not part of MDL (give it to the commands: "
            "--host, --port, --unit)",
            "note",
        )
    if not functions:
        found = [d for d in _summed_up(reader.diagnostics) if d.severity == "warning"]
        raise MdlError([error("no property has a Modbus form MDL can hold", source).diagnostics[0], *found])
    device = Device(title, description, functions, source=source)
    if device.extensions():
        device.version = "1.0"
    device.notes = _summed_up(reader.diagnostics)
    return device


def _summed_up(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    """The diagnostics in line order, those of one kind past the first SHOWN_PER_KIND folded into the next one
    (`; and N more like it`): a TD of 20,000 properties of another protocol is a few lines, not 20,000."""
    collector = Collector(shown_each=SHOWN_PER_KIND, shown_lines=SHOWN_PER_KIND, fold=True, kind_of=message_kind)
    for d in sorted(diagnostics, key=line_order):
        collector.add(d)
    return collector.diagnostics()


def _what(value: Any) -> str:
    """A JSON value as a message says it: a text quoted (cut), an object or a list by its kind."""
    if isinstance(value, str):
        return shown(value)
    if isinstance(value, (dict, list)):
        return "an object" if isinstance(value, dict) else "a list"
    return str(json.dumps(value))[:40] if not isinstance(value, int) or isinstance(value, bool) else str(value)[:40]


def _reject_constant(name: str) -> None:
    raise ValueError(f"{name} is not JSON")


def _parse(text: str, source: str) -> Any:
    try:
        return json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise error(f"not JSON: {exc.msg}", source, exc.lineno, exc.colno) from None
    except RecursionError:
        raise error("not a Thing Description: JSON nested too deeply", source) from None
    except ValueError as exc:  # NaN, Infinity; an integer of more digits than Python converts
        raise error(f"not JSON mdl reads: {str(exc)[:120]}", source) from None


_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"\s*:?|[{}\[\]]', re.DOTALL)


def _property_lines(text: str) -> dict[str, int]:
    """Each property name -> the line of its key (for messages): the keys of the object that the top-level
    key `properties` holds. Best effort: a document Python's json refuses gives none."""
    breaks = [m.start() for m in re.finditer("\n", text)]
    out: dict[str, int] = {}
    depth = 0
    inside = None  # the depth of the properties object, once its key was seen
    after_key = False
    for m in _TOKEN.finditer(text):
        token = m.group(0)
        if token in "{[":
            depth += 1
            if after_key and inside == -1:
                inside = depth
            after_key = False
            continue
        if token in "}]":
            if inside is not None and inside > 0 and depth == inside:
                break
            depth -= 1
            continue
        after_key = False
        if not token.endswith(":"):
            continue
        try:
            key = json.loads(token[:-1].rstrip())
        except ValueError:
            continue
        if inside is None and depth == 1 and key == "properties":
            inside, after_key = -1, True
        elif inside is not None and inside > 0 and depth == inside and key not in out:
            out[key] = bisect.bisect_right(breaks, m.start()) + 1
    return out


def _writable_text(text: str, what: str, source: str, line: int | None = None) -> None:
    bad = unwritable(text)
    if bad:
        raise error(f"{what} holds the character {bad}, which MDL (XML) cannot carry", source, line)


def _text(prop: dict[str, Any], key: str, name: str, reader: _Reader) -> str | None:
    value = prop.get(key)
    if value is None:
        return None
    if not isinstance(value, str):
        reader.say(name, f"'{key}' is not a text: left out of the function")
        return None
    _writable_text(value, f"property {shown(name)}: '{key}'", reader.path, reader.lines.get(name))
    return value


def _number(value: Any) -> float | None:
    """A JSON number as a float (None for anything else, booleans and what a double cannot hold included)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        x = float(value)
    except OverflowError:
        return None
    return x if math.isfinite(x) else None


def _integer(value: Any, low: int, high: int) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, str) and value.strip().isdigit() and len(value.strip()) < 8:
        value = int(value.strip())
    return value if isinstance(value, int) and low <= value <= high else None


def _term(form: dict[str, Any], name: str) -> Any:
    """A binding term of the form, under the `modv:` prefix or the older `modbus:`."""
    return form.get(f"modv:{name}", form.get(f"modbus:{name}"))


@dataclass
class _Form:
    table: str
    address: int
    quantity: int | None
    media: str
    params: dict[str, str]
    msb: Any
    msw: Any


def _modbus_form(name: str, prop: dict[str, Any], base: str | None, reader: _Reader) -> _Form:
    forms = prop.get("forms")
    if not isinstance(forms, list) or not forms:
        raise _LeftOut("no forms")
    chosen = None
    others = []
    for form in forms:
        href = form.get("href") if isinstance(form, dict) else None
        if not isinstance(href, str):
            continue
        try:
            href = _joined(base, href) if base else href
            scheme = urlsplit(href).scheme.lower()
        except ValueError:
            continue
        if scheme == v.SCHEME and chosen is None:
            chosen = (form, href)
        elif scheme != v.SCHEME:
            others.append(scheme or "no scheme")
    if chosen is None:
        raise _LeftOut(f"no Modbus form (forms of {', '.join(sorted(set(others))) or 'no href'})")
    if others:
        reader.say(name, f"its forms other than Modbus ({', '.join(sorted(set(others)))}) are not part of MDL")
    form, href = chosen
    return _parse_form(name, form, href, reader)


def _joined(base: str, href: str) -> str:
    """`href` relative to the TD's `base` (urljoin joins only the schemes it knows: as http, then back)."""
    if urlsplit(href).scheme:
        return href
    scheme = urlsplit(base).scheme
    if not scheme:
        return urljoin(base, href)
    return scheme + urljoin("http" + base[len(scheme) :], href)[len("http") :]


def _parse_form(name: str, form: dict[str, Any], href: str, reader: _Reader) -> _Form:
    try:
        parts = urlsplit(href)
        host = parts.hostname or ""
    except ValueError as exc:
        raise _LeftOut(f"its href is not a URL ({exc})") from None
    try:
        port: int | None = parts.port
    except ValueError:  # a Thing Model's {{PORT}}
        port = None
    path = [p for p in parts.path.split("/")]
    unit = _integer(path[1], 0, 255) if len(path) > 1 and path[1] else _integer(_term(form, "unitID"), 0, 255)
    address: Any = path[2] if len(path) > 2 and path[2] else _term(form, "address")
    address = _integer(address, 0, 2**31)
    if address is None:
        raise _LeftOut("its form has no address (the href's path /UNIT/ADDRESS, or modv:address) MDL can hold")
    if _term(form, "zeroBasedAddressing") is False:
        if address == 0:
            raise _LeftOut("address 0 counted from 1 (modv:zeroBasedAddressing false)")
        address -= 1
    if address > MAX_ADDRESS:
        raise _LeftOut(f"address {address} is over {MAX_ADDRESS}")
    quantity: Any = None
    try:
        query = parse_qs(parts.query)
    except ValueError:
        query = {}
    if query.get("quantity"):
        quantity = query["quantity"][0]
    elif _term(form, "quantity") is not None:
        quantity = _term(form, "quantity")
    if quantity is not None:
        quantity = _integer(quantity, 1, MAX_BITS)
        if quantity is None:
            raise _LeftOut("its quantity is not a number of registers or coils MDL can hold")
    table = _table(form)
    if not reader.connections and "{{" not in href:
        where = f"{host}:{port}" if port is not None else host
        reader.connections.append(f"modbus+tcp://{where} unit {unit if unit is not None else '?'}")
    content = form.get("contentType")
    content = content if isinstance(content, str) else ""
    media, *pieces = content.split(";") if content else ["", *()]
    params: dict[str, str] = {}
    for piece in pieces:
        key, eq, value = piece.partition("=")
        if eq:
            params[key.strip()] = value.strip()
    return _Form(
        table,
        address,
        quantity,
        media.strip().lower(),
        params,
        _term(form, "mostSignificantByte"),
        _term(form, "mostSignificantWord"),
    )


def _table(form: dict[str, Any]) -> str:
    entity = _term(form, "entity")
    if isinstance(entity, str) and entity in v.TABLES:
        return v.TABLES[entity]
    function = _term(form, "function")
    if isinstance(function, (str, int)) and not isinstance(function, bool) and function in v.FUNCTION_TABLES:
        return v.FUNCTION_TABLES[function]
    said = entity if entity is not None else function
    what = f" ({_what(said)})" if said is not None else ""
    raise _LeftOut(f"its form names no Modbus table MDL knows (modv:entity or modv:function{what})")


def _orders(seq: str | None, form: _Form, n: int) -> tuple[str, str]:
    """(byte order, word order) of a value of n registers, as node-wot's codec reads it."""
    if seq is None:
        byte = "big" if form.msb is not False else "little"
        word = "big" if form.msw is not False else "little"
        return byte, word if n > 1 else "big"
    byte, word = v.ORDERS[seq]
    if n == 1:  # one register: LITTLE_ENDIAN reverses its two bytes as a byte swap does; both cancel out
        return ("little" if (byte == "little") != (word == "little") else "big"), "big"
    return byte, word


def _function(name: str, prop: Any, base: str | None, reader: _Reader) -> Function:
    if not isinstance(name, str) or not name.strip():
        raise _LeftOut("an empty name")
    _writable_text(name, f"the property name {shown(name)}", reader.path, reader.lines.get(name))
    if not isinstance(prop, dict):
        raise _LeftOut("not an object")
    form = _modbus_form(name, prop, base, reader)
    fn = Function(name, "", [form.address], line=reader.lines.get(name))
    fn.description = _text(prop, "description", name, reader) or _text(prop, "title", name, reader) or ""
    kind = prop.get("type")
    if form.table in ("coil", "discrete"):
        _bit_table(fn, form, kind, name, reader)
    else:
        _registers(fn, form, prop, kind, name)
    _access(fn, prop, name, reader)
    fn.units = _text(prop, "unit", name, reader)
    _terms(fn, prop, name, reader)
    _limits(fn, prop, name, reader)
    _labels(fn, prop, kind, name, reader)
    return fn


def _bit_table(fn: Function, form: _Form, kind: Any, name: str, reader: _Reader) -> None:
    if form.quantity not in (None, 1):
        raise _LeftOut(f"{form.quantity} {form.table}s as one value (MDL: one bit a function)")
    if kind != "boolean":
        reader.say(name, f"a {form.table} is read as true or false, not as {_what(kind)}")
    fn.format = "BIT"
    fn.register_type = form.table


def _registers(fn: Function, form: _Form, prop: dict[str, Any], kind: Any, name: str) -> None:
    if form.media not in ("", v.OCTETS):
        raise _LeftOut(f"content type {form.media[:40]}: mdl reads registers as octets (application/octet-stream)")
    length = _integer(form.params.get("length"), 1, 2 * MAX_REGISTERS) if "length" in form.params else None
    if "length" in form.params and length is None:
        raise _LeftOut(f"length {form.params['length'][:20]} is not a number of bytes of registers")
    n = form.quantity if form.quantity is not None else (-(-length // 2) if length is not None else 1)
    if n > MAX_REGISTERS:
        raise _LeftOut(f"{n} registers: one request reads at most {MAX_REGISTERS}")
    if length is not None and length != 2 * n:
        raise _LeftOut(f"{length} bytes of {n} registers (node-wot refuses them: 2 a register)")
    seq = form.params.get("byteSeq")
    if seq is not None and seq not in _BYTE_SEQS:
        raise _LeftOut(f"byteSeq {seq[:30]} (node-wot knows {', '.join(_BYTE_SEQS)})")
    signed = form.params.get("signed", "true")
    if signed not in ("true", "false"):
        raise _LeftOut(f"signed={signed[:20]} (true or false)")
    if form.table != "holding":
        fn.register_type = form.table
    pick = _pick(prop)
    if pick is not None:
        _byte(fn, pick, seq, kind, signed, n)
        return
    byte, word = _orders(seq, form, n)
    if kind == "boolean":
        if n != 1:
            raise _LeftOut(f"true or false in {n} registers (MDL: a BIT is one register)")
        fn.format = "BIT"
        return
    if kind == "string":
        # node-wot swaps each register's bytes for *_BYTE_SWAP and never reverses the words of a text
        fn.format, fn.count = "STRING", n
        if seq is not None and seq.endswith("BYTE_SWAP") or (seq is None and form.msb is False):
            fn.byte_order = "little"
        return
    if kind == "number":
        if n not in (2, 4):
            raise _LeftOut(f"a {16 * n}-bit float (MDL: FLOAT32 and FLOAT64; node-wot reads 2 bytes as a half float)")
        fn.format = f"FLOAT{16 * n}"
    elif kind == "integer":
        if n > 4:
            raise _LeftOut(f"a {16 * n}-bit integer (MDL: at most 64 bits)")
        sign = "" if signed == "true" else "U"
        fn.format = f"{sign}INT{16 * n}" if n in (1, 2, 4) else f"{sign}INT16"
        if n == 3:
            fn.count = 3
    else:
        raise _LeftOut(f"type {_what(kind)} (MDL reads boolean, integer, number and string)")
    if byte == "little":
        fn.byte_order = "little"
    if word == "little" and n > 1:
        fn.word_order = "little"


def _pick(prop: dict[str, Any]) -> tuple[int, int] | None:
    if v.BIT_OFFSET not in prop and v.BIT_LENGTH not in prop:
        return None
    offset = _integer(prop.get(v.BIT_OFFSET, 0), 0, 16 * MAX_REGISTERS)
    length = _integer(prop.get(v.BIT_LENGTH), 0, 16 * MAX_REGISTERS)
    if offset is None or length is None:
        raise _LeftOut("ex:bitOffset and ex:bitLength are not numbers of bits")
    return offset, length


def _byte(fn: Function, pick: tuple[int, int], seq: str | None, kind: Any, signed: str, n: int) -> None:
    """One byte of one register (ex:bitOffset 0 or 8, ex:bitLength 8): node-wot swaps the register's bytes
    for *_BYTE_SWAP before it picks one."""
    offset, length = pick
    if n != 1 or length != 8 or offset not in (0, 8):
        raise _LeftOut(f"bits {offset}..{offset + length - 1} of {n} registers (MDL: a byte of one register)")
    first = (offset == 0) != (seq is not None and seq.endswith("BYTE_SWAP"))
    fn.length = "Upper byte" if first else "Lower byte"
    if kind == "string":
        fn.format = "STRING"
    elif kind == "integer":
        fn.format = "INT8" if signed == "true" else "UINT8"
    else:
        raise _LeftOut(f"a byte of type {_what(kind)} (MDL: an integer or a text)")


def _access(fn: Function, prop: dict[str, Any], name: str, reader: _Reader) -> None:
    read_only = prop.get("readOnly") is True
    write_only = prop.get("writeOnly") is True
    if read_only and write_only:
        raise _LeftOut("both readOnly and writeOnly")
    if fn.table in ("input", "discrete"):
        if not read_only:
            reader.say(name, f"a {fn.table} register cannot be written: read-only")
        if write_only:
            raise _LeftOut(f"a write-only {fn.table}")
        return
    if read_only:
        fn.access = "read"
    elif write_only:
        fn.access = "write"


def _terms(fn: Function, prop: dict[str, Any], name: str, reader: _Reader) -> None:
    for term, attr in ((v.MULTIPLIER, "multiplier"), (v.OFFSET, "offset")):
        if term in prop:
            x = _number(prop[term])
            if x is None or (attr == "multiplier" and x == 0.0):
                raise _LeftOut(f"{term} is not a number MDL can hold")
            setattr(fn, attr, x)
    if v.BITS in prop:
        bits = prop[v.BITS]
        text = str(bits) if isinstance(bits, int) and not isinstance(bits, bool) else bits
        if not isinstance(text, str) or parse_bits(text) is None:
            raise _LeftOut(f"{v.BITS} is not N or N-M")
        fn.bits = text
    for term, attr in ((v.SCALE_EXPONENT, "scale_exponent"), (v.SCALE_BY, "scale_by")):
        if term in prop:
            other = prop[term]
            if not isinstance(other, str) or not other:
                raise _LeftOut(f"{term} is not a property's name")
            _writable_text(other, f"property {shown(name)}: {term}", reader.path, reader.lines.get(name))
            setattr(fn, attr, other)
    if v.NOT_IMPLEMENTED in prop:
        values = prop[v.NOT_IMPLEMENTED]
        if (
            not isinstance(values, list)
            or not values
            or not all(isinstance(x, str) and _HEX.fullmatch(x) for x in values)
        ):
            raise _LeftOut(f"{v.NOT_IMPLEMENTED} is not a list of hex register values (0xFFFF)")
        fn.not_implemented = list(values)


def _described(fn: Function, raw: float) -> float:
    """A register value as the description's value: mdl's rule (divide where the multiplier is 1/d)."""
    m = fn.eff_multiplier
    d = divisor_of(m)
    x = raw / d if d is not None else (raw * m if m != 1.0 else raw)
    return x + fn.offset if fn.offset else x


def _limits(fn: Function, prop: dict[str, Any], name: str, reader: _Reader) -> None:
    limits = {key: prop[key] for key in ("minimum", "maximum") if key in prop}
    if not limits:
        return
    if fn.bits is not None or fn.factor is not None or fn.format in ("BIT", "STRING"):
        reader.say(name, "minimum and maximum of its register value are not part of MDL")
        return
    found = {}
    for key, value in limits.items():
        x = _number(value)
        if x is None:
            reader.say(name, f"{key} is not a number: left out of the function")
            continue
        found[key] = _described(fn, x)
    if fn.eff_multiplier < 0:
        found = {"minimum" if key == "maximum" else "maximum": x for key, x in found.items()}
    fn.minimum, fn.maximum = found.get("minimum"), found.get("maximum")


def _labels(fn: Function, prop: dict[str, Any], kind: Any, name: str, reader: _Reader) -> None:
    enum, one_of = prop.get("enum"), prop.get("oneOf")
    if enum is None and one_of is None:
        return
    if fn.scales or fn.bits is not None or fn.factor is not None:
        reader.say(name, "labels of its register value are not part of MDL")
        return
    labels: dict[int, str] = {}
    for item in one_of if isinstance(one_of, list) else []:
        if isinstance(item, dict) and "const" in item and isinstance(item.get("title"), str):
            key = _label_key(item["const"])
            if key is not None and key not in labels:
                _writable_text(item["title"], f"property {shown(name)}: a label", reader.path)
                labels[key] = item["title"]
    for value in enum if isinstance(enum, list) else []:
        key = _label_key(value)
        if key is not None and key not in labels:
            labels[key] = str(value).lower() if isinstance(value, bool) else str(value)
    if not labels or kind == "string":
        reader.say(name, "an enumeration of values other than integers is not part of MDL")
        return
    fn.values = labels


def _label_key(value: Any) -> int | None:
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**63:
        return int(value)
    return value if isinstance(value, int) and -(2**63) <= value < 2**64 else None
