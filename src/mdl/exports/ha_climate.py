"""A thermostat as Home Assistant's modbus `climate` (`mdl export --to homeassistant`; docs/fleet.md,
"Home Assistant: thermostats").

Home Assistant's modbus integration has no entity that writes a number, but its climate writes a target
temperature (climate.py). A description with a writable temperature set point becomes one climate:
- the target: a readable and writable holding register with the thermostat profile's role `setpoint_c`,
  `heating_setpoint_c` or `cooling_setpoint_c` (in that order), else the first writable function in °C or °F;
- the current temperature: the function with the role `room_temperature_c`, else the first read-only
  function in °C or °F, that Home Assistant reads as the target (the climate unpacks both with one
  data_type, swap, scale, offset and precision, in the same unit);
- `hvac_mode_register`: the function with the role `mode`, else a writable enumeration whose every label is
  one of Home Assistant's HVAC modes (off, heat, cool, heat_cool, auto, dry, fan_only), one whole register
  unscaled (the climate reads it raw); `fan_mode_register` likewise for an enumeration of fan modes (on,
  off, auto, low, medium, high, top, middle, focus, diffuse) with a speed among them;
- min_temp/max_temp (the target's minimum and maximum, else what its register holds), temp_step (10^-precision,
  else the multiplier), temperature_unit C or F, and the function codes mdl writes with
  (target_temp_write_registers, write_registers: function 16).
Home Assistant writes a target as int((value - offset) / scale), which cuts where mdl rounds: the export
tries every value the climate offers (from min_temp by temp_step) against mdl's encoder and warns with the
first that lands elsewhere. The climate has no `nan_value` (warned where the functions have one).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from decimal import ROUND_CEILING, Decimal
from typing import TYPE_CHECKING, Any

from mdl.exports.base import (
    decimals,
    plain_number,
    scale_of,
    unreadable,
    warn_patterns,
    write_code,
    written_by_fragment,
)
from mdl.exports.ha_types import STRUCT, ha_type, packed
from mdl.exports.ha_units import ha_unit
from mdl.ir.codec import CodecError, compile_encoder
from mdl.model.layout import integer_range

if TYPE_CHECKING:
    from mdl.exchange.notes import Notes
    from mdl.resolver import ResolvedDevice, ResolvedFunction

TARGET_ROLES = ("setpoint_c", "heating_setpoint_c", "cooling_setpoint_c")
CURRENT_ROLE = "room_temperature_c"
MODE_ROLE = "mode"
UNITS = {"°C": "C", "°F": "F"}  # Home Assistant's climate takes these two (temperature_unit)
FLOAT_MAX = 3.4028234663852886e38  # the largest 32-bit float
WRITE_CHECKS = 20000  # the most target values tried against mdl's encoder

# a label (lower case, words joined by _) -> Home Assistant's key for the HVAC mode it names (climate.py)
HVAC_MODES = {
    "off": "state_off",
    "heat": "state_heat",
    "heating": "state_heat",
    "cool": "state_cool",
    "cooling": "state_cool",
    "heat_cool": "state_heat_cool",
    "auto": "state_auto",
    "automatic": "state_auto",
    "dry": "state_dry",
    "fan_only": "state_fan_only",
    "fan": "state_fan_only",
}
_CONDITIONING = {"state_heat", "state_cool", "state_heat_cool", "state_dry", "state_fan_only"}
FAN_MODES = {
    name: f"state_fan_{name}"
    for name in ("on", "off", "auto", "low", "medium", "high", "top", "middle", "focus", "diffuse")
}
_SPEEDS = {FAN_MODES[name] for name in ("low", "medium", "high", "top", "middle", "focus", "diffuse")}
CURRENT_LEFT_OUT = (
    "Home Assistant's climate shows it as its current temperature, and Home Assistant loads one entity per "
    "register: no sensor of its own (left out)"
)
WRITTEN = "written by Home Assistant's climate (its sensor shows the value)"


@dataclass
class Climate:
    """The climate's keys from `address` on (the writer adds name, unique_id, device_address and
    scan_interval), and the functions it reads and writes."""

    target: ResolvedFunction
    current: ResolvedFunction
    entity: dict[str, Any]
    writes: dict[str, str] = field(default_factory=dict)  # function name -> what of the climate it is


def _label(text: str) -> str:
    return re.sub(r"[\s/_-]+", "_", text.strip().lower())


def _unit(f: ResolvedFunction) -> str | None:
    """C or F: the function's temperature unit as the climate takes it; None for any other."""
    units = (f.fn.units or "").strip()
    if not units:
        return "C" if f.fn.role in (*TARGET_ROLES, CURRENT_ROLE) else None  # a role's unit (profiles: °C)
    return UNITS.get(ha_unit(units, f.fn.role).unit)


