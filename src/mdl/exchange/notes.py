"""How an export says what it loses (SPEC 11, issue 20): one warning per kind of loss, naming every function it
concerns, each with its own detail where the kind needs one (`functions 'a', 'b' (0xFFFF): Telegraf: ...`),
at the first function's line. The engines (mdl.exports) and the formats that write (XIF, WISE) share it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from mdl.diagnostics import Diagnostic

if TYPE_CHECKING:
    from mdl.model import Function
    from mdl.resolver import ResolvedDevice, ResolvedFunction


Lost = tuple[str, str | None]  # a kind of loss and what is particular to one function (or None)


def bits_detail(fn: Function) -> str:
    """The detail a warning about a function's `bits` gives: `bits 4-5`."""
    return f"bits {fn.bits}"


def factor_detail(fn: Function) -> str:
    """The detail a warning about a function scaled by another gives: `scale_exponent w_sf`."""
    return f"{'scale_exponent' if fn.scale_exponent is not None else 'scale_by'} {fn.factor}"


class LeftOut(ValueError):
    """A function a writer cannot hold: why (the kind of loss, for `Notes.warn`) and its detail, or None."""

    def __init__(self, why: str, detail: str | None = None) -> None:
        super().__init__(why)
        self.why = why
        self.detail = detail


@dataclass
class _Kind:
    """One kind of loss (or note) of one export: the functions it concerns, each with its detail or None."""

    severity: str
    message: str
    functions: list[tuple[ResolvedFunction, str | None]] = field(default_factory=list)
    seen: set[tuple[str, str | None]] = field(default_factory=set)  # (function name, detail) in functions


@dataclass
class Notes:
    """The warnings (and notes) of one export, each naming the engine (none where `engine` is ""): those about
    functions gathered into one per kind (severity and message), in the order each kind was first met."""

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
        self._said.append(Diagnostic(self.resolved.device.source, None, None, self._prefix + message, "warning"))

    def note(self, message: str) -> None:
        self._said.append(Diagnostic(self.resolved.device.source, None, None, self._prefix + message, "note"))

    @property
    def _prefix(self) -> str:
        return f"{self.engine}: " if self.engine else ""

    @property
    def found(self) -> list[Diagnostic]:
        """Every warning and note: one for each kind, at its first function's line."""
        return [said if isinstance(said, Diagnostic) else self._diagnostic(said) for said in self._said]

    def _diagnostic(self, kind: _Kind) -> Diagnostic:
        return Diagnostic(
            self.resolved.device.source,
            kind.functions[0][0].fn.line,
            None,
            f"{subject(kind.functions)}: {self._prefix}{kind.message}",
            kind.severity,
        )


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
    parts = [
        ", ".join(f"'{name}'" for name in names) + (f" ({detail})" if detail else "")
        for detail, names in by_detail.items()
    ]
    return ("function " if len(details) == 1 else "functions ") + ", ".join(parts)
