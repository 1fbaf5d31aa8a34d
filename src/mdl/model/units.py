"""Units as vendors write them and as mdl spells them: one home for the spellings (`Volts`, `KWH`, `degC`,
`m3` -> `V`, `kWh`, `°C`, `m³`), the symbols that are a guess (`C` for degrees Celsius), and how each
spelling converts to the SI unit of its quantity (`kWh` -> 1000 `Wh`, `°F` -> `°C`). Home Assistant's
export (mdl.exports.ha_units) and profiles (mdl.profiles) read them.

Symbols are matched as written (case matters: mW and MW differ), after trimming spaces; words
(`volts`, `Celsius`, `kilowatt hours`) in any case.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

# a vendor's symbol -> its usual spelling, matched as written; every spelling in SI stands for itself
SYMBOLS: dict[str, str] = {
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
# words, in any case -> the usual spelling
WORDS: dict[str, str] = {
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
HUMIDITY_WORDS = {"%rh", "% rh", "rh", "%r.h.", "rh%", "% r.h.", "relative humidity"}  # in any case
# symbols that could mean something else: the spelling taken and the guess said
GUESSED: dict[str, tuple[str, str]] = {
    "C": ("°C", "'C' taken as degrees Celsius (not coulombs)"),
    "F": ("°F", "'F' taken as degrees Fahrenheit (not farads)"),
    "K": ("K", "'K' taken as kelvin (not a thousand)"),
    "m": ("m", "'m' taken as metres (not minutes)"),
}


@dataclass(frozen=True)
class Scale:
    """A spelling's value in the base unit of its quantity: base = value * factor + offset."""

    base: str
    factor: float
    offset: float = 0.0


_GALLON = 3.785411784e-3  # m³, the US gallon
_CUBIC_FOOT = 0.028316846592  # m³


def _same(base: str, *spellings: tuple[str, float]) -> dict[str, Scale]:
    return {unit: Scale(base, factor) for unit, factor in spellings}


# every spelling mdl knows -> its quantity's base unit (the unit profiles use: SI, with W, Wh, var, VA,
# Hz and °C named as meters and thermostats name them)
SI: dict[str, Scale] = {
    **_same("V", ("V", 1), ("mV", 1e-3), ("kV", 1e3)),
    **_same("A", ("A", 1), ("mA", 1e-3), ("kA", 1e3)),
    **_same("W", ("W", 1), ("kW", 1e3), ("MW", 1e6), ("mW", 1e-3)),
    **_same("VA", ("VA", 1), ("kVA", 1e3), ("MVA", 1e6)),
    **_same("var", ("var", 1), ("kvar", 1e3), ("Mvar", 1e6)),
    **_same("Wh", ("Wh", 1), ("kWh", 1e3), ("MWh", 1e6)),
    **_same("varh", ("varh", 1), ("kvarh", 1e3), ("Mvarh", 1e6)),
    **_same("VAh", ("VAh", 1), ("kVAh", 1e3)),
    **_same("Hz", ("Hz", 1), ("kHz", 1e3), ("MHz", 1e6)),
    "°C": Scale("°C", 1),
    "°F": Scale("°C", 5 / 9, -32 * 5 / 9),
    "K": Scale("°C", 1, -273.15),
    "%": Scale("%", 1),
    **_same(
        "Pa",
        ("Pa", 1),
        ("hPa", 100),
        ("kPa", 1e3),
        ("bar", 1e5),
        ("cbar", 1e3),
        ("mbar", 100),
        ("psi", 6894.757293168),
        ("inHg", 3386.389),
        ("mmHg", 133.322387415),
    ),
    **_same("m³", ("m³", 1), ("L", 1e-3), ("mL", 1e-6), ("gal", _GALLON), ("ft³", _CUBIC_FOOT)),
    **_same("m³/h", ("m³/h", 1), ("L/min", 1e-3 * 60), ("gal/min", _GALLON * 60), ("ft³/min", _CUBIC_FOOT * 60)),
    **_same("s", ("ms", 1e-3), ("s", 1), ("min", 60), ("h", 3600), ("d", 86400)),
    "lx": Scale("lx", 1),
    "ppm": Scale("ppm", 1),
    "dBm": Scale("dBm", 1),
    **_same("m/s", ("m/s", 1), ("km/h", 1 / 3.6), ("mph", 0.44704), ("kn", 1852 / 3600)),
    "W/m²": Scale("W/m²", 1),
    **_same("m", ("mm", 1e-3), ("cm", 1e-2), ("m", 1), ("km", 1e3)),
    **_same("kg", ("g", 1e-3), ("kg", 1)),
    "rpm": Scale("rpm", 1),
}


@dataclass(frozen=True)
class Spelled:
    """A unit as written, in mdl's spelling: `unit` (None: not a unit mdl knows), whether it is a relative
    humidity's percent, and the guess made (None when certain)."""

    unit: str | None
    humidity: bool = False
    guess: str | None = None


def spell(units: str) -> Spelled:
    """`units` as a function writes it -> mdl's spelling of the unit, with the guess made if any."""
    text = units.strip()
    if text.lower() in HUMIDITY_WORDS:
        return Spelled("%", humidity=True)
    if text in GUESSED:
        spelled, guess = GUESSED[text]
        return Spelled(spelled, guess=guess)
    if text in SI:
        return Spelled(text)
    if text in SYMBOLS:
        return Spelled(SYMBOLS[text])
    if re.fullmatch(r"%\s*[A-Za-z][A-Za-z0-9 ]*", text):  # `% WMax`, `%WHRtg`: a percent of a named quantity
        return Spelled("%")
    return Spelled(WORDS.get(" ".join(text.lower().split())))


def conversion(units: str, to: str) -> tuple[float, float] | None:
    """(factor, offset) turning a value in `units` (as written) into `to` (mdl's spelling):
    to_value = value * factor + offset; None when the two are not units of one quantity."""
    have, want = SI.get(spell(units).unit or ""), SI.get(to)
    if have is None or want is None or have.base != want.base:
        return None
    factor = have.factor / want.factor
    return factor, (have.offset - want.offset) / want.factor
