"""A device served as the SunSpec models of its profile (SPEC 13, docs/sunspec.md "Gateway"):
`mdl sim DEVICE --as sunspec` and `mdl serve DEVICE --from CONNECTION --as sunspec`.

The profile is chosen (`choose`), the device's functions bound to its roles (mdl.profiles.fit), and a
model picked from mdl.device.sunspec.points. The chain (model 1, that model, the end marker) is built
by mdl.formats.sunspec as `mdl import --from sunspec` builds it and held in the sim's own register
store (`FacadeRegisters`, a mdl.device.server.sim.Registers): every read a client makes first computes the
points from the roles' current values (`source`: the simulated registers, or the gateway's last
poll). A value that is missing, not a number, or too large for its point at the coarsest scale is
served as SunSpec's "not implemented" (0x8000, 0xFFFF, 0x80000000 ...). The chain takes no writes.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TextIO

from mdl.device.server.sim import Registers
from mdl.device.sunspec.points import MODEL_SCALES, MODELS, POINTS, SCALES, Point
from mdl.diagnostics import Diagnostic, MdlError, error, one_line
from mdl.formats.sunspec.read import COMMON, chain_device
from mdl.model import Device, Function, Value
from mdl.model.layout import integer_range
from mdl.profiles.fit import Fit, fit
from mdl.profiles.load import load_profile, shipped
from mdl.profiles.report import fit_diagnostics
from mdl.resolver import ResolvedDevice, resolve

RoleValues = dict[str, float | None]  # role -> its value in the role's unit; None: none now
Source = Callable[[], RoleValues | None]  # None: the device does not answer
_SIGNED = ("INT16", "INT32")
_BITS = {"INT16": 16, "UINT16": 16, "INT32": 32, "UINT32": 32}
# model 1's strings and the device's identity element each is served from
IDENTITY = (("Mn", "manufacturer"), ("Md", "product"), ("Vr", "product_version"), ("SN", "name"))


def served_profiles() -> list[str]:
    return sorted(MODELS)


def choose(resolved: ResolvedDevice, spec: str | None, path: Path) -> tuple[Fit, list[Diagnostic]]:
    """The profile to serve as: `spec` (a name or a YAML file), else the one shipped profile with a SunSpec
    model that the device's roles fit. MdlError when none fits, several do, or the profile has no model."""
    where = str(path)
    functions: dict[str, object] = {f.name: f for f in resolved.device.functions}
    if spec is not None:
        chosen = fit(load_profile(spec), resolved)
        _has_model(chosen.profile.name)
        if not chosen.ok:
            raise MdlError(fit_diagnostics(where, chosen, functions))
        return chosen, fit_diagnostics(where, chosen, functions)  # its notes: each guess of the fit
    fits = {name: fit(load_profile(name), resolved) for name in shipped()}
    good = [name for name, f in fits.items() if f.ok and f.bound]
    served = [name for name in good if name in MODELS]
    if len(served) > 1:
        raise error(f"the device's roles fit profiles {', '.join(served)}: choose one with --profile", where)
    if not served:
        others = [name for name in good if name not in MODELS]
        fits_too = f" (it fits {', '.join(others)}, which SunSpec has no model for)" if others else ""
        lacking = "; ".join(
            f"{name} lacks {', '.join(r.name for r in fits[name].missing_required) or 'nothing but has problems'}"
            for name in served_profiles()
        )
        raise error(
            f"the device fits no profile with a SunSpec model ({', '.join(served_profiles())}){fits_too}: {lacking}",
            where,
        )
    name = served[0]
    said = Diagnostic(where, None, None, f"served as profile {name}, the one its roles fit", "note")
    return fits[name], [said, *fit_diagnostics(where, fits[name], functions)]


def _has_model(profile: str) -> None:
    if profile not in MODELS:
        raise error(
            f"profile {profile} has no SunSpec model: the gateway serves {', '.join(served_profiles())} "
            "(SunSpec models 1 + 201/203, 103, 802/713)"
        )


def pick_model(fitted: Fit) -> int:
    """The first of the profile's candidate models whose trigger roles the device binds."""
    for model, triggers in MODELS[fitted.profile.name]:
        if not triggers or triggers & set(fitted.bound):
            return model
    raise AssertionError("the last candidate of every profile has no triggers")


def role_values(fitted: Fit, values: dict[str, Value]) -> RoleValues:
    """Each bound role's value in the role's unit (value * factor + offset); None where the function has
    no number (not implemented, not read, text)."""
    out: RoleValues = {}
    for role, binding in fitted.bound.items():
        v = values.get(binding.function.name)
        number = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        out[role] = float(v) * binding.factor + binding.offset if number else None  # type: ignore[arg-type]
    return out


def _point_value(point: Point, roles: RoleValues) -> float | None:
    got = [roles.get(r) for r in point.roles]
    if any(v is None for v in got):
        return None
    numbers = [v for v in got if v is not None]
    total = sum(numbers) * point.scale
    result = total / len(numbers) if point.how == "mean" else total
    return result if math.isfinite(result) else None


def _bounds(fn: Function) -> tuple[int, int]:
    """The raw integers a point may hold: its format's, without the "not implemented" value."""
    bits = _BITS[fn.format or "UINT16"]
    low, high = integer_range(bits, fn.format in _SIGNED)
    for text in fn.not_implemented or ():
        missing = int(text, 0)
        if fn.format in _SIGNED and missing >= 1 << (bits - 1):
            missing -= 1 << bits
        low, high = low + (missing == low), high - (missing == high)
    return low, high


