"""`mdl export --to homeassistant`: a `modbus:` hub for Home Assistant's configuration.yaml (SPEC 11).

The file is a YAML list of hubs, the form `modbus: !include modbus.yaml` in configuration.yaml reads, with
one hub (named by the device's stem, with the connection of the command line) holding:
- `sensors` for readable numbers and text: `data_type` (int16 ... uint64, float32/64, string with its
  `count`, or `custom` with a struct `structure` for one byte of a register), `swap` (byte: MDL
  byte_order little; word: word_order little; word_byte: both), `scale`/`offset` (Home Assistant
  computes scale * value + offset), `precision` (the function's, else the decimal places its
  scaling needs, as Home Assistant rounds what it shows to it), `nan_value` (the first
  not_implemented value, as the number Home Assistant unpacks from those registers), `input_type`,
  `unit_of_measurement` in Home Assistant's spelling with the `device_class` and `state_class` it gives
  (ha_units; not for text, which Home Assistant refuses with a unit);
- `binary_sensors` for coils and discrete inputs that cannot be written, `switches` for writable coils
  (write_type `coil`, function 5, or `coils`, function 15, for a function that says write_multiple;
  `verify` reads the coil back);
- a BIT in a holding or input register (true when the register is not 0): Home Assistant's
  binary_sensor reads bit 0 of a register only, so it is a uint16 sensor with `max_value: 1` (it
  shows 1 or 0); a writable one is also a switch (write_type `holding`, function 6, or `holdings`,
  function 16, command_on 1, command_off 0) without `verify` (which knows the values 1 and 0 only);
- a function with `bits` (SPEC 2.2) that is one bit landing on bit 0 of a register as sent (bit 0 of a
  16-bit big-endian value, or of the register holding the low word) is a binary_sensor of that register
  (`input_type` holding or input; binary_sensor.py: `registers[0] & 1`), read-only (a switch writes the
  whole register); any other bits, and a value scaled by another register (`scale_exponent`,
  `scale_by`: a sensor's scale and offset are constants), are left out with a warning;
- a writable register of range 0..1 (minimum 0, maximum 1, unscaled, without labels: a relay, an enable) is
  also a switch writing what mdl writes for 1 and 0 (command_on/command_off where not 1 and 0), with
  `verify` where it can be read;
- a thermostat (a writable set point in °C or °F with a room temperature Home Assistant reads alike, or the
  thermostat profile's roles) is a `climate` (ha_climate): the set point its target temperature, the room
  temperature its current one (which then has no sensor of its own: one entity per register), an
  enumeration of HVAC modes or fan modes its hvac_mode_register or fan_mode_register;
each with `name` (the function's), `unique_id` (stem, unit, identifier), `device_address` (--unit),
`address` (the wire address) and `scan_interval` (--interval, whole seconds).

Home Assistant's modbus integration has no writable number entity: any other writable register is exported
as a sensor, with a warning naming the modbus.write_register action. Home Assistant loads one entity per
register and table (its validator's key: hub, address, input_type or write_type, command_on/off,
device_address; a climate's also its target, HVAC mode and fan mode registers; validators.py check_config):
where two functions share one, the second is left out with a warning, as Home Assistant would drop it.
Checked against Home Assistant 2024.3's own schema (homeassistant.components.modbus.CONFIG_SCHEMA) and its
value rules (base_platform.py, climate.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from mdl.exchange.export import Export
from mdl.exchange.text import comment_text, yaml_dumper
from mdl.exports.base import (
    Notes,
    bit_in_register,
    bits_detail,
    connection_of,
    decimals,
    factor_detail,
    hex_pattern,
    left_out_unreadable,
    nothing_left,
    patterns_of,
    register_bit,
    scale_of,
    whole_seconds,
    write_code,
    written_by_fragment,
)
from mdl.exports.ha_climate import CURRENT_LEFT_OUT, WRITTEN, Climate, climate_of
from mdl.exports.ha_types import NO_DATA_TYPE, ha_type, shape, unpacked
from mdl.exports.ha_units import ROLE_CLASSES, ha_unit
from mdl.ir.codec import CodecError, compile_encoder
from mdl.model.layout import integer_range

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.resolver import ResolvedDevice, ResolvedFunction

ENGINE = "Home Assistant"
FLOAT_PRECISION = 2  # what Home Assistant shows of a float without precision
MIN_SCAN = 5  # Home Assistant warns of a scan_interval under this many seconds
# the hub's entity lists, by Home Assistant's platform names, in the order its validator reads them (const.PLATFORMS)
_PLATFORM = {"binary_sensors": "binary_sensor", "climates": "climate", "sensors": "sensor", "switches": "switch"}
_PLATFORM_ORDER = ("binary_sensors", "climates", "sensors", "switches")
_DEFAULTS: dict[str, dict[str, Any]] = {  # the schema's defaults that the validator's key reads (__init__.py)
    "binary_sensors": {"input_type": "coil"},
    "climates": {"input_type": "holding"},
    "sensors": {"input_type": "holding"},
    "switches": {"write_type": "holding", "command_on": 1, "command_off": 0},
}
Entity = tuple["ResolvedFunction", dict[str, Any]]


def _nan_value(f: ResolvedFunction, kind: dict[str, Any], notes: Notes) -> int | None:
    patterns = patterns_of(f)
    if not patterns:
        return None
    if len(patterns) > 1:
        notes.warn(
            f,
            "nan_value holds one 'not implemented' value: the first is used, the others read as numbers",
            f"{hex_pattern(patterns[0])} used; {', '.join(map(hex_pattern, patterns[1:]))} read as numbers",
        )
    if kind["data_type"] == "string":
        notes.warn(f, "text has no nan_value: the 'not implemented' value reads as text", hex_pattern(patterns[0]))
        return None
    value = unpacked(kind, patterns[0])
    if value != value:  # a float NaN: Home Assistant shows none for it anyway
        return None
    if value == 0 or value != int(value):
        notes.warn(
            f,
            "nan_value cannot be 0 or a fraction: the 'not implemented' value reads as a number",
            f"{hex_pattern(patterns[0])} unpacks to {value!r}",
        )
        return None
    number = int(value)
    lay = f.layout
    low, high = integer_range(lay.bits, True)
    if lay.kind == "float" or (lay.signed and low <= -number <= high):
        notes.warn(
            f,
            "nan_value also makes its negative read as not implemented (Home Assistant compares both signs)",
            f"nan_value {number} also makes {-number}",
        )
    return number


def _precision(f: ResolvedFunction, kind: dict[str, Any], notes: Notes) -> int | None:
    if kind["data_type"] == "string":
        return None
    if f.fn.precision is not None:
        if f.fn.precision < 0:
            notes.warn(
                f, "precision cannot round left of the point: whole numbers are shown", f"precision {f.fn.precision}"
            )
            return 0
        return f.fn.precision
    step = scale_of(f)
    if f.layout.kind == "float":
        notes.warn(f, f"shows a float with {FLOAT_PRECISION} decimal places unless the function has a precision")
        return None
    if step is None:
        return None
    places = max(decimals(step.multiplier), decimals(step.offset))
    return places or None


def _sensor(
    f: ResolvedFunction, base: dict[str, Any], notes: Notes, written: str | None = None
) -> dict[str, Any] | None:
    """A readable number or text as a sensor, or None (warned); `written`: what writes the function instead of the
    modbus.write_register action (a switch, the climate), said in a note."""
    kind = ha_type(f.layout)
    if isinstance(kind, str):
        notes.warn(f, f"{kind}: left out", shape(f.layout) if kind == NO_DATA_TYPE else None)
        return None
    entry = dict(base)
    entry["input_type"] = "input" if f.layout.table == "input" else "holding"
    entry.update(kind)
    step = scale_of(f)
    if step is not None:
        if step.multiplier != 1:
            entry["scale"] = step.multiplier
        if step.offset != 0:
            entry["offset"] = step.offset
    precision = _precision(f, kind, notes)
    if precision is not None:
        entry["precision"] = precision
    if f.fn.units or f.fn.role in ROLE_CLASSES:
        entry.update(_unit(f, kind, notes))
    nan_value = _nan_value(f, kind, notes)
    if nan_value is not None:
        entry["nan_value"] = nan_value
    if f.fn.values:
        notes.warn(f, "a sensor has no enumeration: it shows the number, not the label")
    if kind["data_type"] == "string":
        notes.warn(f, "the text keeps the NUL padding that mdl strips")
    if f.fn.writable and written == SWITCH:
        pass  # its switch writes it (said there)
    elif f.fn.writable and written is not None:
        notes.note_for(f, WRITTEN, written)
    elif f.fn.writable:
        notes.warn(
            f,
            "the modbus integration has no entity that writes a register value: exported as a sensor: "
            f"write it with {WRITE_ACTION}",
            _write_detail(f),
        )
    return entry


def _unit(f: ResolvedFunction, kind: dict[str, Any], notes: Notes) -> dict[str, Any]:
    """unit_of_measurement in Home Assistant's spelling, with the device_class and state_class it gives
    (ha_units); a change of spelling and each guess said in a note."""
    units = f.fn.units or ""
    if kind["data_type"] == "string":
        notes.warn(
            f,
            "a unit makes Home Assistant expect a number, and the sensor shows text: written without its unit",
            repr(units),
        )
        return {}
    found = ha_unit(units, f.fn.role)
    out: dict[str, Any] = {"unit_of_measurement": found.unit} if found.unit else {}
    if found.unit != units:
        notes.note_for(f, "units written in Home Assistant's spelling", f"{units!r} as {found.unit!r}")
    if f.fn.values:  # an enumeration's number is a state, not a measurement
        return out
    if found.device_class is not None:
        out["device_class"] = found.device_class
    if found.state_class is not None:
        out["state_class"] = found.state_class
    else:
        notes.note_for(
            f,
            "a unit Home Assistant does not class: no device_class or state_class (long-term "
            "statistics and the Energy dashboard leave the sensor out)",
            repr(units),
        )
    for guess in found.guesses:
        notes.note_for(f, guess)
    return out


def _bit_sensor(f: ResolvedFunction, base: dict[str, Any], notes: Notes) -> dict[str, Any]:
    """A BIT in a register as Home Assistant can read it as mdl does: the register clamped to 1."""
    kind: dict[str, Any] = {"data_type": "uint16"}
    entry = {**base, "input_type": "input" if f.layout.table == "input" else "holding", **kind, "max_value": 1}
    nan_value = _nan_value(f, kind, notes)
    if nan_value is not None:
        entry["nan_value"] = nan_value
    notes.warn(
        f,
        "a bit in a register (true when the register is not 0) is a sensor showing 1 or 0 (max_value: 1): "
        "a binary_sensor would read bit 0 only",
    )
    return entry


def _register_bit(f: ResolvedFunction, base: dict[str, Any], notes: Notes) -> dict[str, Any] | None:
    """A function with `bits` as a binary_sensor (one bit that is bit 0 of a register as sent), or None (warned)."""
    found = register_bit(f)
    if found is None or found[1] != 0 or not f.fn.readable:
        where = f"bit {found[1]} of register {found[0]}" if found is not None else bits_detail(f.fn)
        notes.warn(
            f,
            "a binary_sensor reads bit 0 of a register only, and no sensor takes some bits of one: left out",
            where if f.fn.readable else "write-only",
        )
        return None
    if f.fn.writable:
        notes.warn(f, "exported read-only (a binary_sensor): a switch would write the whole register, not its bit")
    patterns = patterns_of(f)
    if patterns:
        notes.warn(
            f,
            "a binary_sensor has no 'not implemented' value: the values that mean it read as a bit",
            ", ".join(map(hex_pattern, patterns)),
        )
    return {**base, "address": found[0], "input_type": "input" if f.layout.table == "input" else "holding"}


def _write_type(f: ResolvedFunction) -> str:
    """The switch's write_type: the function code mdl writes with (5/15 for a coil, 6/16 for a register)."""
    return {5: "coil", 15: "coils", 6: "holding", 16: "holdings"}[write_code(f)]


