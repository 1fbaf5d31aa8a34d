"""A profile from its YAML: one of those shipped in data/ (`meter`), or a user's file. Every mistake
is an error naming the file, line and column (mdl.exchange.yamlnodes keeps the positions)."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from mdl.diagnostics import error
from mdl.exchange.yamlnodes import Map, Node, Text, load_yaml, need, opt
from mdl.model.units import SI
from mdl.profiles.shipped import DATA

NAME = re.compile(r"[a-z][a-z0-9_]{0,62}")
RATIO = "1"  # the unit of a plain number (a power factor): a function in % is divided by 100
TYPES = ("float", "int", "bool")
ACCESS = ("read", "read_write")
_ROLE_KEYS = ("unit", "type", "required", "access", "sign", "opposite", "description")
_TOP_KEYS = ("name", "title", "roles")


@dataclass(frozen=True)
class Role:
    """One value a kind of device offers. `unit` is mdl's spelling of an SI unit, RATIO, or None (an int
    or bool); `opposite` names a role a device may give instead, with the opposite sign."""

    name: str
    unit: str | None
    type: str = "float"
    required: bool = False
    access: str = "read"
    sign: str | None = None
    opposite: str | None = None
    description: str = ""

    @property
    def writable(self) -> bool:
        return self.access == "read_write"


@dataclass
class Profile:
    name: str
    title: str
    roles: dict[str, Role] = field(default_factory=dict)
    source: str = ""  # the file it was read from

    @property
    def class_name(self) -> str:
        """The interface's name in generated code: `meter` -> `Meter`, `ev_charger` -> `EvCharger`."""
        return "".join(part.capitalize() for part in self.name.split("_"))


def shipped() -> list[str]:
    """The names of the profiles mdl ships, sorted."""
    return sorted(p.stem for p in DATA.glob("*.yaml"))


def shipped_roles() -> dict[str, list[str]]:
    """Each role name of the shipped profiles -> the profiles that have it."""
    out: dict[str, list[str]] = {}
    for name in shipped():
        for role in read_profile(DATA / f"{name}.yaml").roles:
            out.setdefault(role, []).append(name)
    return out


def load_profile(spec: str) -> Profile:
    """`meter` (a shipped profile) or a path to a YAML file."""
    path = Path(spec)
    if path.suffix.lower() not in (".yaml", ".yml") and "/" not in spec and "\\" not in spec:
        if spec not in shipped():
            raise error(f"no profile named '{spec[:60]}': mdl ships {', '.join(shipped())} (or give a .yaml file)")
        path = DATA / f"{spec}.yaml"
    elif not path.is_file():
        raise error("no such profile file", path)
    return read_profile(path)


def _text(node: Node, what: str, path: Path) -> str:
    if not isinstance(node, Text):
        raise error(f"{what} must be a text", path, node.line, node.col)
    return node.value


def _flag(node: Node, what: str, path: Path) -> bool:
    value = _text(node, what, path).lower()
    if value not in ("true", "false", "yes", "no"):
        raise error(f"{what} must be true or false, not '{value[:40]}'", path, node.line, node.col)
    return value in ("true", "yes")


def _name(node: Text, what: str, path: Path) -> str:
    if not NAME.fullmatch(node.value):
        raise error(
            f"{what} '{node.value[:40]}' is not a name (a lower-case letter, then lower-case letters, digits and _)",
            path,
            node.line,
            node.col,
        )
    return node.value


def _unknown(node: Map, known: tuple[str, ...], where: str, path: Path) -> None:
    for key, item in node.value.items():
        if key not in known:
            raise error(f"unknown key '{key[:40]}' in {where} (known: {', '.join(known)})", path, item.line, item.col)


def read_profile(path: Path) -> Profile:
    root = load_yaml(path, "a profile")
    _unknown(root, _TOP_KEYS, "a profile", path)
    name = _name(need(root, "name", path, Text), "the profile's name", path)
    title = opt(root, "title", path, Text)
    roles = need(root, "roles", path, Map)
    if not roles.value:
        raise error("a profile needs at least one role", path, roles.line, roles.col)
    profile = Profile(name, title.value if title else name, source=str(path))
    for key, node in roles.value.items():
        role = _role(key, node, path)
        profile.roles[role.name] = role
    opposites: dict[str, str] = {}
    for role in profile.roles.values():
        if role.opposite is not None and role.opposite in opposites:
            item = roles.value[role.name]
            message = f"role {role.name}: opposite '{role.opposite}' is role {opposites[role.opposite]}'s already"
            raise error(message, path, item.line, item.col)
        if role.opposite is not None:
            opposites[role.opposite] = role.name
        if role.opposite is not None and role.opposite in profile.roles:
            item = roles.value[role.name]
            message = f"role {role.name}: opposite '{role.opposite}' is a role of the profile itself"
            raise error(message, path, item.line, item.col)
    return profile


def _role(key: str, node: Node, path: Path) -> Role:
    where = f"role {key[:40]}"
    if not isinstance(node, Map):
        raise error(f"{where} must be a mapping (unit, type, required ...)", path, node.line, node.col)
    name = _name(Text(key, node.line, node.col), "a role", path)
    _unknown(node, _ROLE_KEYS, where, path)
    fields = {k: _text(v, f"{where}: {k}", path) for k, v in node.value.items() if k in ("type", "access", "unit")}
    kind = fields.get("type", "float")
    if kind not in TYPES:
        item = node.value["type"]
        raise error(f"{where}: type must be one of {', '.join(TYPES)}, not '{kind[:40]}'", path, item.line, item.col)
    access = fields.get("access", "read")
    if access not in ACCESS:
        item = node.value["access"]
        raise error(f"{where}: access must be read or read_write, not '{access[:40]}'", path, item.line, item.col)
    unit = fields.get("unit")
    if kind == "float" and unit is None:
        raise error(f"{where}: a float role needs a unit (an SI unit, % or 1)", path, node.line, node.col)
    if kind != "float" and unit is not None:
        item = node.value["unit"]
        raise error(f"{where}: an {kind} role has no unit", path, item.line, item.col)
    if unit is not None and unit != RATIO and (unit not in SI or SI[unit].base != unit):
        item = node.value["unit"]
        bases = sorted({s.base for s in SI.values()})
        raise error(
            f"{where}: unit '{unit[:40]}' is not the base unit of a quantity mdl converts ({', '.join(bases)}, 1)",
            path,
            item.line,
            item.col,
        )
    required = node.value.get("required")
    sign, opposite, description = (node.value.get(k) for k in ("sign", "opposite", "description"))
    return Role(
        name,
        unit,
        kind,
        _flag(required, f"{where}: required", path) if required is not None else False,
        access,
        _text(sign, f"{where}: sign", path) if sign is not None else None,
        _opposite(opposite, where, path),
        _text(description, f"{where}: description", path) if description is not None else "",
    )


def _opposite(node: Node | None, where: str, path: Path) -> str | None:
    if node is None:
        return None
    if not isinstance(node, Text):
        raise error(f"{where}: opposite must be a role's name", path, node.line, node.col)
    return _name(node, f"{where}: opposite", path)
