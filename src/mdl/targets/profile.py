"""`mdl gen --profile` (SPEC 13, docs/profiles.md "Generated interfaces"): a profile's interface as
each target prints it. The device is fitted first (mdl.profiles.fit): a fit with problems or a
required role missing is an error, nothing written. What every target needs is here, once: each
role's identifier, the function that plays it and how its value converts (role = value * factor +
offset), the names the interface takes (its class, module and header, checked against the driver's
own), and a role's value written back as the function's integer type (bounds and rounding)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.model.layout import integer_range
from mdl.model.names import CLASS_RESERVED, camel, identifier, unique_identifiers
from mdl.records import replace
from mdl.resolver import ResolvedDevice, ResolvedFunction
from mdl.resolver.checks import position
from mdl.targets.templating import c_int64

if TYPE_CHECKING:  # the profiles (and PyYAML, which reads them) are imported by `mdl gen --profile` alone
    from mdl.profiles.fit import Binding, Fit
    from mdl.profiles.load import Profile, Role

# names the shared Python module defines beside the interface's classes
PY_MODULE_NAMES = frozenset({"NotProvided", "Protocol"})
NOT_PROVIDED_ERRNO = "MDL_ENOTPROVIDED"  # C and C++: errno of a role the device lacks (ENOTSUP)
# role type -> the type of its value in C and C++ (the same spelling in both)
C_TYPES = {"float": "double", "int": "int64_t", "bool": "bool"}


@dataclass(frozen=True)
class RoleCode:
    """One role as the targets print it: `read_<ident>` (and `write_<ident>` for a read_write role)."""

    role: Role
    ident: str
    binding: Binding | None  # None: the device does not provide it

    @property
    def function(self) -> ResolvedFunction | None:
        return self.binding.function if self.binding else None

    @property
    def writable(self) -> bool:
        """Whether the role is written and this device's function can be (else writing it reports
        "not provided")."""
        return self.binding is not None and self.binding.writable and self.binding.function.codec.encode is not None

    @property
    def negated(self) -> bool:
        """An int or bool role played by its opposite: the value negated (or, for a bool, inverted)."""
        return self.binding is not None and self.binding.factor == -1.0 and self.binding.offset == 0.0

    @property
    def unit(self) -> str:
        """The role's unit as the interface's documentation says it ("" for an int or bool role)."""
        from mdl.profiles.load import RATIO

        if self.role.unit is None:
            return ""
        return "1" if self.role.unit == RATIO else self.role.unit

    @property
    def about(self) -> str:
        """A line of documentation: the role, its unit, what it means and its sign."""
        unit = f" [{self.unit}]" if self.unit else ""
        text = "; ".join(t for t in (self.role.description, self.role.sign or "") if t)
        return f"{self.role.name}{unit}{': ' + text if text else ''}"

    @property
    def c_type(self) -> str:
        return C_TYPES[self.role.type]


@dataclass(frozen=True)
class Interface:
    """A profile as generated code names it, fitted to one device."""

    fit: Fit
    class_name: str  # Python's Protocol and C++'s abstract class: `Meter`
    roles: tuple[RoleCode, ...]

    @property
    def profile(self) -> Profile:
        return self.fit.profile

    @property
    def name(self) -> str:
        return self.profile.name

    @property
    def py_module(self) -> str:
        """The shared Python module (`meter_profile`): the Protocols and NotProvided."""
        return f"{self.name}_profile"

    @property
    def header(self) -> str:
        """The shared C and C++ header (`mdl_meter.h`): `mdl::Meter` and `struct mdl_meter`."""
        return f"mdl_{self.name}.h"

    @property
    def guard(self) -> str:
        """The include guard of the shared header's C++ part (+ `_C` for the C part): ends in HH,
        as no driver's guard does."""
        return f"MDL_{self.name.upper()}_INTERFACE_HH"


def class_name(profile: Profile) -> str:
    """The interface's class: `Profile.class_name` through the checked path of every generated class
    name (mdl.model.names rule 4: `none` -> `None_`), and not a name the shared module defines."""
    name = camel(identifier(profile.name))
    return name + "_" if name in PY_MODULE_NAMES or name in CLASS_RESERVED else name


