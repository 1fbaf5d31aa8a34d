"""What `mdl profiles` and `mdl validate --profile` print: a profile's roles, and how a device fits one
(docs/profiles.md)."""

from __future__ import annotations

import json

from mdl.diagnostics import Diagnostic, span_of
from mdl.exchange.text import aligned
from mdl.profiles.fit import Binding, Fit
from mdl.profiles.load import Profile, Role, load_profile, shipped


def listing() -> list[str]:
    """One line per shipped profile: its name, title and roles."""
    out = []
    for name in shipped():
        p = load_profile(name)
        required = sum(r.required for r in p.roles.values())
        out.append(f"{p.name:<12} {p.title} ({len(p.roles)} roles, {required} required)")
    return out


def _unit(role: Role) -> str:
    return role.unit if role.unit is not None else role.type


def roles_table(profile: Profile) -> list[str]:
    rows = [("role", "unit", "required", "access", "meaning")]
    for r in profile.roles.values():
        meaning = (
            r.description + (f"; {r.sign}" if r.sign else "") + (f" (or {r.opposite}, negated)" if r.opposite else "")
        )
        rows.append((r.name, _unit(r), "yes" if r.required else "", r.access, meaning))
    return [f"{profile.name}: {profile.title} ({profile.source})", *aligned(rows)]


def roles_json(profile: Profile) -> str:
    roles = [
        {
            "role": r.name,
            "unit": r.unit,
            "type": r.type,
            "required": r.required,
            "access": r.access,
            "sign": r.sign,
            "opposite": r.opposite,
            "description": r.description,
        }
        for r in profile.roles.values()
    ]
    return json.dumps({"name": profile.name, "title": profile.title, "roles": roles}, ensure_ascii=False, indent=2)


def _how(b: Binding) -> str:
    units = (b.function.fn.units or "").strip()
    if not b.converts:
        return units or "as read"
    offset = f" {'+' if b.offset >= 0 else '-'} {abs(b.offset):g}" if b.offset else ""
    return f"{units or 'as read'} x {b.factor:g}{offset}"


def fit_lines(path: str, fit: Fit) -> list[str]:
    """The summary `mdl validate --profile` prints on stdout."""
    p = fit.profile
    required = [r for r in p.roles.values() if r.required]
    have = sum(r.name in fit.bound for r in required)
    out = [f"{path}: profile {p.name}: {len(fit.bound)} of {len(p.roles)} roles ({have} of {len(required)} required)"]
    width = max(len(r) for r in p.roles)
    for name, b in fit.bound.items():
        out.append(f"  {name:<{width}}  <- {b.function.name} ({_how(b)}){' writable' if b.writable else ''}")
    if fit.missing:
        out.append(f"  not provided: {', '.join(r.name + (' (required)' if r.required else '') for r in fit.missing)}")
    return out


def fit_diagnostics(path: str, fit: Fit, device_functions: dict[str, object]) -> list[Diagnostic]:
    """Errors (a required role missing, a role that cannot be bound) and notes (each guess), each at
    the function's <role> where the file says it."""
    out = []
    for severity, items in (("error", fit.problems), ("note", fit.notes)):
        for name, message in items:
            span = span_of(device_functions[name], "role")
            out.append(
                Diagnostic(
                    path, span.line if span else None, span.col if span else None, f"{name}: {message}", severity
                )
            )
    for role in fit.missing_required:
        out.append(
            Diagnostic(path, None, None, f"profile {fit.profile.name}: required role {role.name} is not provided")
        )
    return out