def _kind(f: ResolvedFunction) -> dict[str, Any] | None:
    """The data_type (and swap) a readable number is read with, where the climate can read it as mdl does."""
    if not f.fn.readable or f.fn.factor is not None or f.fn.bits is not None or unreadable(f) is not None:
        return None
    if f.layout.kind not in ("int", "float") or f.layout.table not in ("holding", "input"):
        return None
    kind = ha_type(f.layout)
    return kind if isinstance(kind, dict) and kind["data_type"] in STRUCT else None


def _scaling(f: ResolvedFunction) -> tuple[float, float]:
    step = scale_of(f)
    return (step.multiplier, step.offset) if step is not None else (1.0, 0.0)


def _rank(f: ResolvedFunction, roles: tuple[str, ...]) -> int:
    return roles.index(f.fn.role) if f.fn.role in roles else len(roles)


def _targets(resolved: ResolvedDevice) -> list[ResolvedFunction]:
    found = [
        f
        for f in resolved.functions
        if f.fn.writable
        and f.layout.table == "holding"
        and not written_by_fragment(f)
        and _kind(f) is not None
        and _unit(f) is not None
    ]
    return sorted(found, key=lambda f: _rank(f, TARGET_ROLES))  # stable: the document's order within a rank


def _current(resolved: ResolvedDevice, target: ResolvedFunction) -> ResolvedFunction | None:
    """The room temperature the climate reads with the target's data_type, scaling and unit, or None."""
    kind, scaling, unit = _kind(target), _scaling(target), _unit(target)
    found = [
        f
        for f in resolved.functions
        if f is not target
        and (not f.fn.writable or f.fn.role == CURRENT_ROLE)
        and f.fn.role not in TARGET_ROLES
        and _kind(f) == kind
        and _scaling(f) == scaling
        and _unit(f) == unit
    ]
    return min(found, key=lambda f: _rank(f, (CURRENT_ROLE,)), default=None)


def _places(f: ResolvedFunction) -> int | None:
    """The decimal places the function's value needs (its precision, else its scaling's); None for a float
    without a precision."""
    if f.fn.precision is not None:
        return max(0, f.fn.precision)
    if f.layout.kind == "float":
        return None
    multiplier, offset = _scaling(f)
    return max(decimals(multiplier), decimals(offset))


def _number(x: Decimal | float) -> int | float:
    """A plain YAML number: 10 rather than 10.0."""
    value = float(x)
    return int(value) if value.is_integer() and abs(value) < 2**53 else value


def _limits(f: ResolvedFunction) -> tuple[Decimal, Decimal]:
    """min_temp and max_temp: the function's minimum and maximum, else the values its register holds."""
    lay = f.layout
    if lay.kind == "float":
        low, high = Decimal(-FLOAT_MAX), Decimal(FLOAT_MAX)
    else:
        multiplier, offset = (Decimal(plain_number(x)) for x in _scaling(f))
        ends = [multiplier * end + offset for end in integer_range(lay.bits, lay.signed)]
        low, high = min(ends), max(ends)
    if f.fn.minimum is not None:
        low = max(low, Decimal(plain_number(f.fn.minimum)))
    if f.fn.maximum is not None:
        high = min(high, Decimal(plain_number(f.fn.maximum)))
    return low, high


def _step(f: ResolvedFunction, places: int | None) -> Decimal:
    if f.fn.precision is not None or f.layout.kind == "float":
        return Decimal(1).scaleb(-(places if places is not None else 2))
    return abs(Decimal(plain_number(_scaling(f)[0])))


def _registers(regs: list[int] | None) -> str:
    return "nothing" if regs is None else " ".join(map(str, regs))


