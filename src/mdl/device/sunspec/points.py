"""The SunSpec gateway's table (SPEC 13, docs/sunspec.md "Gateway"): which SunSpec models serve each
profile, which point each role becomes (from mdl.formats.sunspec.roles, the table `mdl import --from
sunspec` reads the other way), and the scale factors' ranges. Data only: the gateway
(mdl.device.sunspec.gateway) reads it.

A profile's candidate models are tried in order: the first whose trigger roles the device binds (any
of them; none listed: always) is served, after model 1 (common). A point is one role's value, or a
sum or mean of several roles (only when the device binds all of them); `scale` turns the role's unit
into the point's (a power factor of -1..1 into SunSpec's percent).
"""

from __future__ import annotations

from dataclasses import dataclass

from mdl.formats.sunspec.roles import ROLES


@dataclass(frozen=True)
class Point:
    """A SunSpec point (its name in the model) served from roles: `how` is one, sum or mean."""

    point: str
    roles: tuple[str, ...]
    how: str = "one"
    scale: float = 1.0


def _one(point: str, role: str, scale: float = 1.0) -> Point:
    return Point(point, (role,), "one", scale)


PHASES_2_3 = frozenset(
    f"{kind}_l{n}_{unit}" for kind, unit in (("power", "w"), ("voltage", "v"), ("current", "a")) for n in (2, 3)
)

# profile name -> its candidate models, each (model id, trigger roles: any of them bound picks it)
MODELS: dict[str, tuple[tuple[int, frozenset[str]], ...]] = {
    "meter": ((203, PHASES_2_3), (201, frozenset())),
    "inverter": ((103, frozenset()),),
    "battery": ((802, frozenset({"power_w"})), (713, frozenset())),
}

# roles a gateway does not serve: a device's own status numbering is not SunSpec's St, and a limit is
# written, which the gateway does not do
NOT_SERVED = frozenset({"status", "power_limit_pct"})
POINT_SCALES = {"PF": 100.0}  # SunSpec's PF is in percent (units Pct); the role's is -1..1


def _from_roles(model: int) -> tuple[Point, ...]:
    """The points of `model` that play roles (mdl.formats.sunspec.roles, the one table of them)."""
    return tuple(
        _one(point, role, POINT_SCALES.get(point, 1.0))
        for point, role in ROLES[model].items()
        if role not in NOT_SERVED
    )


# model id -> the points served from roles (every other point of the model: "not implemented")
POINTS: dict[int, tuple[Point, ...]] = {
    201: (
        *_from_roles(201),
        Point("A", ("current_l1_a",), "sum"),  # single phase: the total is phase A's
        Point("PhV", ("voltage_l1_v",), "mean"),
    ),
    203: (
        *_from_roles(203),
        Point("A", ("current_l1_a", "current_l2_a", "current_l3_a"), "sum"),
        Point("PhV", ("voltage_l1_v", "voltage_l2_v", "voltage_l3_v"), "mean"),
    ),
    103: _from_roles(103),
    802: _from_roles(802),
    713: _from_roles(713),
}

# scale factor point -> (finest exponent, coarsest exponent): the finest at which every value it scales fits
SCALES: dict[str, tuple[int, int]] = {
    "W_SF": (-1, 5),
    "VA_SF": (-1, 5),
    "VAR_SF": (-1, 5),
    "VAr_SF": (-1, 5),
    "DCW_SF": (-1, 5),
    "V_SF": (-1, 4),
    "A_SF": (-2, 4),
    "Hz_SF": (-2, 2),
    "PF_SF": (-1, 1),
    "Tmp_SF": (-1, 2),
    "SoC_SF": (-1, 1),
    "SoH_SF": (-1, 1),
    "Pct_SF": (-1, 1),
    "TotWh_SF": (0, 0),  # energies count up: one scale for ever, as meters keep it
    "WH_SF": (0, 0),
    "WHRtg_SF": (0, 4),
}
# where one model's scale factor scales something else than the name says elsewhere: model 713's WH_SF
# scales capacities (WHRtg, WHAvail), not an energy counter
MODEL_SCALES: dict[tuple[int, str], tuple[int, int]] = {(713, "WH_SF"): (0, 4)}
