"""The profile role each well-known SunSpec point plays (SPEC 13: models 101-103, 111-113, 201-204,
701-714 map to roles by point). SunSpec fixes what these points mean, their units and signs (a meter's
W is positive when importing, an inverter's when producing), so the roles are certain, not guessed:
`mdl import --from sunspec` sets them, and a note lists them. One home for the table: the SunSpec
gateway serves a profile's roles through the same points."""

from __future__ import annotations

from mdl.diagnostics import Diagnostic
from mdl.model import Function

_PHASES = {"A": "l1", "B": "l2", "C": "l3"}
_METER = {
    "W": "power_w",
    "TotWhImp": "energy_import_wh",
    "TotWhExp": "energy_export_wh",
    **{f"Wph{p}": f"power_{n}_w" for p, n in _PHASES.items()},
    **{f"PhVph{p}": f"voltage_{n}_v" for p, n in _PHASES.items()},
    **{f"Aph{p}": f"current_{n}_a" for p, n in _PHASES.items()},
    "Hz": "frequency_hz",
    "PF": "power_factor",
    "VAR": "reactive_power_var",
    "VA": "apparent_power_va",
}
_INVERTER = {
    "W": "power_w",
    "WH": "energy_wh",
    "DCW": "dc_power_w",
    "St": "status",
    "PhVphA": "voltage_v",
    "A": "current_a",
    "Hz": "frequency_hz",
    "TmpCab": "temperature_c",
}
# model id -> point name -> role (the profile it belongs to is the model's kind)
ROLES: dict[int, dict[str, str]] = {
    **{m: _INVERTER for m in (101, 102, 103, 111, 112, 113)},
    **{m: _METER for m in (201, 202, 203, 204)},
    123: {"WMaxLimPct": "power_limit_pct"},
    701: {
        "St": "status",
        "W": "power_w",
        "TotWhInj": "energy_wh",
        "A": "current_a",
        "LNV": "voltage_v",
        "Hz": "frequency_hz",
        "TmpCab": "temperature_c",
    },
    704: {"WMaxLimPct": "power_limit_pct"},  # 702-712 hold ratings, settings and curves: no other role
    713: {"SoC": "soc_pct", "SoH": "soh_pct", "WHRtg": "capacity_wh"},
    714: {"DCW": "dc_power_w"},
    802: {
        "SoC": "soc_pct",
        "SoH": "soh_pct",
        "WHRtg": "capacity_wh",
        "W": "power_w",
        "V": "voltage_v",
        "A": "current_a",
    },
}


def assign_roles(functions: list[Function], models: list[tuple[int, str]]) -> list[Diagnostic]:
    """Set the role of each known point of the chain's models ((model id, its functions' prefix), in
    chain order); a role is played once: a later model's point that would play it again keeps none.
    Returns the notes that say what was set and what was not."""
    by_name = {fn.name: fn for fn in functions}
    taken: dict[str, str] = {}
    set_, again = [], []
    for mid, prefix in models:
        for point, role in ROLES.get(mid, {}).items():
            fn = by_name.get(f"{prefix}_{point}")
            if fn is None:
                continue
            if role in taken:
                again.append(f"{fn.name} ({role}: {taken[role]} plays it)")
                continue
            fn.role, taken[role] = role, fn.name
            set_.append(f"{fn.name} {role}")
    notes = []
    if set_:
        notes.append(Diagnostic(None, None, None, f"roles from the SunSpec points: {', '.join(set_)}", "note"))
    if again:
        notes.append(Diagnostic(None, None, None, f"left without a role: {', '.join(again)}", "note"))
    return notes
