"""Units as Home Assistant spells and classes them, for `mdl export --to homeassistant` (docs/fleet.md).

A vendor's spelling of a unit (`Volts`, `Amps`, `KWH`, `degC`, `m3`) -> Home Assistant's (`V`, `A`,
`kWh`, `°C`, `m³`), and from that the sensor's `device_class` and `state_class`. Only combinations that
Home Assistant 2024.3 accepts are written (homeassistant.components.sensor.const DEVICE_CLASS_UNITS and
DEVICE_CLASS_STATE_CLASSES; later releases only add units): a unit Home Assistant's class does not
take there (kV, MW, kVA, kvar, kvarh) gets a state_class and no device_class. Where the class is a
guess (an energy reading taken as a counter that only grows, `C` taken as degrees Celsius) the entry
says why, and the export says it in a note.

Symbols are matched as written (case matters: mW and MW differ), after trimming spaces; words
(`volts`, `Celsius`, `kilowatt hours`) in any case.
"""

from __future__ import annotations

from dataclasses import dataclass

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

# a vendor's symbol -> Home Assistant's, matched as written; every spelling in CLASSES stands for itself
_SYMBOLS: dict[str, str] = {
    "VAC": "V",
    "VDC": "V",
    "Vac": "V",
    "Vdc": "V",
    "V AC": "V",
    "V DC": "V",
    "KV": "kV",
    "KW": "kW",
    "Kw": "kW",
    "KVA": "kVA",
    "kva": "kVA",
    "VAr": "var",
    "VAR": "var",
    "Var": "var",
    "kVAr": "kvar",
    "kVAR": "kvar",
    "KVAR": "kvar",
    "kVar": "kvar",
    "Kvar": "kvar",
    "WH": "Wh",
    "KWH": "kWh",
    "kWH": "kWh",
    "KWh": "kWh",
    "kwh": "kWh",
    "Kwh": "kWh",
    "MWH": "MWh",
    "VArh": "varh",
    "VARh": "varh",
    "VARH": "varh",
    "kVArh": "kvarh",
    "kVARh": "kvarh",
    "KVARH": "kvarh",
    "kVarh": "kvarh",
    "kvarH": "kvarh",
    "KVARh": "kvarh",
    "Kvarh": "kvarh",
    "HZ": "Hz",
    "hz": "Hz",
    "KHZ": "kHz",
    "KHz": "kHz",
    "ºC": "°C",
    "℃": "°C",
    "° C": "°C",
    "degC": "°C",
    "deg C": "°C",
    "DegC": "°C",
    "DEG C": "°C",
    "ºF": "°F",
    "℉": "°F",
    "° F": "°F",
    "degF": "°F",
    "deg F": "°F",
    "DegF": "°F",
    "DEG F": "°F",
    "PA": "Pa",
    "KPA": "kPa",
    "KPa": "kPa",
    "kpa": "kPa",
    "HPA": "hPa",
    "hpa": "hPa",
    "Bar": "bar",
    "BAR": "bar",
    "mBar": "mbar",
    "MBAR": "mbar",
    "PSI": "psi",
    "Psi": "psi",
    "m3": "m³",
    "M3": "m³",
    "m^3": "m³",
    "l": "L",
    "ml": "mL",
    "ML": "mL",
    "ft3": "ft³",
    "l/min": "L/min",
    "LPM": "L/min",
    "lpm": "L/min",
    "l/m": "L/min",
    "m3/h": "m³/h",
    "m3/hr": "m³/h",
    "m³/hr": "m³/h",
    "GPM": "gal/min",
    "gpm": "gal/min",
    "CFM": "ft³/min",
    "cfm": "ft³/min",
    "sec": "s",
    "secs": "s",
    "mins": "min",
    "hr": "h",
    "hrs": "h",
    "Hr": "h",
    "Hrs": "h",
    "lux": "lx",
    "Lux": "lx",
    "LUX": "lx",
    "PPM": "ppm",
    "DBM": "dBm",
    "dbm": "dBm",
    "W/m2": "W/m²",
    "W/M2": "W/m²",
    "RPM": "rpm",
    "Rpm": "rpm",
    "r/min": "rpm",
}
# words, in any case -> Home Assistant's spelling
_WORDS: dict[str, str] = {
    "volt": "V",
    "volts": "V",
    "millivolt": "mV",
    "millivolts": "mV",
    "kilovolt": "kV",
    "kilovolts": "kV",
    "amp": "A",
    "amps": "A",
    "ampere": "A",
    "amperes": "A",
    "milliamp": "mA",
    "milliamps": "mA",
    "milliampere": "mA",
    "milliamperes": "mA",
    "watt": "W",
    "watts": "W",
    "kilowatt": "kW",
    "kilowatts": "kW",
    "megawatt": "MW",
    "megawatts": "MW",
    "watt hour": "Wh",
    "watt hours": "Wh",
    "watt-hour": "Wh",
    "watt-hours": "Wh",
    "kilowatt hour": "kWh",
    "kilowatt hours": "kWh",
    "kilowatt-hour": "kWh",
    "kilowatt-hours": "kWh",
    "megawatt hour": "MWh",
    "megawatt hours": "MWh",
    "megawatt-hour": "MWh",
    "megawatt-hours": "MWh",
    "hertz": "Hz",
    "celsius": "°C",
    "degree celsius": "°C",
    "degrees celsius": "°C",
    "deg. c": "°C",
    "degrees c": "°C",
    "fahrenheit": "°F",
    "degree fahrenheit": "°F",
    "degrees fahrenheit": "°F",
    "deg. f": "°F",
    "degrees f": "°F",
    "kelvin": "K",
    "percent": "%",
    "pct": "%",
    "pascal": "Pa",
    "pascals": "Pa",
    "kilopascal": "kPa",
    "kilopascals": "kPa",
    "millibar": "mbar",
    "millibars": "mbar",
    "cubic meter": "m³",
    "cubic meters": "m³",
    "cubic metre": "m³",
    "cubic metres": "m³",
    "liter": "L",
    "liters": "L",
    "litre": "L",
    "litres": "L",
    "gallon": "gal",
    "gallons": "gal",
    "second": "s",
    "seconds": "s",
    "millisecond": "ms",
    "milliseconds": "ms",
    "minute": "min",
    "minutes": "min",
    "hour": "h",
    "hours": "h",
    "day": "d",
    "days": "d",
}
_HUMIDITY = {"%rh", "% rh", "rh", "%r.h.", "rh%", "% r.h.", "relative humidity"}  # in any case
# symbols that could mean something else: Home Assistant's spelling and the guess said
_GUESSED: dict[str, tuple[str, str]] = {
    "C": ("°C", "'C' taken as degrees Celsius (not coulombs)"),
    "F": ("°F", "'F' taken as degrees Fahrenheit (not farads)"),
    "K": ("K", "'K' taken as kelvin (not a thousand)"),
    "m": ("m", "'m' taken as metres (not minutes)"),
}


@dataclass(frozen=True)
class HaUnit:
    """A function's unit as the export writes it: Home Assistant's spelling and classes, and what is guessed."""

    unit: str
    device_class: str | None = None
    state_class: str | None = None
    guesses: tuple[str, ...] = ()  # each guess made, to be said


def ha_unit(units: str) -> HaUnit:
    """`units` (an MDL function's) as Home Assistant spells and classes it; a unit it does not know stays as
    written, without classes."""
    text = units.strip()
    if text.lower() in _HUMIDITY:
        return HaUnit("%", HUMIDITY.device_class, HUMIDITY.state_class)
    guesses: tuple[str, ...] = ()
    words = " ".join(text.lower().split())
    if text in _GUESSED:
        spelled, guess = _GUESSED[text]
        guesses = (guess,)
    elif text in CLASSES:
        spelled = text
    elif text in _SYMBOLS:
        spelled = _SYMBOLS[text]
    elif words in _WORDS:
        spelled = _WORDS[words]
    else:
        return HaUnit(units)
    found = CLASSES[spelled]
    return HaUnit(spelled, found.device_class, found.state_class, guesses + ((found.guess,) if found.guess else ()))