WRITE_ACTION = "the modbus.write_register action"


def _write_detail(f: ResolvedFunction) -> str | None:
    """How Home Assistant's modbus.write_register action writes a register function as mdl does: its value is
    written with function 6, or as a list with function 16 (modbus.py async_write_register): that, or None."""
    return "its value a list of registers: function 16, as mdl writes it" if write_code(f) == 16 else None


SWITCH = "its switch"  # what writes a two-state register (`_sensor`'s `written`)


def _on_off(f: ResolvedFunction) -> tuple[int, int] | None:
    """The register values mdl writes for 1 and 0, for a writable integer of one holding register whose range is
    0..1 (minimum 0, maximum 1: a relay, an enable; unscaled, without labels), which a switch writes as its
    command_on and command_off; None for any other function."""
    lay = f.layout
    if lay.table != "holding" or lay.kind != "int" or len(lay.addresses) != 1 or f.fn.bits is not None:
        return None
    if f.fn.values or scale_of(f) is not None or (f.fn.minimum, f.fn.maximum) != (0, 1) or f.codec.encode is None:
        return None
    encode = compile_encoder(f.codec, f.codec.encode)
    try:
        on, off = encode(1), encode(0)
    except CodecError:
        return None
    return on[0], off[0]


def _register_switch(
    f: ResolvedFunction, base: dict[str, Any], on_off: tuple[int, int], notes: Notes
) -> dict[str, Any]:
    """A switch that writes a two-state register as mdl writes 1 and 0; `verify` reads the register back."""
    switch = {**base, "write_type": _write_type(f)}
    if on_off != (1, 0):
        switch.update(command_on=on_off[0], command_off=on_off[1])
    if not f.fn.readable:
        notes.warn(f, "write-only: the switch shows the state it last wrote")
        return switch
    switch["verify"] = {}
    if f.layout.unit != "word" or f.layout.bits != 16:
        notes.warn(
            f,
            "a switch's verify compares the whole register, of which the function is one byte: where the other "
            "byte is not 0 the switch keeps the state it showed (Home Assistant logs the register)",
        )
    return switch


