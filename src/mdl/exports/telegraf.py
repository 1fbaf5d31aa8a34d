"""`mdl export --to telegraf`: Telegraf's `[[inputs.modbus]]` in the `request` configuration style (SPEC 11).

One `[[inputs.modbus.request]]` section per request of mdl's read plan (`ResolvedDevice.plan`), so that
Telegraf polls with mdl's coalescing: its fields are the functions the request carries, and an
`omit = true` field fills each register of the request no exported field reads (Telegraf splits a
section at any gap). Field names are the functions' identifiers (safe in Telegraf's glob filters); the
measurement is the device's stem, the plugin's `name` tag the device's name.

Per field: `type` (INT16 ... UINT64, FLOAT32/64, INT8L/H and UINT8L/H for one byte of a register,
STRING with `length` in registers; coils and discrete inputs take `output = "BOOL"`), `scale` for a
multiplier (Telegraf computes value * scale, as mdl does). A section has one `byte_order` (ABCD, DCBA,
BADC, CDAB: MDL's byte and word order); where the functions of one request need different ones, the
request becomes several sections.

mdl divides by d where a multiplier is exactly 1/d (0.1: / 10), and value * 0.1 can differ from value / 10
in the last digit: such a field has no `scale`, and a `[[processors.starlark]]` divides it (Telegraf
1.15+; Starlark's `/` on float(value) is the same IEEE division). Offsets go to `[[processors.scale]]`
(factor 1 and the offset: value + offset; Telegraf 1.27+), enumerations to `[[processors.enum]]`. A BIT
in a holding or input register (true when the register is not 0, where Telegraf's BIT type reads one
bit) is read as UINT16 and `[[processors.enum]]` maps 0 to false and every other value to true
(`default`). The processors run in that order (`order`), each limited to the measurement by
`namepass`. Telegraf only reads.

A function with one bit (`bits`, SPEC 2.2) is a BIT field of the register holding it, `bit` its place in the
register as the section's byte order gives it (type_conversions_bit.go: the 16-bit register converted,
then `v >> bit & 1`; Telegraf 1.32+, which the header then names); the 0 or 1 goes through the same
`[[processors.enum]]` mapping to false and true. A range of bits, and a value scaled by another register
(`scale_exponent`, `scale_by`), are left out with a warning: no field type or processor here reads them.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from mdl.diagnostics import error
from mdl.exchange.export import Export
from mdl.exchange.text import comment_text, toml_string
from mdl.exports.base import (
    Notes,
    bit_in_register,
    bits_detail,
    connection_of,
    factor_detail,
    hex_pattern,
    left_out_unreadable,
    nothing_left,
    patterns_of,
    plain_number,
    register_bit,
    scale_of,
)

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.model.layout import Layout
    from mdl.resolver import ResolvedDevice, ResolvedFunction

ENGINE = "Telegraf"
ORDERS = ("ABCD", "CDAB", "DCBA", "BADC")  # tried in this order for a section
_WORD_TYPES = {
    ("int", 16, True): "INT16",
    ("int", 16, False): "UINT16",
    ("int", 32, True): "INT32",
    ("int", 32, False): "UINT32",
    ("int", 64, True): "INT64",
    ("int", 64, False): "UINT64",
    ("float", 32, True): "FLOAT32",
    ("float", 64, True): "FLOAT64",
}
_BYTE_SWAPPED = ("DCBA", "BADC")  # the orders that read each register's bytes swapped
_ORDER_OF = {("big", "big"): "ABCD", ("little", "little"): "DCBA", ("little", "big"): "BADC", ("big", "little"): "CDAB"}


def field_type(lay: Layout, order: str) -> str | None:
    """The Telegraf type that reads the layout as mdl does in a section of `order`, or None."""
    n = len(lay.addresses)
    swapped = order in _BYTE_SWAPPED
    if lay.kind == "bool":  # a BIT in a register: the whole register, which processors.enum maps to a bool
        return "UINT16"
    if lay.unit in ("low", "high") or (n == 1 and lay.bits == 8):
        if order not in ("ABCD", "DCBA"):  # Telegraf's 8-bit types know these two only
            return None
        # which byte on the wire: low/high unit, or the lower byte after the byte order
        second = lay.unit == "low" or (lay.unit == "word" and lay.byte_order == "big")
        low = second != swapped  # DCBA reads the wire's first byte as the low one
        return f"{'' if lay.signed else 'U'}INT8{'L' if low else 'H'}"
    byte_swapped = lay.byte_order == "little"
    if lay.kind == "string":
        return "STRING" if swapped == byte_swapped else None
    if n == 1:
        name = _WORD_TYPES.get((lay.kind, lay.bits, lay.signed))
        return name if name and swapped == byte_swapped else None
    name = _WORD_TYPES.get((lay.kind, lay.bits, lay.signed))
    if name is None or lay.bits != 16 * n:
        return None
    return name if order == _ORDER_OF[(lay.byte_order, lay.word_order)] else None


def _type(f: ResolvedFunction, order: str) -> str | None:
    """The field type of a function (BIT for one bit of a register) in a section of `order`, or None."""
    return "BIT" if register_bit(f) is not None else field_type(f.layout, order)


def _bit_entry(f: ResolvedFunction, order: str) -> dict[str, object]:
    """The `bit` option of a BIT field: the bit's place in the register as `order` converts it."""
    found = register_bit(f)
    assert found is not None
    return {"bit": found[1] ^ 8 if order in _BYTE_SWAPPED else found[1]}


