"""Profiles (SPEC 13): what a kind of device offers, whoever made it. A profile names roles (`power_w`,
`energy_import_wh`), each with a unit, a type, a sign convention and whether a device of that kind
must have it; a function says which role it plays with `<role>`. `load.py` reads the profiles shipped
in `data/` and users' own YAML files; `fit.py` binds a device's functions to a profile's roles, with
the unit conversion and sign each needs (docs/profiles.md)."""
