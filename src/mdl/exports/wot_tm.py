"""A profile's W3C WoT Thing Model (`mdl profiles NAME --as tm`, SPEC 11.1 and 13; docs/wot.md): one property
per role, with the role's type and SI unit, read-only unless the role is read_write, the role's description
and sign convention as the property's description; the roles a device need not have are `tm:optional`. A
TD written with `--names roles --profile NAME` links it (`profile_link`, rel `type`) and names its
properties after these roles."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mdl.exchange.text import json_text
from mdl.formats.wot import vocabulary as v
from mdl.profiles.load import RATIO

if TYPE_CHECKING:
    from mdl.profiles.load import Profile

_TYPES = {"float": "number", "int": "integer", "bool": "boolean"}


def profile_file(profile: Profile) -> str:
    """The file name the profile's Thing Model is linked as (relative: written beside the TDs)."""
    return f"{profile.name}.tm.jsonld"


def profile_link(profile: Profile) -> dict[str, str]:
    """A TD's link to the Thing Model of the profile whose roles name its properties."""
    return {"rel": "type", "href": profile_file(profile), "type": v.TM_LINK_TYPE}


def profile_thing_model(profile: Profile) -> str:
    """The profile's Thing Model as JSON text."""
    properties: dict[str, Any] = {}
    for role in profile.roles.values():
        prop: dict[str, Any] = {"title": role.name}
        said = [text for text in (role.description, role.sign) if text]
        if said:
            prop["description"] = "; ".join(said)
        prop["type"] = _TYPES[role.type]
        if role.unit is not None and role.unit != RATIO:
            prop["unit"] = role.unit
        prop["readOnly"] = not role.writable
        prop["observable"] = True
        properties[role.name] = prop
    doc: dict[str, Any] = {
        "@context": v.CONTEXT[:2],
        "@type": v.THING_MODEL,
        "title": profile.title,
        "description": f"The roles of the mdl profile '{profile.name}': any vendor's device of this kind, alike",
        "properties": properties,
    }
    optional = [f"/properties/{role.name}" for role in profile.roles.values() if not role.required]
    if optional:
        doc["tm:optional"] = optional
    return json_text(doc, 2)