def _entities(
    resolved: ResolvedDevice, settings: Settings, notes: Notes, climate: Climate | None
) -> dict[str, list[Entity]]:
    out: dict[str, list[Entity]] = {"sensors": [], "binary_sensors": [], "switches": [], "climates": []}
    scan = whole_seconds(settings, notes)
    if scan < MIN_SCAN:
        notes.device_warning(
            f"scan_interval {scan} is under {MIN_SCAN} seconds, which Home Assistant warns may make it unstable"
        )
    written = climate.writes if climate is not None else {}
    for f in resolved.functions:
        if f.fn.readable and left_out_unreadable(f, notes):
            continue
        base = {
            "name": _named(f.name, settings),
            "unique_id": _unique(resolved, settings, f.ident),
            "device_address": settings.unit,
            "address": f.layout.addresses[0],
        }
        if climate is not None and f is climate.current:
            notes.warn(f, CURRENT_LEFT_OUT, f"climate '{climate.target.name}'")
            continue
        if f.fn.factor is not None:
            notes.warn(
                f,
                "a sensor's scale and offset are constants, and none is read from another register: left out",
                factor_detail(f.fn),
            )
            continue
        if f.fn.bits is not None:
            sensor = _register_bit(f, base, notes)
            if sensor is not None:
                out["binary_sensors"].append((f, {**sensor, "scan_interval": scan}))
            continue
        writable = f.fn.writable and not written_by_fragment(f)
        if f.fn.writable and not writable:
            notes.warn(f, "a write fragment encodes it, which Home Assistant cannot: exported read-only")
        if f.layout.kind == "bool" and f.layout.table in ("coil", "discrete"):
            if writable and f.layout.table == "coil":
                switch = {**base, "write_type": _write_type(f)}
                if f.fn.readable:
                    switch["verify"] = {}
                else:
                    notes.warn(f, "write-only: the switch shows the state it last wrote")
                out["switches"].append((f, {**switch, "scan_interval": scan}))
            elif f.fn.readable:
                input_type = "discrete_input" if f.layout.table == "discrete" else "coil"
                out["binary_sensors"].append((f, {**base, "input_type": input_type, "scan_interval": scan}))
            else:
                notes.warn(f, "neither readable nor writable here: left out")
            continue
        if bit_in_register(f):
            if f.fn.readable:
                out["sensors"].append((f, {**_bit_sensor(f, base, notes), "scan_interval": scan}))
            if writable and f.layout.table == "holding":
                out["switches"].append((f, {**base, "write_type": _write_type(f), "scan_interval": scan}))
                notes.warn(
                    f,
                    "the switch writes 1 or 0 and shows the state it last wrote (its verify knows the "
                    "register values 1 and 0 only)" + ("; the sensor reads the register" if f.fn.readable else ""),
                )
            elif not f.fn.readable:
                notes.warn(f, "neither readable nor writable here: left out")
            continue
        on_off = _on_off(f) if writable and f.name not in written else None
        if on_off is not None:
            out["switches"].append((f, {**_register_switch(f, base, on_off, notes), "scan_interval": scan}))
        if not f.fn.readable:
            if on_off is None:
                notes.warn(
                    f,
                    f"write-only register: the modbus integration writes it only with {WRITE_ACTION}: left out",
                    _write_detail(f),
                )
            continue
        sensor = _sensor(f, base, notes, SWITCH if on_off is not None else written.get(f.name))
        if sensor is not None:
            out["sensors"].append((f, {**sensor, "scan_interval": scan}))
    if climate is not None:
        target = climate.target
        entity = {
            "name": _named(target.name, settings),
            "unique_id": _unique(resolved, settings, target.ident),
            "device_address": settings.unit,
            **climate.entity,
            "scan_interval": scan,
        }
        out["climates"].append((target, entity))
    return {key: value for key, value in out.items() if value}


