"""What the three engine writers (VOLTTRON, Home Assistant, Telegraf; SPEC 11) share.

Each writer walks the resolved device's functions and decides, from the layout and the value IR
the resolve step computed (never from the document again), how its engine reads each one. What the
engine cannot express is said with `Notes.warn(f, kind, detail)`: the export prints one warning per
kind of loss (SPEC 11), naming every function it concerns, each with its own detail where the kind
needs one (`functions 'a', 'b' (0xFFFF): Telegraf: ...`), at the first function's line. A function no
engine can read as mdl does (an expression, a fragment, registers that are not one ascending run, a
value built from bytes of several registers) is left out with such a warning (`left_out_unreadable`).
An export that would hold nothing at all is an error (`nothing_left`).

How every export writes text (docs/fleet.md, "Text in exports"): the encoders of mdl.exchange.text
(`comment_text`, `toml_string`, `json_text`, `spreadsheet_cell`; YAML's in homeassistant.py), so that no name,
unit or description can end a comment, a string or a cell early and become configuration of its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from decimal import Decimal
from typing import TYPE_CHECKING

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.exchange.connection import Endpoint
from mdl.values.ir import Expression, Fragment, NotImplemented, Scale, find_step

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.resolve import ResolvedDevice, ResolvedFunction


@dataclass
class _Kind:
    """One kind of loss (or note) of one export: the functions it concerns, each with its detail or None."""

    severity: str
    message: str
    functions: list[tuple[ResolvedFunction, str | None]] = field(default_factory=list)
    seen: set[tuple[str, str | None]] = field(default_factory=set)  # (function name, detail) in functions


@dataclass
class Notes:
    """The warnings (and notes) of one export, each naming the engine: those about functions gathered into one
    per kind (severity and message), in the order each kind was first met."""

    resolved: ResolvedDevice
    engine: str
    _said: list[_Kind | Diagnostic] = field(default_factory=list)
    _kinds: dict[tuple[str, str], _Kind] = field(default_factory=dict)

    def warn(self, f: ResolvedFunction, message: str, detail: str | None = None) -> None:
        """A loss of kind `message` for `f`; `detail`: what is particular to this function (a value, a unit)."""
        self._add(f, message, detail, "warning")

    def note_for(self, f: ResolvedFunction, message: str, detail: str | None = None) -> None:
        """Like warn, a note (a guess said, a spelling changed): not a loss, so --fail-on-warning lets it pass."""
        self._add(f, message, detail, "note")

    def _add(self, f: ResolvedFunction, message: str, detail: str | None, severity: str) -> None:
        kind = self._kinds.get((severity, message))
        if kind is None:
            kind = self._kinds[(severity, message)] = _Kind(severity, message)
            self._said.append(kind)
        if (f.name, detail) not in kind.seen:
            kind.seen.add((f.name, detail))
            kind.functions.append((f, detail))

    def device_warning(self, message: str) -> None:
        self._said.append(Diagnostic(self.resolved.device.source, None, None, f"{self.engine}: {message}", "warning"))

    def note(self, message: str) -> None:
        self._said.append(Diagnostic(self.resolved.device.source, None, None, f"{self.engine}: {message}", "note"))

    @property
    def found(self) -> list[Diagnostic]:
        """Every warning and note: one for each kind, at its first function's line."""
        return [said if isinstance(said, Diagnostic) else self._diagnostic(said) for said in self._said]

    def _diagnostic(self, kind: _Kind) -> Diagnostic:
        return Diagnostic(self.resolved.device.source, kind.functions[0][0].fn.line, None,
                          f"{subject(kind.functions)}: {self.engine}: {kind.message}", kind.severity)


def subject(functions: list[tuple[ResolvedFunction, str | None]]) -> str:
    """`function 'a'`, or `functions 'a', 'b' (d1), 'c' (d2)`: the functions, those of the same details together
    with them in parentheses (a function's several details joined by `; `), in the order first met."""
    details: dict[str, list[str]] = {}
    for f, detail in functions:
        said = details.setdefault(f.name, [])
        if detail:
            said.append(detail)
    by_detail: dict[str, list[str]] = {}
    for name, said in details.items():
        by_detail.setdefault("; ".join(said), []).append(name)
    parts = [", ".join(f"'{name}'" for name in names) + (f" ({detail})" if detail else "")
             for detail, names in by_detail.items()]
    return ("function " if len(details) == 1 else "functions ") + ", ".join(parts)


