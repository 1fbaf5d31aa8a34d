"""What an engine export's warnings say, taken apart (tests/unit/exports/test_export_warnings.py), and the units
and classes Home Assistant accepts."""

from __future__ import annotations

import re

_LINE = re.compile(
    r"^(?P<file>.*?)(?::(?P<line>\d+))?: (?P<severity>warning|note): "
    r"(?P<subject>functions? '.*?): (?P<engine>Home Assistant|Telegraf|VOLTTRON): (?P<kind>.*)$"
)


_BARE = re.compile(r"^(?P<file>.*?)(?::(?P<line>\d+))?: (?P<severity>warning|note): (?P<rest>functions? '.*)$")


_DETAIL = re.compile(r" \([^()]*\)")


# Home Assistant 2024.3's units and state classes for the device classes the export writes
# (homeassistant.components.sensor.const DEVICE_CLASS_UNITS, DEVICE_CLASS_STATE_CLASSES)
ACCEPTED: dict[str, tuple[set[str], set[str]]] = {
    "voltage": ({"V", "mV"}, {"measurement"}),
    "current": ({"A", "mA"}, {"measurement"}),
    "power": ({"W", "kW"}, {"measurement"}),
    "apparent_power": ({"VA"}, {"measurement"}),
    "reactive_power": ({"var"}, {"measurement"}),
    "energy": ({"Wh", "kWh", "MWh", "MJ", "GJ"}, {"total", "total_increasing"}),
    "frequency": ({"Hz", "kHz", "MHz", "GHz"}, {"measurement"}),
    "temperature": ({"°C", "°F", "K"}, {"measurement"}),
    "humidity": ({"%"}, {"measurement"}),
    "pressure": ({"Pa", "hPa", "kPa", "bar", "cbar", "mbar", "psi", "inHg", "mmHg"}, {"measurement"}),
    "volume": ({"m³", "L", "mL", "gal", "ft³", "CCF", "fl. oz."}, {"total", "total_increasing"}),
    "volume_flow_rate": ({"L/min", "m³/h", "gal/min", "ft³/min"}, {"measurement"}),
    "duration": ({"ms", "s", "min", "h", "d"}, {"measurement", "total", "total_increasing"}),
    "illuminance": ({"lx"}, {"measurement"}),
    "signal_strength": ({"dB", "dBm"}, {"measurement"}),
    "speed": ({"m/s", "km/h", "mph", "kn", "ft/s", "in/d", "in/h", "mm/d", "mm/h"}, {"measurement"}),
    "irradiance": ({"W/m²", "BTU/(h⋅ft²)"}, {"measurement"}),
    "distance": ({"mm", "cm", "m", "km", "in", "ft", "yd", "mi"}, {"measurement", "total", "total_increasing"}),
    "weight": ({"kg", "g", "mg", "µg", "oz", "lb", "st"}, {"measurement", "total", "total_increasing"}),
}


def said(stderr: str) -> list[dict]:
    """Each warning or note about functions: file, line, severity, engine (None for XIF and WISE, whose warnings
    name none), kind and the functions it names."""
    out = []
    for text in stderr.splitlines():
        m = _LINE.match(text)
        found = m.groupdict() if m else _bare(text)
        if found:
            subject = _DETAIL.sub("", found["subject"].split(" ", 1)[1])
            out.append({**found, "names": re.findall(r"'([^']*)'", subject)})
    return out


def _bare(text: str) -> dict | None:
    """A warning about functions that names no engine (XIF, WISE): its subject ends at the first `: ` outside
    quotes and parentheses."""
    m = _BARE.match(text)
    if m is None:
        return None
    rest, depth, quoted = m["rest"], 0, False
    for i, ch in enumerate(rest):
        if ch == "'" and depth == 0:
            quoted = not quoted
        elif not quoted:
            depth += {"(": 1, ")": -1}.get(ch, 0)
            if depth == 0 and rest.startswith(": ", i):
                return {
                    **{k: m[k] for k in ("file", "line", "severity")},
                    "subject": rest[:i],
                    "engine": None,
                    "kind": rest[i + 2 :],
                }
    return None


def named(stderr: str, engine: str, fragment: str, severity: str = "warning") -> set[str]:
    """The functions named by the engine's warnings (or notes) that hold `fragment`."""
    return {
        name
        for d in said(stderr)
        if d["engine"] == engine and d["severity"] == severity and fragment in d["kind"]
        for name in d["names"]
    }


def assert_one_per_kind(stderr: str) -> None:
    found = said(stderr)
    kinds = [(d["severity"], d["engine"], d["kind"]) for d in found]
    assert len(kinds) == len(set(kinds)), stderr  # each kind once
    for d in found:
        assert len(d["names"]) == len(set(d["names"])), d  # each function once in it
        assert d["subject"].startswith("functions " if len(d["names"]) > 1 else "function "), d