HVAC_MODE_COUNT = 7  # Home Assistant's HVAC modes: a climate's target_temp_register is a list of this many


def _keys(hub: str, component: str, entity: dict[str, Any]) -> tuple[list[str], str]:
    """Home Assistant's keys for an entity (validators.py check_config.validate_entity, its schema's
    defaults filled in): its register keys (a climate's also for its target, HVAC mode and fan mode registers)
    and its name key."""
    filled = {**_DEFAULTS[component], **entity}
    device = filled.get("device_address", 0)
    register = f"{hub}{filled['address']}"
    for conf in ("input_type", "write_type", "command_on", "command_off"):
        if conf in filled:
            register += f"_{filled[conf]}"
    keys = [f"{register}_{device}"]
    if component == "climates":
        keys.append(f"{hub}{[filled['target_temp_register']] * HVAC_MODE_COUNT}_{device}")  # the schema's list
        keys += [
            f"{hub}{filled[conf]['address']}_{device}"
            for conf in ("hvac_mode_register", "fan_mode_register")
            if conf in filled
        ]
    return keys, f"{_PLATFORM[component]}.{filled['name']}"


def _named(name: str, settings: Settings) -> str:
    """An entity's name: the function's, after the device's id in a fleet (Home Assistant's names are one
    namespace for every hub)."""
    return f"{settings.name} {name}" if settings.name is not None else name