UNREADABLE = "cannot be read as mdl does: {}: left out"


def unreadable(f: ResolvedFunction) -> tuple[str, str | None] | None:
    """Why none of the engines can read `f` as mdl does (it is left out), and the function's detail; or None."""
    steps = f.codec.decode
    if find_step(steps, Expression) is not None or f.layout.kind == "expr":
        return "a Toolkit expression computes its value", None
    if find_step(steps, Fragment) is not None:
        return "a read fragment computes its value", None
    if f.fn.bits is not None or f.fn.factor is not None:  # issue 21: the engines' exports do not carry them yet
        return "its value is bits of a register or scaled by another register (not carried yet)", None
    addresses = f.layout.addresses
    if addresses != tuple(range(addresses[0], addresses[0] + len(addresses))):
        return "its registers are not one ascending run", f"registers {' '.join(map(str, addresses))}"
    if f.layout.unit in ("low", "high") and len(addresses) > 1:
        return "its value is built from bytes of several registers", None
    return None


def left_out_unreadable(f: ResolvedFunction, notes: Notes) -> bool:
    """Whether `f` is left out as unreadable (`unreadable`), with the warning that says so."""
    found = unreadable(f)
    if found is not None:
        notes.warn(f, UNREADABLE.format(found[0]), found[1])
    return found is not None


def written_by_fragment(f: ResolvedFunction) -> bool:
    return find_step(f.codec.encode, Fragment) is not None


def bit_in_register(f: ResolvedFunction) -> bool:
    """A BIT in a holding or input register: mdl reads it as true when the register is not 0 (any bit
    set) and writes true as 1. Every engine's own bit type reads something else there."""
    return f.layout.kind == "bool" and f.layout.table in ("holding", "input")


def write_code(f: ResolvedFunction) -> int:
    """The function code mdl writes `f` with (mdl.device.runtime): one coil 5, one register 6, unless the
    function says write_multiple; then 15 for coils, 16 for registers, as for several registers."""
    if f.layout.table == "coil":
        return 15 if f.fn.write_multiple else 5
    return 6 if len(f.layout.addresses) == 1 and not f.fn.write_multiple else 16


def scale_of(f: ResolvedFunction) -> Scale | None:
    return find_step(f.codec.decode, Scale)


def patterns_of(f: ResolvedFunction) -> tuple[tuple[int, ...], ...]:
    """The register values that mean "not implemented", in the document's order."""
    step = find_step(f.codec.decode, NotImplemented)
    return step.patterns if step is not None else ()


def hex_pattern(pattern: tuple[int, ...]) -> str:
    return " ".join(f"0x{word:04X}" for word in pattern)


def plain_number(x: float) -> str:
    """`x` as a plain decimal (no exponent) that reads back as the same double: 0.1, 1e-05 -> 0.00001, 2 -> 2."""
    text = format(Decimal(repr(float(x))), "f")
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return text if text not in ("-0", "") else "0"


def decimals(x: float) -> int:
    """Digits after the point in `plain_number(x)`: the decimal places a product with an integer needs."""
    text = plain_number(x)
    return len(text.split(".", 1)[1]) if "." in text else 0


def connection_of(settings: Settings, notes: Notes) -> Endpoint:
    """The connection the command line gave, or the default one (said in a note)."""
    if settings.connection is not None:
        return settings.connection
    conn = Endpoint()
    notes.note(f"no connection given: the configuration names {conn.host}:{conn.port}; give --host/--port or "
               "--serial for the device's own")
    return conn


def whole_seconds(settings: Settings, notes: Notes) -> int:
    """The poll interval in whole seconds, for engines that take nothing finer (said where it changes)."""
    seconds = max(1, math.ceil(settings.interval - 1e-9))
    if seconds != settings.interval:
        notes.device_warning(f"polls in whole seconds: --interval {plain_number(settings.interval)} becomes {seconds}")
    return seconds


def nothing_left(resolved: ResolvedDevice, engine: str, notes: Notes) -> MdlError:
    """The error for a description of which the engine can hold nothing, with every reason why."""
    reasons = [d for d in notes.found if d.severity == "warning"]
    why = "; ".join(d.message for d in reasons[:5]) or "it has no functions"
    more = f" (and {len(reasons) - 5} more)" if len(reasons) > 5 else ""
    return error(f"{engine} can hold none of this description's functions: {why}{more}", resolved.device.source)