def _offered(low: Decimal, high: Decimal, step: Decimal) -> list[float]:
    """The targets Home Assistant's climate offers: min_temp, the multiples of temp_step between (its frontend
    rounds a target to the step), max_temp; at most WRITE_CHECKS of them."""
    first = (low / step).to_integral_value(rounding=ROUND_CEILING) * step
    count = max(0, min(WRITE_CHECKS, int((high - first) / step) + 1))
    return [float(low), *(float(first + k * step) for k in range(count)), float(high)]


def _miswritten(f: ResolvedFunction, entity: dict[str, Any], step: Decimal) -> str | None:
    """The first target the climate offers with this step that Home Assistant writes other than mdl does
    (`10.1 written 100 where mdl writes 101`), or None."""
    assert f.codec.encode is not None
    encode = compile_encoder(f.codec, f.codec.encode)
    low, high = Decimal(plain_number(entity["min_temp"])), Decimal(plain_number(entity["max_temp"]))
    for value in _offered(low, high, step):
        try:
            mdl: list[int] | None = encode(value)
        except CodecError:
            mdl = None
        ha = packed(entity, value)
        if ha != mdl:
            return f"{plain_number(value)} written {_registers(ha)} where mdl writes {_registers(mdl)}"
    return None


def _temp_step(f: ResolvedFunction, entity: dict[str, Any], step: Decimal, notes: Notes) -> Decimal:
    """temp_step: the function's step, else the first of 2, 5 and 10 of them whose every target Home Assistant
    writes as mdl does (it cuts (value - offset) / scale to an integer where mdl rounds: 10.1 / 0.1 is
    100.99999999999999, written 100), warned; where none is, the function's step, warned."""
    wrong = _miswritten(f, entity, step) if step > 0 else None
    if wrong is None:
        return step
    for coarser in (step * 2, step * 5, step * 10):
        if _miswritten(f, entity, coarser) is None:
            notes.warn(
                f,
                "Home Assistant's climate cuts (value - offset) / scale to an integer where mdl rounds: "
                "it steps coarser, by the values it writes as mdl does",
                f"temp_step {plain_number(float(coarser))}: by {plain_number(float(step))}, {wrong}",
            )
            return coarser
    notes.warn(
        f,
        "Home Assistant's climate writes some target temperatures other than mdl does (it cuts "
        "(value - offset) / scale to an integer where mdl rounds)",
        wrong,
    )
    return step


def _raw_values(f: ResolvedFunction) -> dict[int, str] | None:
    """An enumeration the climate reads and writes as mdl does (one whole register, unscaled): register
    value -> label; None for any other function."""
    lay = f.layout
    if not (f.fn.readable and f.fn.writable and f.fn.values) or written_by_fragment(f) or unreadable(f):
        return None
    if lay.table != "holding" or len(lay.addresses) != 1 or lay.kind != "int" or lay.bits != 16:
        return None
    if lay.unit != "word" or lay.byte_order != "big" or f.fn.bits is not None or f.fn.factor is not None:
        return None
    if scale_of(f) is not None:
        return None
    return {key & 0xFFFF: label for key, label in sorted(f.fn.values.items())}


def _mapped(raw: dict[int, str], modes: dict[str, str]) -> dict[int, str | None]:
    return {value: modes.get(_label(label)) for value, label in raw.items()}


def _hvac_mode(resolved: ResolvedDevice, taken: set[int], notes: Notes) -> tuple[ResolvedFunction, Any] | None:
    """The HVAC mode function and its hvac_mode_register, or None."""
    candidates = sorted(
        (f for f in resolved.functions if f.layout.addresses[0] not in taken and _raw_values(f) is not None),
        key=lambda f: _rank(f, (MODE_ROLE,)),
    )
    for f in candidates:
        raw = _raw_values(f)
        assert raw is not None
        mapped = _mapped(raw, HVAC_MODES)
        known = {value: mode for value, mode in mapped.items() if mode is not None}
        if f.fn.role == MODE_ROLE and known:
            unknown = [f"{value} {raw[value]!r}" for value, mode in mapped.items() if mode is None]
            if unknown:
                notes.warn(f, "Home Assistant's climate shows no HVAC mode for these values", ", ".join(unknown))
        elif len(known) != len(raw) or not _CONDITIONING & set(known.values()):
            continue
        grouped: dict[str, list[int]] = {}
        for value, mode in known.items():
            grouped.setdefault(mode, []).append(value)
        values: dict[str, Any] = {mode: found[0] if len(found) == 1 else found for mode, found in grouped.items()}
        notes.note_for(
            f,
            "its labels taken as Home Assistant's HVAC modes",
            ", ".join(f"{value} {mode.removeprefix('state_')}" for value, mode in known.items()),
        )
        register: dict[str, Any] = {"address": f.layout.addresses[0], "values": values}
        if write_code(f) == 16:
            register["write_registers"] = True
        return f, register
    return None


