"""`mdl export --names roles [--profile NAME]` (SPEC 13): points named after the profile roles their
functions play (`power_w` rather than a vendor's `p_tot`), so that one engine configuration reads every
vendor's meter alike. With a profile, the values are the role's too: its unit and sign folded into the
function's multiplier and offset (kW x 1000 -> W; a meter's `power_export_w` read as `power_w`, negated),
so the engine reads W from every vendor. The description is renamed and resolved again before any writer
sees it; a function is kept under its own name where its role's name is taken by another function, or
where another function names it (a scale factor, an expression), each said in a note."""

from __future__ import annotations

import re
from dataclasses import replace

from mdl.diagnostics import Diagnostic, MdlError
from mdl.model import Function
from mdl.profiles.fit import Binding, fit
from mdl.profiles.load import RATIO, Profile
from mdl.profiles.report import fit_diagnostics
from mdl.resolver import ResolvedDevice, resolve


def _referenced(device_functions: list[Function]) -> set[str]:
    """The names other functions refer to: scale factors and the fields expressions read."""
    out: set[str] = set()
    for fn in device_functions:
        out.update(n for n in (fn.scale_exponent, fn.scale_by) if n)
        if fn.expression:
            out.update(re.findall(r"[A-Za-z_][A-Za-z0-9_.]*", fn.expression))
    return out


def _converted(fn: Function, b: Binding) -> Function:
    """`fn` reading its role's value: role = value * factor + offset folded into multiplier and offset."""
    f, c = b.factor, b.offset
    if f == 1.0 and c == 0.0:
        return replace(fn, units=b.role.unit if b.role.unit not in (None, RATIO) else fn.units)
    low, high = (None if v is None else v * f + c for v in (fn.minimum, fn.maximum))
    if f < 0:
        low, high = high, low
    offset = (fn.offset or 0.0) * f + c
    return replace(
        fn,
        multiplier=(fn.multiplier if fn.multiplier is not None else 1.0) * f,
        offset=offset or None,
        minimum=low,
        maximum=high,
        units=b.role.unit if b.role.unit != RATIO else None,
    )


def named_by_roles(resolved: ResolvedDevice, profile: Profile | None = None) -> tuple[ResolvedDevice, list[Diagnostic]]:
    device = resolved.device
    names = {fn.name for fn in device.functions}
    referenced = _referenced(device.functions)
    bound: dict[str, Binding] = {}
    if profile is not None:
        fitted = fit(profile, resolved)
        if fitted.problems:  # a value that cannot be given in its role's unit is not renamed as if it could
            found = fit_diagnostics(str(device.source or ""), fitted, {f.name: f for f in device.functions})
            raise MdlError([d for d in found if d.severity == "error"])
        bound = {b.function.name: b for b in fitted.bound.values()}
    renamed, kept = [], []
    taken = set(names)
    functions = []
    for fn in device.functions:
        binding = bound.get(fn.name)
        role = binding.role.name if binding else fn.role
        if role is None or (role == fn.name and binding is None):
            functions.append(fn)
            continue
        if (role in taken and role != fn.name) or fn.name in referenced:
            why = f"'{role}' is another function's name" if role in taken else "other functions refer to it"
            kept.append(f"{fn.name} ({why})")
            functions.append(fn)
            continue
        taken.discard(fn.name)
        taken.add(role)
        if binding is not None and binding.converts:
            renamed.append(
                f"{fn.name} as {role} (x {binding.factor:g}{f' + {binding.offset:g}' if binding.offset else ''})"
            )
        elif role != fn.name:
            renamed.append(f"{fn.name} as {role}")
        functions.append(replace(_converted(fn, binding) if binding else fn, name=role))
    notes = []
    where = device.source
    if renamed:
        notes.append(Diagnostic(where, None, None, f"--names roles: {', '.join(renamed)}", "note"))
    if kept:
        notes.append(Diagnostic(where, None, None, f"--names roles: kept their names: {', '.join(kept)}", "note"))
    if not renamed and not kept:
        notes.append(Diagnostic(where, None, None, "--names roles: no function has a role: names unchanged", "note"))
        return resolved, notes
    again = replace(device, functions=functions)
    return resolve(again, where), notes