def _unique(resolved: ResolvedDevice, settings: Settings, ident: str) -> str:
    return f"{settings.name}_{ident}" if settings.name is not None else f"{resolved.stem}_{settings.unit}_{ident}"


def hub_of(text: str) -> dict[str, Any]:
    """The one hub of a single device's export (its text), for a fleet's file (mdl.exports.fleet)."""
    hubs = yaml.safe_load(text)
    assert isinstance(hubs, list) and len(hubs) == 1
    return dict(hubs[0])


def fleet_text(hubs: list[dict[str, Any]]) -> str:
    """A fleet's hubs as one modbus.yaml, dumped as a device's is."""
    head = (
        "# Home Assistant modbus integration: a fleet's hubs, one per line, by mdl export --inventory.\n"
        "# Save it as modbus.yaml beside configuration.yaml, which reads it with\n#   modbus: !include modbus.yaml\n"
    )
    return head + yaml.dump(
        hubs, Dumper=yaml_dumper(), sort_keys=False, allow_unicode=True, default_flow_style=False, width=100
    )


def _drop_duplicates(hub: str, entities: dict[str, list[Entity]], notes: Notes) -> dict[str, list[dict[str, Any]]]:
    """The entities Home Assistant loads: the first for each register key and name, in its platforms' order;
    each one it would drop is left out with a warning naming the function."""
    registers: dict[str, ResolvedFunction] = {}
    names: set[str] = set()
    kept: dict[str, list[dict[str, Any]]] = {}
    for component in sorted(entities, key=_PLATFORM_ORDER.index):
        for f, entity in entities[component]:
            keys, name = _keys(hub, component, entity)
            first = next((registers[key] for key in keys if key in registers), None)
            if first is not None or name in names:
                table = entity.get("input_type") or entity.get("write_type", "holding")
                if first is not None:
                    what = "shares its register with an entity before it"
                    detail = f"{table} {entity['address']}, device_address {entity['device_address']}: '{first.name}'"
                else:
                    what, detail = "its name is taken by another entity of its platform", component
                notes.warn(
                    f,
                    f'{what}, and Home Assistant loads only the first ("is duplicate, second entry not '
                    'loaded!"): left out',
                    detail,
                )
                continue
            registers.update(dict.fromkeys(keys, f))
            names.add(name)
            kept.setdefault(component, []).append(entity)
    return {component: kept[component] for component in entities if component in kept}


