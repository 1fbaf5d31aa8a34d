"""Units as Home Assistant spells and classes them, for `mdl export --to homeassistant` (docs/fleet.md).

A vendor's spelling of a unit (`Volts`, `Amps`, `KWH`, `degC`, `m3`), spelled as mdl.model.units does
(`V`, `A`, `kWh`, `°C`, `m³`, Home Assistant's spellings too), and from that the sensor's
`device_class` and `state_class`. Only combinations that Home Assistant 2024.3 accepts are written
(homeassistant.components.sensor.const DEVICE_CLASS_UNITS and DEVICE_CLASS_STATE_CLASSES; later
releases only add units): a unit Home Assistant's class does not take there (kV, MW, kVA, kvar,
kvarh) gets a state_class and no device_class. Where the class is a guess (an energy reading taken
as a counter that only grows, `C` taken as degrees Celsius) the entry says why, and the export says
it in a note.
"""

from __future__ import annotations

from dataclasses import dataclass

from mdl.model.units import spell

MEASUREMENT = "measurement"  # an instantaneous value
TOTAL_INCREASING = "total_increasing"  # a counter that only grows (a fall is a reset to 0)

_COUNTER = (
    "taken as a meter's counter that only grows (state_class total_increasing{}); one that can fall (net "
    "or bidirectional energy) needs state_class total"
)
_ENERGY = "an energy reading " + _COUNTER.format(", as the Energy dashboard needs")
_REACTIVE = "a reactive energy reading " + _COUNTER.format("")
_VOLUME = (
    "a volume taken as a meter's counter that only grows (device_class volume, state_class "
    "total_increasing); a gas or water meter for the Energy dashboard needs device_class gas or water, "
    "a tank's content device_class volume_storage with state_class measurement"
)


@dataclass(frozen=True)
class UnitClass:
    """How Home Assistant classes a sensor in this unit: device_class (None: no class takes the unit)."""

    device_class: str | None
    state_class: str
    guess: str | None = None  # why the classes are a guess (said in a note), None when certain


# Home Assistant's spelling -> its classes (DEVICE_CLASS_UNITS of Home Assistant 2024.3)
CLASSES: dict[str, UnitClass] = {
    **{u: UnitClass("voltage", MEASUREMENT) for u in ("V", "mV")},
    "kV": UnitClass(None, MEASUREMENT),
    **{u: UnitClass("current", MEASUREMENT) for u in ("A", "mA")},
    **{u: UnitClass("power", MEASUREMENT) for u in ("W", "kW")},
    "MW": UnitClass(None, MEASUREMENT),
    "VA": UnitClass("apparent_power", MEASUREMENT),
    "kVA": UnitClass(None, MEASUREMENT),
    "var": UnitClass("reactive_power", MEASUREMENT),
    "kvar": UnitClass(None, MEASUREMENT),
    **{u: UnitClass("energy", TOTAL_INCREASING, _ENERGY) for u in ("Wh", "kWh", "MWh")},
    **{u: UnitClass(None, TOTAL_INCREASING, _REACTIVE) for u in ("varh", "kvarh")},
    **{u: UnitClass("frequency", MEASUREMENT) for u in ("Hz", "kHz", "MHz")},
    **{u: UnitClass("temperature", MEASUREMENT) for u in ("°C", "°F", "K")},
    "%": UnitClass(None, MEASUREMENT),
    **{
        u: UnitClass("pressure", MEASUREMENT)
        for u in ("Pa", "hPa", "kPa", "bar", "cbar", "mbar", "psi", "inHg", "mmHg")
    },
    **{u: UnitClass("volume", TOTAL_INCREASING, _VOLUME) for u in ("m³", "L", "mL", "gal", "ft³")},
    **{u: UnitClass("volume_flow_rate", MEASUREMENT) for u in ("L/min", "m³/h", "gal/min", "ft³/min")},
    **{u: UnitClass("duration", MEASUREMENT) for u in ("ms", "s", "min", "h", "d")},
    "lx": UnitClass("illuminance", MEASUREMENT),
    "ppm": UnitClass(None, MEASUREMENT),
    "dBm": UnitClass("signal_strength", MEASUREMENT),
    **{u: UnitClass("speed", MEASUREMENT) for u in ("m/s", "km/h", "mph", "kn")},
    "W/m²": UnitClass("irradiance", MEASUREMENT),
    **{u: UnitClass("distance", MEASUREMENT) for u in ("mm", "cm", "m", "km")},
    "kg": UnitClass("weight", MEASUREMENT),
    "rpm": UnitClass(None, MEASUREMENT),
}
HUMIDITY = UnitClass("humidity", MEASUREMENT)  # "%" of relative humidity (%RH): Home Assistant writes it "%"


# a profile role (SPEC 13) -> the classes it certainly has, and the units Home Assistant takes for them
ROLE_CLASSES: dict[str, tuple[UnitClass, tuple[str, ...]]] = {
    "power_factor": (UnitClass("power_factor", MEASUREMENT), ("", "%")),
    "soc_pct": (UnitClass("battery", MEASUREMENT), ("%",)),
    "humidity_pct": (HUMIDITY, ("%",)),
    "capacity_wh": (UnitClass("energy_storage", MEASUREMENT), ("Wh", "kWh", "MWh")),
}
COUNTER_ROLES = frozenset({"energy_import_wh", "energy_export_wh", "energy_wh", "session_energy_wh"})


@dataclass(frozen=True)
class HaUnit:
    """A function's unit as the export writes it: Home Assistant's spelling and classes, and what is guessed."""

    unit: str
    device_class: str | None = None
    state_class: str | None = None
    guesses: tuple[str, ...] = ()  # each guess made, to be said


def ha_unit(units: str, role: str | None = None) -> HaUnit:
    """`units` (an MDL function's) as Home Assistant spells and classes it (mdl.model.units spells it); a
    unit it does not know stays as written, without classes. A profile role makes the class certain: a
    power factor, a state of charge, a capacity; an energy role is a counter, no guess."""
    spelled = spell(units)
    if role in ROLE_CLASSES:
        classes, taken = ROLE_CLASSES[role]
        unit = "%" if spelled.unit == "%" else (spelled.unit or units.strip())
        if unit in taken:
            return HaUnit(unit, classes.device_class, classes.state_class)
    if role in COUNTER_ROLES and spelled.unit in ("Wh", "kWh", "MWh"):
        found = CLASSES[spelled.unit]
        return HaUnit(spelled.unit, found.device_class, found.state_class)
    if spelled.humidity:
        return HaUnit("%", HUMIDITY.device_class, HUMIDITY.state_class)
    if spelled.unit is None or spelled.unit not in CLASSES:
        return HaUnit(units)
    found = CLASSES[spelled.unit]
    guesses = tuple(g for g in (spelled.guess, found.guess) if g)
    return HaUnit(spelled.unit, found.device_class, found.state_class, guesses)
