"""A device's functions bound to a profile's roles (SPEC 13): which function plays each role, and how
its value becomes the role's (role value = value * factor + offset: a unit converted, a sign turned
for a function that plays the role's `opposite`); which roles the device lacks; and what cannot be
bound (a role given twice, a unit of another quantity, text where a number is meant)."""

from __future__ import annotations

from dataclasses import dataclass, field

from mdl.model.units import conversion, spell
from mdl.profiles.load import RATIO, Profile, Role
from mdl.resolver import ResolvedDevice, ResolvedFunction

_KINDS = {"float": ("int", "float"), "int": ("int",), "bool": ("bool",)}
_EXPR_KINDS = {"float": ("long", "double"), "int": ("long",), "bool": ("bool",)}


@dataclass(frozen=True)
class Binding:
    """The function that plays a role and how its value converts: role = value * factor + offset."""

    role: Role
    function: ResolvedFunction
    factor: float = 1.0
    offset: float = 0.0
    writable: bool = False  # the role is written (read_write) and the function can be

    @property
    def converts(self) -> bool:
        return self.factor != 1.0 or self.offset != 0.0


@dataclass
class Fit:
    profile: Profile
    bound: dict[str, Binding] = field(default_factory=dict)  # role name -> binding, in the profile's order
    problems: list[tuple[str, str]] = field(default_factory=list)  # (function, what is wrong): errors
    notes: list[tuple[str, str]] = field(default_factory=list)  # (function, what was taken): said

    @property
    def missing(self) -> list[Role]:
        return [r for r in self.profile.roles.values() if r.name not in self.bound]

    @property
    def missing_required(self) -> list[Role]:
        return [r for r in self.missing if r.required]

    @property
    def ok(self) -> bool:
        return not self.problems and not self.missing_required


def fit(profile: Profile, device: ResolvedDevice) -> Fit:
    out = Fit(profile)
    opposites = {r.opposite: r for r in profile.roles.values() if r.opposite}
    found: dict[str, tuple[ResolvedFunction, float]] = {}
    for rf in device.functions:
        name = rf.fn.role
        if name is None:
            continue
        role, sign = (profile.roles[name], 1.0) if name in profile.roles else (opposites.get(name), -1.0)
        if role is None:
            out.notes.append((rf.name, f"role '{name}' is not one of profile {profile.name}'s: left out"))
            continue
        if role.name in found:
            other = found[role.name][0].name
            out.problems.append((rf.name, f"plays {role.name}, which {other} plays already"))
            continue
        found[role.name] = (rf, sign)
    for role in profile.roles.values():
        if role.name in found:
            rf, sign = found[role.name]
            binding = _bind(role, rf, sign, out)
            if binding is not None:
                out.bound[role.name] = binding
    return out


def _bind(role: Role, rf: ResolvedFunction, sign: float, out: Fit) -> Binding | None:
    as_role = f"as {role.name}" if sign > 0 else f"as {role.name} (its role {role.opposite}: the sign turned)"
    vt = rf.codec.value_type
    kinds = _EXPR_KINDS[role.type] if vt.kind == "expr" else _KINDS[role.type]
    kind = vt.expr_type if vt.kind == "expr" else vt.kind
    if kind not in kinds or not rf.fn.readable:
        what = "cannot be read" if not rf.fn.readable else f"reads {kind}, not {role.type}"
        out.problems.append((rf.name, f"{as_role}: {what}"))
        return None
    factor, offset = 1.0, 0.0
    units = (rf.fn.units or "").strip()
    if role.unit == RATIO:
        if units and spell(units).unit == "%":  # `%`, `Pct`, `percent`: a ratio in hundredths
            factor = 0.01
        elif units and units != RATIO:
            out.problems.append((rf.name, f"{as_role}: units '{units[:40]}' are not a plain number or %"))
            return None
    elif role.unit is not None:
        if not units:
            out.notes.append((rf.name, f"{as_role}: no units given: taken as {role.unit}"))
        else:
            converted = conversion(units, role.unit)
            if converted is None:
                out.problems.append((rf.name, f"{as_role}: units '{units[:40]}' cannot be converted to {role.unit}"))
                return None
            factor, offset = converted
            guess = spell(units).guess
            if guess:
                out.notes.append((rf.name, f"{as_role}: {guess}"))
    writable = role.writable and rf.fn.writable
    if role.writable and not writable:
        out.notes.append((rf.name, f"{as_role}: read only here: writing {role.name} reports 'not provided'"))
    return Binding(role, rf, factor * sign, offset * sign, writable)