def _hub(resolved: ResolvedDevice, settings: Settings, notes: Notes) -> dict[str, Any]:
    conn = connection_of(settings, notes)
    hub: dict[str, Any] = {"name": resolved.stem}
    if conn.serial is not None:
        hub.update(
            type="serial",
            port=conn.serial,
            baudrate=conn.baud,
            bytesize=conn.bytesize,
            method="rtu",
            parity=conn.parity,
            stopbits=conn.stopbits,
        )
    else:
        hub.update(type="rtuovertcp" if conn.rtu else "tcp", host=conn.host, port=conn.port)
    hub["timeout"] = int(conn.timeout) if conn.timeout == int(conn.timeout) else conn.timeout
    return hub


def export_homeassistant(resolved: ResolvedDevice, settings: Settings) -> Export:
    notes = Notes(resolved, ENGINE)
    climate = climate_of(resolved, notes)
    hub = _hub(resolved, settings, notes)
    entities = _drop_duplicates(hub["name"], _entities(resolved, settings, notes, climate), notes)
    if climate is not None and "climates" not in entities:  # Home Assistant would drop it: no climate, then
        notes = Notes(resolved, ENGINE)
        hub = _hub(resolved, settings, notes)
        entities = _drop_duplicates(hub["name"], _entities(resolved, settings, notes, None), notes)
    if not entities:
        raise nothing_left(resolved, ENGINE, notes)
    hub.update(entities)
    source = Path(resolved.device.source).name if resolved.device.source else "a description"
    head = (
        f"# Home Assistant modbus integration: {comment_text(resolved.name)}, from {comment_text(source)} by "
        "mdl export.\n# A list of modbus hubs: save it as modbus.yaml beside configuration.yaml, which reads it "
        "with\n#   modbus: !include modbus.yaml\n# (where configuration.yaml already lists hubs under modbus:, "
        "add this one to them).\n"
    )
    body = yaml.dump(
        [hub], Dumper=yaml_dumper(), sort_keys=False, allow_unicode=True, default_flow_style=False, width=100
    )
    return Export(text=head + body, warnings=notes.found)