def _yield_role_names(
    profile: Profile, fitted: Fit, resolved: ResolvedDevice, path: str
) -> tuple[ResolvedDevice, list[Diagnostic]]:
    """A function named after the role it plays (csv2xml names them so: `power_w` read in kW) gives the
    role its method name: the function's own methods become `read_<name>_device` (a note says so), and
    the role's `read_power_w` reads the role's unit."""
    idents = {f"{rc}" for rc in unique_identifiers(profile.roles)}
    players = {b.function.name for b in fitted.bound.values()}
    taken = {f.ident for f in resolved.functions}
    renamed, functions = [], []
    for f in resolved.functions:
        if f.name in players and f.ident in idents:
            new = f"{f.ident}_device"
            while new in taken:
                new += "_"
            taken.add(new)
            renamed.append(f"{f.name}'s own methods are read_{new}/write_{new}")
            functions.append(replace(f, ident=new))
        else:
            functions.append(f)
    if not renamed:
        return resolved, []
    note = f"profile {profile.name}: functions named after their roles: {'; '.join(renamed)}"
    return replace(resolved, functions=tuple(functions)), [Diagnostic(path, None, None, note, "note")]


def prepare(spec: str, resolved: ResolvedDevice, path: str) -> tuple[Interface, list[Diagnostic], ResolvedDevice]:
    """The interface of profile `spec` (a shipped name or a YAML file) for this device, the notes
    to say (each guess of the fit, each role renamed) and the device to generate (its functions named
    after their roles give way); MdlError listing every problem when the device does not fit (the
    diagnostics `mdl validate --profile` prints) or a name would clash."""
    from mdl.profiles.fit import fit
    from mdl.profiles.load import load_profile
    from mdl.profiles.report import fit_diagnostics

    profile = load_profile(spec)
    fitted = fit(profile, resolved)
    diagnostics = fit_diagnostics(path, fitted, {f.name: f for f in resolved.device.functions})
    if not fitted.ok:
        raise MdlError(diagnostics)
    resolved, gave_way = _yield_role_names(profile, fitted, resolved, path)
    if gave_way:
        fitted = fit(profile, resolved)
        diagnostics += gave_way
    idents = unique_identifiers(profile.roles)
    roles = tuple(
        RoleCode(role, ident, fitted.bound.get(role.name))
        for role, ident in zip(profile.roles.values(), idents, strict=True)
    )
    for rc in roles:
        if rc.ident != rc.role.name:
            message = f"profile {profile.name}: role {rc.role.name} is read_{rc.ident} in generated code"
            diagnostics.append(Diagnostic(path, None, None, message, "note"))
    _check_methods(profile.name, roles, resolved, path)
    return Interface(fitted, class_name(profile), roles), diagnostics, resolved


def _check_methods(profile: str, roles: tuple[RoleCode, ...], resolved: ResolvedDevice, path: str) -> None:
    """A role's method must not be one of the driver's own (a function called `power_w` reads as
    read_power_w): that is an error at the function's name, which only renaming it resolves."""
    wanted = {f"read_{rc.ident}": rc for rc in roles}
    wanted.update({f"write_{rc.ident}": rc for rc in roles if rc.role.writable})
    problems = []
    for f in resolved.functions:
        for method in (f"read_{f.ident}", f"write_{f.ident}"):
            if method in wanted:
                line, col = position(f.fn, "name")
                role = wanted[method].role.name
                problems.append(
                    Diagnostic(
                        path,
                        line,
                        col,
                        f"function {f.name}: its method {method} would also be role {role}'s of profile "
                        f"{profile}'s interface: rename the function",
                    )
                )
                break
    if problems:
        raise MdlError(problems)


def check_files(interface: Interface, driver: dict[str, str], shared: dict[str, str]) -> dict[str, str]:
    """The driver's files and the interface's shared ones; an error where a shared file would have a
    driver file's name (a device called `Meter Profile` next to meter_profile.py)."""
    for name in shared:
        if name in driver:
            raise error(
                f"the device's generated file {name} has the name of profile {interface.name}'s interface "
                "file: rename the device or generate it into another directory"
            )
    return {**driver, **shared}


_INT_TYPE = re.compile(r"(u?)int(8|16|32|64)_t")


@dataclass(frozen=True)
class IntWrite:
    """How a role's value becomes the value of a function of integer type `type`, refused (EINVAL)
    where the type cannot hold it. A float role's double is rounded half up (as every driver rounds)
    and must be within low <= rounded < end; an int role's int64_t within int_low..int_high (C
    literals; None where every int64_t at that end fits)."""

    type: str
    low: float
    end: float
    int_low: str | None
    int_high: str | None


def int_write(c_type: str) -> IntWrite | None:
    """IntWrite for a C or C++ integer type (`int16_t`, `uint64_t`), None for any other type."""
    found = _INT_TYPE.fullmatch(c_type)
    if found is None:
        return None
    bits = int(found.group(2))
    low, high = integer_range(bits, not found.group(1))
    if found.group(1):
        return IntWrite(c_type, 0.0, float(high + 1), c_int64(0), c_int64(high) if bits < 64 else None)
    wide = bits == 64
    return IntWrite(
        c_type, float(low), float(high + 1), None if wide else c_int64(low), None if wide else c_int64(high)
    )
