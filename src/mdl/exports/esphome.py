"""`mdl export --to esphome`: an ESPHome node on the RS-485 line, reading the device with its
modbus_controller (SPEC 11; docs/fleet.md, "ESPHome").

The file is a whole node configuration: `esphome` (its name from the description's stem, friendly_name the
device's name), `esp32` (--board), `uart` (--tx-pin, --rx-pin, and the line's --baud, --parity,
--stopbits, --bytesize), `modbus` (`flow_control_pin`: --flow-control-pin, the RS-485 transceiver's DE/RE
pin; every pin checked by `pin_problem` before it reaches the YAML), `modbus_controller` (address --unit,
update_interval --interval), and one entity per function:
- `sensor` for a readable number: `register_type` (holding, or read for an input register), `address`,
  `value_type` (esphome_types: U_WORD ... S_QWORD_R, FP32, FP32_R), a `bitmask` for an 8-bit value or a
  range of `bits`, `filters` (`multiply`, then `offset`: mdl's scale; a signed byte's sign), the unit in
  Home Assistant's spelling with the device_class and state_class of its unit or role (ha_units), and
  `accuracy_decimals` (the function's precision, else the decimal places its scaling needs);
- `binary_sensor` for a read-only coil, discrete input, one of `bits` (its `bitmask`), or a BIT in a
  register (bitmask 0xFFFF: true when the register is not 0);
- `text_sensor` for text (register_count, response_size in bytes, raw_encode ANSI);
- `number` for a writable number (`multiply` is the reciprocal of mdl's scale: ESPHome shows the register
  divided by it and writes the value times it), with min_value/max_value (the function's, else its
  type's range) and step;
- `switch` for a writable coil or BIT in a register; `select` for a writable enumeration (`optionsmap`).
Each writer of a register says `use_write_multiple` where mdl writes with function 16 or 15.
Whatever ESPHome cannot express is said with one warning per kind of loss (base.Notes).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from mdl.exchange.connection import LINE_ONLY, Endpoint
from mdl.exchange.export import Export
from mdl.exchange.text import comment_text, yaml_dumper
from mdl.exports.base import (
    Notes,
    bits_detail,
    decimals,
    factor_detail,
    left_out_unreadable,
    nothing_left,
    patterns_of,
    plain_number,
    register_bit,
    scale_of,
    warn_patterns,
    written_by_fragment,
)
from mdl.exports.esphome_names import UNIT_MAX_BYTES, Names, display_name, inert, node_name
from mdl.exports.esphome_types import FLOAT_EXACT, ValueType, rounds, value_type, with_bits
from mdl.exports.ha_units import ROLE_CLASSES, ha_unit
from mdl.ir.steps import Bits, find_step

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.resolver import ResolvedDevice, ResolvedFunction

ENGINE = "ESPHome"
PLATFORMS = ("sensor", "binary_sensor", "text_sensor", "number", "switch", "select")
SIGNED_BYTE = "return x >= 128 ? x - 256 : x;"  # ESPHome reads a byte unsigned (a filter lambda, C++)
NOT_IMPLEMENTED = "return {} ? NAN : x;"  # the 'not implemented' values of one register, before the scale
FLOAT_MAX = 3.4028234663852886e38  # the largest 32-bit float
FLOAT_STEP = 0.001  # a float number's step where the function gives no precision
Entity = dict[str, Any]


class Hex(int):
    """A bitmask, written in hex (an integer to YAML and to ESPHome's hex_uint32_t)."""


class _HexDumper(yaml_dumper()):  # type: ignore[misc]  # a class made at run time
    pass


_HexDumper.add_representer(Hex, lambda dumper, value: dumper.represent_scalar("tag:yaml.org,2002:int", f"0x{value:X}"))


def _register_type(f: ResolvedFunction) -> str:
    return {"holding": "holding", "input": "read", "coil": "coil", "discrete": "discrete_input"}[f.layout.table]


def _write_multiple(f: ResolvedFunction, entity: Entity) -> Entity:
    """`use_write_multiple` where mdl writes one register or coil with function 16 or 15 (ESPHome writes
    several registers with 16 anyway)."""
    if f.fn.write_multiple and (f.layout.table == "coil" or len(f.layout.addresses) == 1):
        entity["use_write_multiple"] = True
    return entity


class _Writer:
    def __init__(self, resolved: ResolvedDevice, notes: Notes) -> None:
        self.resolved, self.notes = resolved, notes
        self.names = Names(notes)
        self.out: dict[str, list[Entity]] = {platform: [] for platform in PLATFORMS}

    def add(self, f: ResolvedFunction, platform: str, entity: Entity) -> None:
        self.out[platform].append({"name": self.names.name(f, platform), **entity})

    def base(self, f: ResolvedFunction, vt: ValueType | None = None) -> Entity:
        entity: Entity = {"register_type": _register_type(f), "address": f.layout.addresses[0]}
        if vt is not None:
            entity["value_type"] = vt.name
            if vt.bitmask is not None:
                entity["bitmask"] = Hex(vt.bitmask)
        return entity

    def function(self, f: ResolvedFunction) -> None:
        if f.fn.readable and left_out_unreadable(f, self.notes):
            return
        if f.fn.factor is not None:
            self.notes.warn(
                f, "a filter multiplies by a constant, never by another register's value: left out", factor_detail(f.fn)
            )
            return
        if not f.fn.readable:
            self.notes.warn(f, "write-only: an ESPHome entity reads its register on every update: left out")
            return
        writable = f.fn.writable and not written_by_fragment(f)
        if f.fn.writable and not writable:
            self.notes.warn(f, "a write fragment encodes it, which ESPHome cannot: exported read-only")
        if f.layout.kind == "bool":
            self.boolean(f, writable)
        elif f.layout.kind == "string":
            self.text(f, writable)
        else:
            self.number(f, writable)

    def boolean(self, f: ResolvedFunction, writable: bool) -> None:
        if f.layout.table in ("coil", "discrete"):
            entity = self.base(f)
            if writable and f.layout.table == "coil":
                self.add(f, "switch", _write_multiple(f, entity))
            else:
                self.add(f, "binary_sensor", entity)
            return
        self.patterns(f)
        if writable:  # a BIT in a holding register: the switch writes 1 or 0, as mdl does
            self.notes.warn(
                f,
                "a switch reads the bits it writes: it shows bit 0 of the register (mdl: true when the register "
                "is not 0)",
            )
            self.add(f, "switch", _write_multiple(f, {**self.base(f), "bitmask": Hex(1)}))
        else:
            self.add(f, "binary_sensor", {**self.base(f), "bitmask": Hex(0xFFFF)})

    def text(self, f: ResolvedFunction, writable: bool) -> None:
        if f.layout.byte_order == "little" or f.layout.unit != "word":
            self.notes.warn(f, "a text_sensor reads each register's bytes most significant first: left out")
            return
        if writable:
            self.notes.warn(f, "no ESPHome entity writes text to a register: exported read-only (a text_sensor)")
        self.patterns(f)
        self.notes.warn(f, "the text_sensor keeps the trailing spaces mdl strips, and drops control characters (ANSI)")
        n = len(f.layout.addresses)
        self.add(f, "text_sensor", {**self.base(f), "register_count": n, "response_size": 2 * n, "raw_encode": "ANSI"})

    def number(self, f: ResolvedFunction, writable: bool) -> None:
        vt = value_type(f.layout)
        if isinstance(vt, str):
            self.notes.warn(
                f, f"{vt}: left out", f"a {f.layout.bits}-bit {f.layout.kind} in {len(f.layout.addresses)} registers"
            )
            return
        bit = find_step(f.codec.decode, Bits)
        if bit is not None and bit.boolean:
            self.bit(f, writable)
            return
        vt = with_bits(f, vt)
        if isinstance(vt, str):
            self.notes.warn(f, f"{vt}: left out", bits_detail(f.fn))
            return
        if rounds(f, vt):
            self.notes.warn(
                f,
                f"its value is held as a 32-bit float: integers beyond {FLOAT_EXACT} are rounded",
                vt.name + (" (an unsigned value above 2^63 reads negative)" if vt.name.startswith("U_QWORD") else ""),
            )
        step = scale_of(f)
        if writable and bit is not None:
            self.notes.warn(f, "a number writes the whole register, not some bits of it: exported read-only")
            writable = False
        if writable and step is not None and step.offset != 0:
            self.notes.warn(
                f, "a number has no offset: exported read-only (a sensor)", f"offset {plain_number(step.offset)}"
            )
            writable = False
        if writable and vt.bitmask is not None and (vt.bitmask != 0xFF or vt.signed_byte):
            # a number writes its value into the whole register, as mdl writes an unsigned low byte
            self.notes.warn(f, "a number writes a whole register, not one byte of it: exported read-only")
            writable = False
        if writable and not _settable(f):
            self.notes.warn(f, "a number's range must hold values within +-16777215: exported read-only")
            writable = False
        if writable:
            self.patterns(f)
        if writable and f.fn.values and self.select(f, vt):
            return
        if f.fn.values and not writable:
            self.notes.warn(f, "a sensor has no enumeration: it shows the number, not the label")
        if writable:
            self.add(f, "number", _write_multiple(f, self.writable_number(f, vt)))
            return
        self.add(f, "sensor", self.sensor(f, vt))

    def bit(self, f: ResolvedFunction, writable: bool) -> None:
        found = register_bit(f)
        if found is None:
            self.notes.warn(f, "a binary_sensor's bitmask takes bits of one register: left out", bits_detail(f.fn))
            return
        if writable:
            self.notes.warn(f, "exported read-only (a binary_sensor): a switch writes the whole register, not its bit")
        self.patterns(f)
        address, bit = found
        self.add(f, "binary_sensor", {"register_type": _register_type(f), "address": address, "bitmask": Hex(1 << bit)})

    def not_implemented(self, f: ResolvedFunction, vt: ValueType) -> str | None:
        """A filter that makes the values meaning "not implemented" NAN (Home Assistant shows unknown, as mdl
        reads null), where the sensor's value before its filters tells them exactly (one whole register);
        else None, warned when there are such values."""
        patterns = patterns_of(f)
        if not patterns:
            return None
        if vt.name not in ("U_WORD", "S_WORD") or vt.bitmask is not None:
            self.patterns(f)
            return None
        raw = sorted({p[0] - (p[0] >> 15 << 16 if vt.name == "S_WORD" else 0) for p in patterns})
        return NOT_IMPLEMENTED.format(" || ".join(f"x == {value}" for value in raw))

    def patterns(self, f: ResolvedFunction) -> None:
        warn_patterns(f, self.notes, "no 'not implemented' value here: the values that mean it read as values")

    def unit(self, f: ResolvedFunction, classes: bool = True) -> Entity:
        """unit_of_measurement in Home Assistant's spelling, with device_class and state_class (ha_units)."""
        units = f.fn.units or ""
        if not units and f.fn.role not in ROLE_CLASSES:
            return {}
        found = ha_unit(units, f.fn.role)
        out: Entity = {}
        unit = inert(found.unit)
        if unit != found.unit:
            self.notes.warn(f, "its unit is written as ESPHome keeps it", f"{found.unit!r} as {unit!r}")
        if len(unit.encode("utf-8")) > UNIT_MAX_BYTES:
            self.notes.warn(
                f, f"ESPHome takes a unit of at most {UNIT_MAX_BYTES} bytes: written without it", repr(units)
            )
        elif unit:
            out["unit_of_measurement"] = unit
        if found.unit != units:
            self.notes.note_for(f, "units written in Home Assistant's spelling", f"{units!r} as {found.unit!r}")
        if f.fn.values or not classes:
            return out
        if found.device_class is not None:
            out["device_class"] = found.device_class
        if found.state_class is not None:
            out["state_class"] = found.state_class
        for guess in found.guesses:
            self.notes.note_for(f, guess)
        return out

    def accuracy(self, f: ResolvedFunction) -> Entity:
        if f.fn.precision is not None:
            return {"accuracy_decimals": max(0, f.fn.precision)}
        step = scale_of(f)
        places = max(decimals(step.multiplier), decimals(step.offset)) if step is not None else 0
        return {} if f.layout.kind == "float" else {"accuracy_decimals": places}

    def sensor(self, f: ResolvedFunction, vt: ValueType) -> Entity:
        entity = self.base(f, vt)
        filters: list[Entity] = []
        if vt.signed_byte:
            filters.append({"lambda": SIGNED_BYTE})
        missing = self.not_implemented(f, vt)
        if missing is not None:
            filters.append({"lambda": missing})
        step = scale_of(f)
        if step is not None and step.multiplier != 1:
            filters.append({"multiply": step.multiplier})
        if step is not None and step.offset != 0:
            filters.append({"offset": step.offset})
        entity.update(self.unit(f))
        entity.update(self.accuracy(f))
        if filters:
            entity["filters"] = filters
        return entity

    def writable_number(self, f: ResolvedFunction, vt: ValueType) -> Entity:
        entity = self.base(f, vt)
        step = scale_of(f)
        multiplier = step.multiplier if step is not None else 1.0
        if multiplier != 1:  # ESPHome shows the register divided by it, and writes the value times it
            entity["multiply"] = step.divisor if step is not None and step.divisor else 1 / multiplier
        low, high = _range(f, multiplier)
        if low < -NUMBER_LIMIT or high > NUMBER_LIMIT:
            self.notes.warn(
                f,
                f"a number's range lies within +-{NUMBER_LIMIT:.0f}: the values beyond it cannot be set",
                "a 32-bit float" if f.layout.kind == "float" else f"{plain_number(low)}..{plain_number(high)}",
            )
            low, high = max(low, -NUMBER_LIMIT), min(high, NUMBER_LIMIT)
        entity["min_value"], entity["max_value"] = low, high
        if f.fn.precision is not None:
            entity["step"] = 10.0 ** -max(0, f.fn.precision)
        elif f.layout.kind == "float":
            entity["step"] = FLOAT_STEP
            self.notes.note_for(f, f"a float number steps by {FLOAT_STEP} (the function gives no precision)")
        else:
            entity["step"] = abs(multiplier)
        entity.update(self.unit(f, classes=False))
        return entity

    def select(self, f: ResolvedFunction, vt: ValueType) -> bool:
        """A writable enumeration as a select (its labels the options), or False (warned) when it cannot be one."""
        values = f.fn.values or {}
        labels = [display_name(label)[0] for label in values.values()]
        if vt.bitmask is not None:  # ESPHome's select has no bitmask: it would compare the whole register
            self.notes.warn(f, "a select maps whole registers, not part of one: exported as a number", vt.name)
            return False
        if scale_of(f) is not None or vt.name.startswith("FP") or len(set(labels)) != len(labels):
            why = "its labels are not unique" if len(set(labels)) != len(labels) else "its value is scaled or a float"
            self.notes.warn(f, "a select maps labels to register values: exported as a number", why)
            return False
        for label, text in zip(labels, values.values(), strict=True):
            if label != text:
                self.notes.warn(f, "its labels are written as ESPHome keeps them", f"{text!r} as {label!r}")
        options = dict(zip(labels, values.keys(), strict=True))
        entity = {"address": f.layout.addresses[0], "value_type": vt.name, "optionsmap": options}
        self.add(f, "select", _write_multiple(f, entity))
        return True


def _range(f: ResolvedFunction, multiplier: float) -> tuple[float, float]:
    """min_value and max_value: the function's, else the values its registers can hold (scaled)."""
    lay = f.layout
    if lay.kind == "float":
        low, high = -FLOAT_MAX, FLOAT_MAX
    else:
        half = 1 << (lay.bits - 1)
        low, high = sorted(
            ((-half if lay.signed else 0) * multiplier, (half - 1 if lay.signed else 2 * half - 1) * multiplier)
        )
    if f.fn.minimum is not None:
        low = max(low, f.fn.minimum)
    if f.fn.maximum is not None:
        high = min(high, f.fn.maximum)
    return float(low), float(high)


NUMBER_LIMIT = 16777215.0  # a number's min_value and max_value lie within +-this (modbus_controller number)


def _settable(f: ResolvedFunction) -> bool:
    """Whether a number can hold some of the function's values: its range, cut to +-NUMBER_LIMIT, is not empty."""
    step = scale_of(f)
    low, high = _range(f, step.multiplier if step is not None else 1.0)
    return max(low, -NUMBER_LIMIT) < min(high, NUMBER_LIMIT)


def _interval(settings: Settings, notes: Notes) -> str:
    ms = settings.interval * 1000
    whole = max(1, math.ceil(ms - 1e-6))
    if abs(whole - ms) > 1e-6:
        notes.device_warning(
            f"polls in whole milliseconds: --interval {plain_number(settings.interval)} becomes {whole} ms"
        )
    return f"{whole // 1000}s" if whole % 1000 == 0 else f"{whole}ms"


def _uart(settings: Settings, notes: Notes) -> Entity:
    conn = settings.connection
    if conn is None:
        conn = Endpoint()
        notes.note(
            f"no serial line given: the uart runs at {conn.baud} {conn.bytesize}{conn.parity}{conn.stopbits}; give "
            "--serial DEVICE with --baud/--parity for the device's own"
        )
    elif conn.serial == LINE_ONLY:  # --baud/--parity alone: the line the ESP32 is on
        notes.note(
            f"the ESP32's UART on {settings.tx_pin}/{settings.rx_pin} runs at {conn.baud} "
            f"{conn.bytesize}{conn.parity}{conn.stopbits}"
        )
    elif conn.serial is None:
        notes.device_warning(
            f"ESPHome's modbus talks RTU on the ESP32's UART, not TCP: {conn} is not used; the uart runs at "
            f"{conn.baud} {conn.bytesize}{conn.parity}{conn.stopbits}"
        )
    else:
        notes.note(
            f"the ESP32's UART on {settings.tx_pin}/{settings.rx_pin} takes the line's settings: {conn.serial} "
            "is not used"
        )
    return {
        "tx_pin": settings.tx_pin,
        "rx_pin": settings.rx_pin,
        "baud_rate": conn.baud,
        "data_bits": conn.bytesize,
        "parity": {"N": "NONE", "E": "EVEN", "O": "ODD"}[conn.parity.upper()],
        "stop_bits": conn.stopbits,
    }


# a pin as ESPHome's esp32 component names one (gpio.py _translate_pin): GPIOn, a number, or a board's pin name
PIN = re.compile(r"GPIO[0-9]{1,2}|[0-9]{1,2}|[A-Z][A-Z0-9_]{0,31}")


def pin_problem(text: str) -> str | None:
    """Why `text` is not a pin name the node can be written with (before it reaches the YAML), or None."""
    if PIN.fullmatch(text):
        return None
    return f"{text[:40]!r} is no pin: give GPIOn (GPIO4), a number (4) or one of the board's pin names (D4, TX)"


def same_pin(a: str, b: str) -> bool:
    """Whether two pin names name one pin (GPIO4 and 4 do)."""
    return a.removeprefix("GPIO").lstrip("0") == b.removeprefix("GPIO").lstrip("0") if a != b else True


def export_esphome(resolved: ResolvedDevice, settings: Settings) -> Export:
    notes = Notes(resolved, ENGINE)
    uart = _uart(settings, notes)
    interval = _interval(settings, notes)
    writer = _Writer(resolved, notes)
    for f in resolved.functions:
        writer.function(f)
    entities = {platform: found for platform, found in writer.out.items() if found}
    if not entities:
        raise nothing_left(resolved, ENGINE, notes)
    friendly, changes = display_name(resolved.name)
    if changes:
        notes.device_warning(f"the device's name is written as ESPHome keeps it, {friendly!r}: {'; '.join(changes)}")
    node: Entity = {
        "esphome": {"name": node_name(resolved.stem), "friendly_name": friendly},
        "esp32": {"board": settings.board, "framework": {"type": "esp-idf"}},
        "uart": uart,
        "modbus": {"flow_control_pin": settings.flow_control_pin} if settings.flow_control_pin else {},
        "modbus_controller": [{"address": settings.unit, "update_interval": interval}],
    }
    for platform, found in entities.items():
        node[platform] = [{"platform": "modbus_controller", **e} for e in found]
    source = Path(resolved.device.source).name if resolved.device.source else "a description"
    head = (
        f"# ESPHome node: {comment_text(resolved.name)}, from {comment_text(source)} by mdl export.\n"
        "# Check it with `esphome config FILE.yaml`; add wifi/api (or mqtt) for it to report anywhere.\n"
    )
    body = yaml.dump(node, Dumper=_HexDumper, sort_keys=False, allow_unicode=True, default_flow_style=False, width=100)
    return Export(text=head + body, warnings=notes.found)
