"""`mdl export --to wot`: a W3C Web of Things Thing Description (TD 1.1, JSON-LD) of the device instance,
or with `--tm` the Thing Model of its type (SPEC 11.1; docs/wot.md).

One property per function, named after it (or after its role: `--names roles`), with one form in the
Modbus binding's words: `href` `modbus+tcp://HOST:PORT/UNIT/ADDRESS?quantity=N` (the port always written:
node-wot's default is not 502), `modv:entity` (node-wot 0.8 refuses `modv:function`), `modv:unitID`,
`modv:address`, `modv:quantity`, `modv:type`, `modv:mostSignificantByte`/`Word`, `modv:pollingTime`
(--interval, in ms) and `modv:timeout`. node-wot decodes from the property's `type` and the form's
`contentType` alone (`application/octet-stream;length=BYTES;signed=...;byteSeq=...`), so those say the
value as the registers hold it: a scaled integer is an `integer` (a 2-byte `number` is a half float to
node-wot) and the scale goes to `mdl:` terms (`mdl:multiplier`, `mdl:offset`, `mdl:bits`,
`mdl:scaleExponent`, `mdl:scaleBy`, `mdl:notImplemented`), with the limits as register values (node-wot
checks every value it reads against the schema). What neither the binding nor node-wot can say or do is one
warning per kind (base.Notes). The document is built as data and written by json.dumps (json_text): no
text of a description becomes JSON of its own.

With --tm the connection is placeholders (`{{HOST}}`, `{{PORT}}`, `{{UNIT_ID}}`, `{{POLLING_TIME}}`,
`{{TIMEOUT}}`), `@type` `tm:ThingModel`. With --profile (and --names roles) the document links the
profile's Thing Model (`mdl profiles NAME --as tm`, mdl.exports.wot_tm) as its type.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any
from urllib.parse import quote

from mdl.exchange.connection import Endpoint, host_port
from mdl.exchange.export import Export
from mdl.exchange.text import json_text
from mdl.exports.base import (
    Notes,
    bits_detail,
    connection_of,
    factor_detail,
    hex_pattern,
    left_out_unreadable,
    nothing_left,
    patterns_of,
    plain_number,
    scale_of,
    written_by_fragment,
)
from mdl.formats.wot import vocabulary as v

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.resolver import ResolvedDevice, ResolvedFunction

ENGINE = "WoT"
Json = dict[str, Any]
SECURITY = {"securityDefinitions": {"nosec_sc": {"scheme": "nosec"}}, "security": "nosec_sc"}

# the kinds of loss (docs/wot.md, "Warnings")
NEITHER = "neither readable nor writable: left out"
TEXT_WORDS = "text with its registers in little-endian word order, which node-wot reads in register order: left out"
WIDE = "node-wot reads integers of up to 48 bits (JavaScript numbers), not this one (the TD still says it)"
WIDE_WRITE = "node-wot's encoder writes integers of up to 32 bits: a write of a wider one fails or is wrong"
SCALED = (
    "the binding has no scale: the property is the register value, and mdl:multiplier and mdl:offset make it the "
    "description's (raw x multiplier + offset)"
)
FACTOR = (
    "the binding has no scale register: the property is the register value, and mdl:scaleExponent or mdl:scaleBy "
    "names the property whose value scales it"
)
BITS = (
    "the binding reads whole registers: the property is the register value, and mdl:bits says which of its bits "
    "hold the description's value"
)
BYTE = (
    "one byte of a register: node-wot's codec terms ex:bitOffset and ex:bitLength pick it out; a consumer without "
    "them reads the whole register"
)
NOT_IMPLEMENTED = (
    "the binding has no 'not implemented' value: the register values that mean it read as numbers "
    "(mdl:notImplemented lists them)"
)
TEXT_PADDING = "node-wot's text keeps the NUL padding and trailing spaces mdl strips"
TEXT_WRITE = "node-wot writes a text only of exactly the registers' length (mdl pads a shorter one with NULs)"
BOOL_WRITE = "node-wot writes true into a register as 0xFFFF, where mdl writes 1"
SWAPPED_WRITE = (
    "node-wot's encoder ignores the byte swap of byteSeq when it writes several registers: a write through "
    "node-wot puts the bytes in the wrong order (reads are right)"
)
SINGLE_WRITE = "node-wot writes one register with function 6 and one coil with 5, where the description says 16 or 15"
BITS_WRITE = "a write through node-wot sets the whole register, where mdl changes only the function's bits"
BYTE_WRITE = (
    "node-wot writes a value of the register's first byte into its second (its encoder places ex:bitOffset 0 "
    "in the low byte): a write through node-wot is wrong"
)
FRAGMENT_WRITE = "a write fragment encodes it, which the binding cannot: not writable here (write-only: left out)"
LIMITS_RAW = (
    "its minimum and maximum bound the description's value, not the register value the property holds: left out"
)
LABELS_RAW = "its labels name the description's value, not the register value the property holds: left out"
LABELS_BOOL = "labels of a true/false value other than one for each of 0 and 1: left out"
LABELS_TEXT = "labels of a text: left out"
LIMITS_READ = "node-wot refuses to read a value outside minimum/maximum, which bound only writes in MDL (mdl reads it)"
LABELS_READ = "node-wot refuses to read a value its enumeration does not list (mdl reads it as a number)"


@dataclass(frozen=True)
class _Where:
    """What the forms say of where the device is: values (a TD) or placeholders (a Thing Model)."""

    authority: str  # HOST:PORT in the href
    unit: int | str
    polling: int | str  # ms
    timeout: int | str  # ms


def _instance(settings: Settings, notes: Notes) -> _Where:
    conn = connection_of(settings, notes)
    if conn.serial is not None:
        gateway = Endpoint()
        notes.device_warning(
            f"the Modbus binding is TCP only: the serial line {conn} cannot be named; the forms name "
            f"modbus+tcp://{host_port(gateway.host, gateway.port)} (a Modbus TCP gateway to the line: give --host)"
        )
        conn = gateway
    elif conn.rtu:
        notes.device_warning(
            "the Modbus binding sends Modbus TCP frames, not RTU over TCP: the forms name "
            f"{host_port(conn.host, conn.port)} as a Modbus TCP server"
        )
    host = quote(conn.host, safe="-._~!$&'()*+,;=:")  # a host name as it may stand in a URL
    if host != conn.host:
        notes.note(f"the host is percent-encoded in the hrefs: {host}")
    authority = f"[{host}]:{conn.port}" if ":" in host else f"{host}:{conn.port}"
    return _Where(authority, settings.unit, max(1, round(settings.interval * 1000)), round(conn.timeout * 1000))


def _model(settings: Settings, notes: Notes) -> _Where:
    if settings.connection is not None or settings.interval_given:
        notes.note(
            "a Thing Model names no connection: the connection options, --unit and --interval fill its "
            "placeholders when a TD is made of it"
        )
    host, port, unit, polling, timeout = map(v.placeholder, v.PLACEHOLDERS)
    return _Where(f"{host}:{port}", unit, polling, timeout)


@dataclass
class _Wire:
    """How the binding and node-wot read a function: the JSON type, the payload and its codec parameters."""

    type: str
    length: int  # bytes of the payload
    xsd: str
    signed: bool | None = None  # the codec's `signed` parameter (integers only)
    byte_seq: str | None = None
    msb: bool | None = None  # modv:mostSignificantByte
    msw: bool | None = None  # modv:mostSignificantWord (several registers)
    pick: tuple[int, int] | None = None  # (ex:bitOffset, ex:bitLength): one byte of the register


def _wire(f: ResolvedFunction, notes: Notes) -> _Wire | None:
    """How the function is read, or None (left out, warned)."""
    lay = f.layout
    n = len(lay.addresses)
    if lay.unit == "bit":
        return _Wire("boolean", 1, "xsd:boolean")
    if lay.kind == "bool":
        return _Wire("boolean", 2, "xsd:boolean")
    if lay.unit in ("low", "high") or (lay.unit == "word" and n == 1 and lay.bits == 8):
        first = lay.unit == "high" or (lay.unit == "word" and lay.byte_order == "little")
        notes.warn(f, BYTE)
        if lay.kind == "string":
            return _Wire("string", 2, "xsd:string", pick=(0 if first else 8, 8))
        return _Wire("integer", 2, v.XSD_INTEGERS[(8, lay.signed)], lay.signed, pick=(0 if first else 8, 8))
    words = lay.word_order if n > 1 else "big"
    seq = v.BYTE_SEQ[(lay.byte_order, words)]
    msw = lay.word_order == "big" if n > 1 else None
    msb = lay.byte_order == "big"
    if lay.kind == "string":
        if words == "little":
            notes.warn(f, TEXT_WORDS)
            return None
        return _Wire("string", 2 * n, "xsd:string", byte_seq=seq, msb=msb, msw=msw)
    if lay.kind == "float":
        return _Wire("number", 2 * n, v.XSD_FLOATS[lay.bits], byte_seq=seq, msb=msb, msw=msw)
    if lay.bits > v.SAFE_BITS:
        notes.warn(f, WIDE, f"{lay.bits} bits")
    xsd = v.XSD_INTEGERS.get((lay.bits, lay.signed)) or v.XSD_INTEGERS[(64, lay.signed)]
    return _Wire("integer", 2 * n, xsd, lay.signed, seq, msb, msw)


def _content_type(wire: _Wire) -> str:
    parts = [v.OCTETS, f"length={wire.length}"]
    if wire.signed is not None:
        parts.append(f"signed={'true' if wire.signed else 'false'}")
    if wire.byte_seq is not None:
        parts.append(f"byteSeq={wire.byte_seq}")
    return ";".join(parts)


def _raw_terms(f: ResolvedFunction, notes: Notes) -> Json:
    """The mdl: terms that make the description's value of the register value, each said once per kind."""
    fn = f.fn
    terms: Json = {}
    span = fn.bit_range
    if fn.bits is not None and span is not None and f.layout.kind == "int":
        terms[v.BITS] = f"{span[0]}" if span[0] == span[1] else f"{span[0]}-{span[1]}"
        notes.warn(f, BITS, bits_detail(fn))
    if fn.eff_multiplier != 1.0:
        terms[v.MULTIPLIER] = fn.eff_multiplier
    if fn.eff_offset != 0.0:
        terms[v.OFFSET] = fn.eff_offset
    if fn.factor is not None:
        terms[v.SCALE_EXPONENT if fn.scale_exponent is not None else v.SCALE_BY] = fn.factor
        notes.warn(f, FACTOR, factor_detail(fn))
    elif fn.scales and f.layout.kind in ("int", "float"):
        said = [f"multiplier {plain_number(fn.eff_multiplier)}"] if fn.eff_multiplier != 1.0 else []
        said += [f"offset {plain_number(fn.eff_offset)}"] if fn.eff_offset != 0.0 else []
        notes.warn(f, SCALED, ", ".join(said))
    patterns = patterns_of(f)
    if patterns and fn.not_implemented:
        terms[v.NOT_IMPLEMENTED] = list(fn.not_implemented)
        notes.warn(f, NOT_IMPLEMENTED, ", ".join(map(hex_pattern, patterns)))
    return terms