def _address(f: ResolvedFunction) -> int:
    """The field's address: the register holding a BIT field's bit, else the function's first."""
    found = register_bit(f)
    return found[0] if found is not None else f.layout.addresses[0]


def _registers(f: ResolvedFunction) -> tuple[int, ...]:
    return (_address(f),) if register_bit(f) is not None else f.layout.addresses


def _fits_somehow(f: ResolvedFunction) -> bool:
    return any(_type(f, order) is not None for order in ORDERS)


def _one_bit(f: ResolvedFunction) -> bool:
    """A BIT in a register read as a whole, or one bit of one: a 0/1 (or register) processors.enum makes a bool."""
    return bit_in_register(f) or register_bit(f) is not None


def _toml(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    return toml_string(str(value))


def _inline(entries: dict[str, object]) -> str:
    return "{ " + ", ".join(f"{key} = {_toml(value)}" for key, value in entries.items()) + " }"


def _exported(resolved: ResolvedDevice, notes: Notes) -> dict[str, ResolvedFunction]:
    """name -> function, for each function Telegraf reads as mdl does (the others warned)."""
    out = {}
    for f in resolved.functions:
        if not f.fn.readable:
            notes.warn(f, "write-only: Telegraf only reads: left out")
            continue
        if left_out_unreadable(f, notes):
            continue
        if f.fn.factor is not None:
            notes.warn(f, "no field or processor multiplies by another register's value: left out", factor_detail(f.fn))
            continue
        if f.fn.bits is not None and register_bit(f) is None:
            notes.warn(
                f, "a BIT field reads one bit, and no field type takes a range of them: left out", bits_detail(f.fn)
            )
            continue
        if not _fits_somehow(f):
            notes.warn(
                f,
                "no field type reads its value: left out",
                f"a {f.layout.bits}-bit {f.layout.kind} in {len(f.layout.addresses)} registers",
            )
            continue
        patterns = patterns_of(f)
        if patterns:
            notes.warn(
                f,
                "no 'not implemented' value: the values that mean it read as numbers",
                ", ".join(map(hex_pattern, patterns)),
            )
        if f.layout.kind == "string":
            notes.warn(f, "a STRING field ends at its first NUL and keeps trailing spaces, which mdl strips")
        out[f.name] = f
    return out


def _runs(functions: list[ResolvedFunction]) -> list[tuple[str, list[ResolvedFunction]]]:
    """The functions of one request (by address) in runs that one byte_order reads, each with its order."""
    runs: list[tuple[str, list[ResolvedFunction]]] = []
    for f in sorted(functions, key=lambda g: (_address(g), g.ident)):
        if runs:
            order, members = runs[-1]
            common = [o for o in ORDERS if all(_type(g, o) for g in (*members, f))]
            if common:
                runs[-1] = (common[0], [*members, f])
                continue
        runs.append((next(o for o in ORDERS if _type(f, o)), [f]))
    return runs


def _fields(order: str, members: list[ResolvedFunction], bits: bool) -> list[str]:
    lines = []
    covered: set[int] = set()
    for f in members:
        covered.update(_registers(f))
    start = min(covered)
    end = max(covered) + 1
    by_address: dict[int, list[ResolvedFunction]] = {}
    for f in members:
        by_address.setdefault(_address(f), []).append(f)
    for address in range(start, end):
        for f in by_address.get(address, []):
            entry: dict[str, object] = {"address": address, "name": f.ident}
            if bits:
                entry["output"] = "BOOL"
            else:
                entry["type"] = _type(f, order)
                if entry["type"] == "BIT":
                    entry.update(_bit_entry(f, order))
                if f.layout.kind == "string":
                    entry["length"] = len(f.layout.addresses)
                step = scale_of(f)
                if step is not None and step.divisor is None and step.multiplier != 1:
                    entry["scale"] = step.multiplier
            lines.append(_inline(entry))
        if address not in covered:
            lines.append(
                _inline(
                    {"address": address, "omit": True} if bits else {"address": address, "type": "UINT16", "omit": True}
                )
            )
    return lines


def _input(resolved: ResolvedDevice, settings: Settings, notes: Notes, exported: dict[str, ResolvedFunction]) -> str:
    conn = connection_of(settings, notes)
    out = ["[[inputs.modbus]]", f"  name = {_toml(settings.name or resolved.name)}"]
    if conn.serial is not None:
        out += [
            f"  controller = {_toml('file://' + conn.serial)}",
            f"  baud_rate = {conn.baud}",
            f"  data_bits = {conn.bytesize}",
            f"  parity = {_toml(conn.parity)}",
            f"  stop_bits = {conn.stopbits}",
            '  transmission_mode = "RTU"',
        ]
    else:
        host = f"[{conn.host}]" if ":" in conn.host else conn.host
        out.append(f"  controller = {_toml(f'tcp://{host}:{conn.port}')}")
        if conn.rtu:
            out.append('  transmission_mode = "RTUoverTCP"')
    out += [
        f"  slave_id = {settings.unit}",
        f"  timeout = {_toml(plain_number(conn.timeout) + 's')}",
        f"  interval = {_toml(plain_number(settings.interval) + 's')}",
        '  configuration_type = "request"',
    ]
    if settings.name is not None or settings.tags:  # a fleet's device: its id and its inventory tags
        out += ["", "  [inputs.modbus.tags]"]
        tags = (("device", settings.name), *settings.tags) if settings.name is not None else settings.tags
        out += [f"    {toml_string(key)} = {_toml(value)}" for key, value in tags]
    for group in resolved.plan:
        request = group.request
        members = [exported[name] for name in request.functions if name in exported]
        if not members:
            continue
        bits = request.table in ("coil", "discrete")
        for order, run in _runs(members):
            out += [
                "",
                "  [[inputs.modbus.request]]",
                f"    slave_id = {settings.unit}",
                f"    register = {_toml(request.table)}",
                f"    byte_order = {_toml(order)}",
                f"    measurement = {_toml(resolved.stem)}",
                "    fields = [",
            ]
            out += [f"      {line}," for line in _fields(order, run, bits)]
            out.append("    ]")
    return "\n".join(out) + "\n"


_STARLARK = """
DIVISORS = {{
{divisors}
}}

def apply(metric):
    for name, divisor in DIVISORS.items():
        value = metric.fields.get(name)
        if value != None:
            metric.fields[name] = float(value) / divisor
    return metric
"""


def _processors(resolved: ResolvedDevice, exported: dict[str, ResolvedFunction]) -> str:
    out = []
    order = 0
    measurement = _toml(resolved.stem)
    divisors = {
        f.ident: step.divisor
        for f in exported.values()
        if (step := scale_of(f)) is not None and step.divisor is not None
    }
    if divisors:
        order += 1
        listed = "\n".join(f"    {_toml(ident)}: {divisor}," for ident, divisor in divisors.items())
        out += [
            "",
            "# the divisions: value / d where the multiplier is 1/d, as mdl computes them (value * 0.1 can",
            "# differ from value / 10 in the last digit)",
            "[[processors.starlark]]",
            f"  order = {order}",
            f"  namepass = [{measurement}]",
            "  source = '''" + _STARLARK.format(divisors=listed) + "'''",
        ]
    offsets: dict[float, list[str]] = {}
    for f in exported.values():
        step = scale_of(f)
        if step is not None and step.offset != 0:
            offsets.setdefault(step.offset, []).append(f.ident)
    if offsets:
        order += 1
        out += [
            "",
            "# the offsets: value * factor + offset, after the fields' scale and the divisions",
            "[[processors.scale]]",
            f"  order = {order}",
            f"  namepass = [{measurement}]",
        ]
        for offset, idents in offsets.items():
            out += [
                "  [[processors.scale.scaling]]",
                "    factor = 1.0",
                f"    offset = {_toml(float(offset))}",
                f"    fields = [{', '.join(map(_toml, idents))}]",
            ]
    bits = [f for f in exported.values() if _one_bit(f)]
    enums = [f for f in exported.values() if f.fn.values and not _one_bit(f)]
    if bits or enums:
        order += 1
        what = ["the label for each value"] if enums else []
        what += ["a bit in a register: 0 is false, any other value true"] if bits else []
        out += [
            "",
            f"# the enumerations: {'; '.join(what)}",
            "[[processors.enum]]",
            f"  order = {order}",
            f"  namepass = [{measurement}]",
        ]
        for f in bits:
            out += [
                "  [[processors.enum.mapping]]",
                f"    field = {_toml(f.ident)}",
                "    default = true",
                "    [processors.enum.mapping.value_mappings]",
                '      "0" = false',
            ]
        for f in enums:
            assert f.fn.values is not None
            out += [
                "  [[processors.enum.mapping]]",
                f"    field = {_toml(f.ident)}",
                "    [processors.enum.mapping.value_mappings]",
            ]
            out += [f"      {_toml(str(key))} = {_toml(label)}" for key, label in f.fn.values.items()]
    return "\n".join(out) + ("\n" if out else "")


def _version(exported: dict[str, ResolvedFunction]) -> str:
    """The oldest Telegraf that reads every field: 1.32 for a BIT field (influxdata/telegraf#15648), else 1.30."""
    return "1.32" if any(register_bit(f) is not None for f in exported.values()) else "1.30"


def _mqtt_output(url_text: str, stem: str | None) -> str:
    """`[[outputs.mqtt]]` of a `--publish mqtt[s]://...` URL: the agent's metrics to the broker, one message a
    metric in Telegraf's json format (name, tags, fields, timestamp), QoS 1 as `mdl read --publish` sends, at
    PREFIX/STEM for one device, and for a fleet's agent at PREFIX/DEVICE (its `device` tag, `stem` None).
    keep_alive: Mosquitto 2.0.12 and later refuse a client that gives none."""
    from mdl.device.fleet.mqtt import parse_url
    from mdl.device.fleet.run import redacted

    try:
        url = parse_url(url_text)
    except ValueError as exc:
        raise error(f"--publish {redacted(url_text)!r}: {exc}") from None
    scheme = "mqtts" if url.tls else "mqtt"
    topic = f"{url.prefix}/{stem}" if stem is not None else url.prefix + '/{{ .Tag "device" }}'
    out = [
        "",
        "[[outputs.mqtt]]",
        "  ## mdl export --publish: every metric of this agent to the broker, one JSON message each",
        f"  servers = [{toml_string(f'{scheme}://{url.host}:{url.port}')}]",
        f"  topic = {toml_string(topic)}",
        "  qos = 1",
        "  keep_alive = 30",
        '  data_format = "json"',
    ]
    if url.username is not None:
        out.append(f"  username = {toml_string(url.username)}")
    if url.password is not None:
        out.append(f"  password = {toml_string(url.password)}")
    return "\n".join(out) + "\n"


def export_telegraf_fleet(parts: list[tuple[ResolvedDevice, Settings]]) -> Export:
    """One agent's configuration for several devices (an inventory's shard): each device's input as the
    single export gives it, named after its id and tagged, and each kind's processors once (a processor
    per device of a kind would apply twice to every metric of its measurement)."""
    inputs: list[str] = []
    processors: list[str] = []
    kinds: dict[str, ResolvedDevice] = {}
    warnings = []
    for resolved, settings in parts:
        notes = Notes(resolved, ENGINE)
        exported = _exported(resolved, notes)
        if not exported:
            raise nothing_left(resolved, ENGINE, notes)
        inputs.append(_input(resolved, settings, notes, exported))
        known = kinds.setdefault(resolved.stem, resolved)
        if known is resolved and len(kinds) > len(processors):
            processors.append(_processors(resolved, exported))
        elif known.device.source != resolved.device.source:
            raise error(
                f"two descriptions are the measurement {resolved.stem!r} ({known.device.source}, "
                f"{resolved.device.source}): their files need other names"
            )
        warnings += [w for w in notes.found if w not in warnings]
    head = "# Telegraf modbus inputs of a fleet's shard (mdl export --inventory): one per device.\n"
    publish = parts[0][1].publish if parts else None
    output = _mqtt_output(publish, None) if publish is not None else ""
    return Export(text=head + "\n".join(["", *inputs]) + "".join(processors) + output, warnings=warnings)


def export_telegraf(resolved: ResolvedDevice, settings: Settings) -> Export:
    notes = Notes(resolved, ENGINE)
    exported = _exported(resolved, notes)
    if not exported:
        raise nothing_left(resolved, ENGINE, notes)
    source = Path(resolved.device.source).name if resolved.device.source else "a description"
    head = (
        f"# Telegraf modbus input: {comment_text(resolved.name)}, from {comment_text(source)} by mdl export.\n"
        f"# One request section per request of mdl's read plan. Needs Telegraf {_version(exported)} or newer.\n"
    )
    text = head + _input(resolved, settings, notes, exported) + _processors(resolved, exported)
    if settings.publish is not None:
        text += _mqtt_output(settings.publish, resolved.stem)
    return Export(text=text, warnings=notes.found)