def _missing_words(fn: Function, count: int) -> list[int] | None:
    """The registers of the function's "not implemented" value; None if it has none."""
    if not fn.not_implemented:
        return None
    raw = int(fn.not_implemented[0], 0)
    return [(raw >> (16 * (count - 1 - i))) & 0xFFFF for i in range(count)]


class FacadeRegisters(Registers):
    """The registers of the SunSpec chain served for a device, recomputed from `source` before each read."""

    def __init__(self, fitted: Fit, source: Source, device: Device, unit: int, warn: TextIO | None = None) -> None:
        self.model = pick_model(fitted)
        chain = chain_device([(COMMON, 0), (self.model, 1)])
        chain.name = f"{device.name} as SunSpec {COMMON} + {self.model}"
        chain.manufacturer, chain.product = device.manufacturer, device.product  # function 43 answers as the device
        chain.product_version = device.product_version
        super().__init__(resolve(chain))
        self.fitted, self.source, self.warn = fitted, source, warn
        self.read_only = {table: set(addresses) for table, addresses in self.tables.items()}  # no writes
        self.by_name = {fn.name: fn for fn in chain.functions}
        self.points = [(p, self.by_name[f"{self.model}_{p.point}"]) for p in POINTS[self.model]]
        self.scales: dict[str, list[tuple[Point, Function]]] = {}
        for point, fn in self.points:
            self.scales.setdefault(fn.scale_exponent or "", []).append((point, fn))
        self.unfit: set[str] = set()  # points whose value does not fit now (said once)
        for fn in chain.functions:
            words = _missing_words(fn, len(self.layouts[fn.name].addresses))
            if fn.initial is None and words is not None:
                self.write(fn, words)
        self.identity_notes = self._identity(device, unit)

    def write(self, fn: Function, words: Iterable[int]) -> None:
        lay = self.layouts[fn.name]
        self.put_each(lay.table, lay.addresses, words)

    def _identity(self, device: Device, unit: int) -> list[str]:
        """Model 1's strings from the device's identity elements (cut to fit, said) and DA, the unit id."""
        notes = []
        for point, attr in IDENTITY:
            text: str | None = getattr(device, attr)
            if not text:
                continue
            fn = self.by_name[f"{COMMON}_{point}"]
            size = 2 * (fn.count or 1)
            data = text.encode("utf-8")
            if len(data) > size:
                data = data[:size].decode("utf-8", "ignore").encode("utf-8")
                notes.append(f"{point} holds {size} bytes: the device's {attr} is cut to '{data.decode('utf-8')}'")
            padded = data.ljust(size, b"\0")
            self.write(fn, [int.from_bytes(padded[i : i + 2], "big") for i in range(0, size, 2)])
        self.write(self.by_name[f"{COMMON}_DA"], [unit])
        return notes

    def get(self, table: str, address: int, count: int) -> list[int]:
        self.refresh()
        return super().get(table, address, count)

    def refresh(self) -> None:
        """Every point from the source's values now: each scale factor the finest at which all the values it
        scales fit, a value that does not fit even at the coarsest "not implemented" (said once)."""
        roles = self.source()
        for sf_name, members in self.scales.items():
            values = [(fn, None if roles is None else _point_value(p, roles)) for p, fn in members]
            exponent = self._exponent(sf_name, values)
            if sf_name:
                self.write(self.by_name[sf_name], [exponent & 0xFFFF])
            for fn, value in values:
                self._put_point(fn, value, exponent)

    @staticmethod
    def _fits(fn: Function, value: float, exponent: int) -> bool:
        low, high = _bounds(fn)
        scaled = value / 10.0**exponent
        return math.isfinite(scaled) and low <= round(scaled) <= high

    def _exponent(self, sf_name: str, values: list[tuple[Function, float | None]]) -> int:
        """The finest exponent at which every value that fits at all fits: one that fits at no exponent
        (served as not implemented) never coarsens its neighbours' scale."""
        point = sf_name.removeprefix(f"{self.model}_")
        finest, coarsest = MODEL_SCALES.get((self.model, point), SCALES.get(point, (0, 0)))
        fitting = [(fn, v) for fn, v in values if v is not None and self._fits(fn, v, coarsest)]
        for exponent in range(finest, coarsest + 1):
            if all(self._fits(fn, v, exponent) for fn, v in fitting):
                return exponent
        return coarsest

    def _put_point(self, fn: Function, value: float | None, exponent: int) -> None:
        count = len(self.layouts[fn.name].addresses)
        missing = _missing_words(fn, count) or [0] * count
        if value is None:
            self.unfit.discard(fn.name)
            self.write(fn, missing)
            return
        if not self._fits(fn, value, exponent):
            if fn.name not in self.unfit:
                self.unfit.add(fn.name)
                scaled = value / 10.0**exponent
                if abs(scaled) < 0.5 and any(int(t, 0) == 0 for t in fn.not_implemented or ()):
                    why = "0 is the point's 'not implemented' value (SunSpec's accumulators count from 1)"
                    self._warn(f"{fn.name} = 0: {why}: served as not implemented", note=True)
                else:
                    self._warn(f"{fn.name} = {value:g} does not fit the point at scale 10^{exponent}: not implemented")
            self.write(fn, missing)
            return
        self.unfit.discard(fn.name)
        raw = round(value / 10.0**exponent)
        bits = 16 * count
        raw &= (1 << bits) - 1
        self.write(fn, [(raw >> (16 * (count - 1 - i))) & 0xFFFF for i in range(count)])

    def _warn(self, message: str, note: bool = False) -> None:
        stream = self.warn or sys.stderr
        stream.write(f"mdl: {'note' if note else 'warning'}: {one_line(message)}\n")
        stream.flush()