_NEAR = 1e-9  # a register value this close to an integer (relative) is that integer: 4.999999999999999 is 5


def _register_value(f: ResolvedFunction, value: float, integer: bool, low: bool) -> int | float:
    """A limit of the description's value as the register value that gives it (an integer limit rounded
    inwards, so that the same register values are in range)."""
    step = scale_of(f)
    x = float(value)
    if step is not None:
        x -= step.offset
        x = x * step.divisor if step.divisor is not None else x / step.multiplier
    if not integer:
        return x
    nearest = round(x)
    if abs(x - nearest) <= _NEAR * max(1.0, abs(x)):
        return int(nearest)
    return int(-(-x // 1)) if low else int(x // 1)


def _limits(f: ResolvedFunction, wire: _Wire, terms: Json, notes: Notes) -> Json:
    fn = f.fn
    if (fn.minimum is None and fn.maximum is None) or wire.type in ("boolean", "string"):
        return {}
    if v.BITS in terms or fn.factor is not None:
        notes.warn(f, LIMITS_RAW)
        return {}
    integer = wire.type == "integer"
    step = scale_of(f)
    flipped = step is not None and step.divisor is None and step.multiplier < 0
    low, high = (fn.maximum, fn.minimum) if flipped else (fn.minimum, fn.maximum)
    out: Json = {}
    if low is not None:
        out["minimum"] = _register_value(f, low, integer, True)
    if high is not None:
        out["maximum"] = _register_value(f, high, integer, False)
    if fn.readable:
        notes.warn(f, LIMITS_READ)
    return out


def _labels(f: ResolvedFunction, wire: _Wire, terms: Json, notes: Notes) -> Json:
    values = f.fn.values
    if not values:
        return {}
    if any(term in terms for term in (v.BITS, v.MULTIPLIER, v.OFFSET, v.SCALE_EXPONENT, v.SCALE_BY)):
        notes.warn(f, LABELS_RAW)
        return {}
    if wire.type == "string":
        notes.warn(f, LABELS_TEXT)
        return {}
    if wire.type == "boolean":
        if sorted(values) != [0, 1]:
            notes.warn(f, LABELS_BOOL)
            return {}
        keys: list[Any] = [bool(key) for key in values]
    else:
        keys = list(values)
    if f.fn.readable and wire.type != "boolean":
        notes.warn(f, LABELS_READ)
    labels = [{"const": key, "title": label} for key, label in zip(keys, values.values(), strict=True)]
    return {"enum": keys, "oneOf": labels}


def _writes(f: ResolvedFunction, wire: _Wire, terms: Json, notes: Notes) -> bool:
    """Whether the property is writable, each way node-wot writes it other than mdl said."""
    if not f.fn.writable:
        return False
    if written_by_fragment(f):
        notes.warn(f, FRAGMENT_WRITE)
        return False
    lay = f.layout
    n = len(lay.addresses)
    if v.BITS in terms:
        notes.warn(f, BITS_WRITE, bits_detail(f.fn))
    elif wire.pick is not None and wire.pick[0] == 0:
        notes.warn(f, BYTE_WRITE)
    if lay.kind == "bool" and lay.unit != "bit":
        notes.warn(f, BOOL_WRITE)
    if wire.type == "string" and wire.pick is None:
        notes.warn(f, TEXT_WRITE, f"{wire.length} bytes")
    if wire.type == "integer" and lay.bits > v.SAFE_WRITE_BITS:
        notes.warn(f, WIDE_WRITE, f"{lay.bits} bits")
    if n > 1 and wire.byte_seq is not None and wire.byte_seq.endswith("BYTE_SWAP"):
        notes.warn(f, SWAPPED_WRITE, f"byteSeq={wire.byte_seq}")
    if f.fn.write_multiple and n == 1:
        notes.warn(f, SINGLE_WRITE)
    return True


def _property(f: ResolvedFunction, where: _Where, notes: Notes) -> Json | None:
    fn = f.fn
    if not fn.readable and not fn.writable:
        notes.warn(f, NEITHER)
        return None
    if left_out_unreadable(f, notes):
        return None
    wire = _wire(f, notes)
    if wire is None:
        return None
    terms = _raw_terms(f, notes)
    writable = _writes(f, wire, terms, notes)
    if not fn.readable and not writable:
        return None  # write-only through a fragment: nothing left (warned)
    if wire.type == "string" and wire.pick is None and fn.readable:
        notes.warn(f, TEXT_PADDING)
    prop: Json = {}
    if fn.description:
        prop["description"] = fn.description
    prop["type"] = wire.type
    if fn.units:
        prop["unit"] = fn.units
    prop.update(_limits(f, wire, terms, notes))
    prop.update(_labels(f, wire, terms, notes))
    prop["readOnly"] = not writable
    if not fn.readable:
        prop["writeOnly"] = True
    else:
        prop["observable"] = True
    if wire.pick is not None:
        prop[v.BIT_OFFSET], prop[v.BIT_LENGTH] = wire.pick
    prop.update(terms)
    ops = (["readproperty"] if fn.readable else []) + (["writeproperty"] if writable else [])
    ops += ["observeproperty", "unobserveproperty"] if fn.readable else []
    address = f.layout.addresses[0]
    n = len(f.layout.addresses)
    form: Json = {
        "href": f"{v.SCHEME}://{where.authority}/{where.unit}/{address}?quantity={n}",
        "op": ops,
        "contentType": _content_type(wire),
        "modv:entity": v.ENTITIES[f.layout.table],
        "modv:unitID": where.unit,
        "modv:address": address,
        "modv:quantity": n,
        "modv:type": wire.xsd,
    }
    if wire.msb is not None:
        form["modv:mostSignificantByte"] = wire.msb
    if wire.msw is not None:
        form["modv:mostSignificantWord"] = wire.msw
    form["modv:pollingTime"] = where.polling
    form["modv:timeout"] = where.timeout
    prop["forms"] = [form]
    return prop


def _links(settings: Settings) -> Json:
    if settings.profile is None:
        return {}
    from mdl.exports.wot_tm import profile_link
    from mdl.profiles.load import load_profile

    return {"links": [profile_link(load_profile(settings.profile))]}


def export_wot(resolved: ResolvedDevice, settings: Settings) -> Export:
    notes = Notes(resolved, ENGINE)
    where = _model(settings, notes) if settings.thing_model else _instance(settings, notes)
    properties: Json = {}
    for f in resolved.functions:
        prop = _property(f, where, notes)
        if prop is not None:
            properties[f.name] = prop
    if not properties:
        raise nothing_left(resolved, ENGINE, notes)
    doc: Json = {"@context": v.CONTEXT}
    if settings.thing_model:
        doc["@type"] = v.THING_MODEL
    doc["title"] = resolved.name
    if resolved.device.description:
        doc["description"] = resolved.device.description
    doc.update(_links(settings))
    doc.update(SECURITY)
    doc["properties"] = properties
    return Export(text=json_text(doc, 2), warnings=notes.found)