def _fan_mode(resolved: ResolvedDevice, taken: set[int], notes: Notes) -> tuple[ResolvedFunction, Any] | None:
    """The fan mode function (an enumeration of Home Assistant's fan modes, one a speed) and its
    fan_mode_register, or None."""
    for f in resolved.functions:
        raw = _raw_values(f) if f.layout.addresses[0] not in taken else None
        if raw is None:
            continue
        mapped = _mapped(raw, FAN_MODES)
        modes = list(mapped.values())
        if None in modes or len(set(modes)) != len(modes) or not _SPEEDS & set(modes):
            continue
        notes.note_for(
            f,
            "its labels taken as Home Assistant's fan modes",
            ", ".join(f"{value} {str(mode).removeprefix('state_fan_')}" for value, mode in mapped.items()),
        )
        address = f.layout.addresses[0]  # a list of one: Home Assistant writes it with function 16
        return f, {
            "address": [address] if write_code(f) == 16 else address,
            "values": {str(mode): value for value, mode in mapped.items()},
        }
    return None


def climate_of(resolved: ResolvedDevice, notes: Notes) -> Climate | None:
    """The thermostat's climate, or None where the description has no writable temperature that Home
    Assistant's climate reads with a room temperature."""
    for target in _targets(resolved):
        current = _current(resolved, target)
        if current is not None:
            return _climate(resolved, target, current, notes)
    return None


def _climate(resolved: ResolvedDevice, target: ResolvedFunction, current: ResolvedFunction, notes: Notes) -> Climate:
    kind = _kind(target)
    assert kind is not None
    entity: dict[str, Any] = {
        "address": current.layout.addresses[0],
        "input_type": "input" if current.layout.table == "input" else "holding",
        **kind,
    }
    multiplier, offset = _scaling(target)
    if multiplier != 1:
        entity["scale"] = multiplier
    if offset != 0:
        entity["offset"] = offset
    shown = [p for p in (_places(current), _places(target)) if p is not None]
    places = max(shown) if shown else None
    if places:
        entity["precision"] = places
    entity["target_temp_register"] = target.layout.addresses[0]
    if len(target.layout.addresses) == 1 and write_code(target) == 16:
        entity["target_temp_write_registers"] = True
    entity["temperature_unit"] = _unit(target)
    low, high = _limits(target)
    if target.fn.minimum is None or target.fn.maximum is None:
        notes.note_for(
            target,
            "no minimum or maximum: the climate's min_temp and max_temp are what its register holds",
            f"{plain_number(float(low))}..{plain_number(float(high))}",
        )
    entity.update(min_temp=_number(low), max_temp=_number(high))
    entity["temp_step"] = _number(_temp_step(target, entity, _step(target, places), notes))
    for f in (current, target):
        warn_patterns(
            f, notes, "a climate has no 'not implemented' value: the values that mean it read as temperatures"
        )
    climate = Climate(target, current, entity, {target.name: "its target temperature"})
    taken = {*target.layout.addresses, *current.layout.addresses}
    if len(target.layout.addresses) == 1:  # the climate reads a mode register with as many registers as a temperature
        hvac = _hvac_mode(resolved, taken, notes)
        if hvac is not None:
            entity["hvac_mode_register"] = hvac[1]
            climate.writes[hvac[0].name] = "its HVAC mode"
            taken.add(hvac[0].layout.addresses[0])
        fan = _fan_mode(resolved, taken, notes)
        if fan is not None:
            entity["fan_mode_register"] = fan[1]
            climate.writes[fan[0].name] = "its fan mode"
    return climate
