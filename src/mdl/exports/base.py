"""What the three engine writers (VOLTTRON, Home Assistant, Telegraf; SPEC 11) share.

Each writer walks the resolved device's functions and decides, from the layout and the value IR
the resolve step computed (never from the document again), how its engine reads each one. What the
engine cannot express is said with `Notes.warn(f, kind, detail)` (mdl.exchange.notes, which the XIF and
WISE writers share): the export prints one warning per kind of loss (SPEC 11), naming every function it
concerns, each with its own detail where the kind needs one (`functions 'a', 'b' (0xFFFF): Telegraf: ...`),
at the first function's line. A function no engine can read as mdl does (an expression, a fragment,
registers that are not one ascending run, a value built from bytes of several registers) is left out
with such a warning (`left_out_unreadable`).
A function with `bits` or a scale register (`scale_exponent`, `scale_by`; SPEC 2.2) is each writer's own
affair: `register_bit` says where one bit is on the wire, `scale_factor` what scales a value and by whom
(docs/bits-and-scale.md, "In other formats and engines", says what each engine carries).
An export that would hold nothing at all is an error (`nothing_left`).

How every export writes text (docs/fleet.md, "Text in exports"): the encoders of mdl.exchange.text
(`comment_text`, `toml_string`, `json_text`, `spreadsheet_cell`; YAML's in homeassistant.py), so that no name,
unit or description can end a comment, a string or a cell early and become configuration of its own.
"""

from __future__ import annotations

import math
from decimal import Decimal
from typing import TYPE_CHECKING

from mdl.diagnostics import MdlError, error
from mdl.exchange.connection import Endpoint
from mdl.exchange.notes import Notes as Notes
from mdl.exchange.notes import bits_detail as bits_detail
from mdl.exchange.notes import factor_detail as factor_detail
from mdl.exchange.notes import subject as subject
from mdl.ir.build import split_value, units
from mdl.ir.steps import Expression, Fragment, NotImplemented, Scale, ScaleFactor, find_step

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.resolver import ResolvedDevice, ResolvedFunction


UNREADABLE = "cannot be read as mdl does: {}: left out"


def unreadable(f: ResolvedFunction) -> tuple[str, str | None] | None:
    """Why none of the engines can read `f` as mdl does (it is left out), and the function's detail; or None."""
    steps = f.codec.decode
    if find_step(steps, Expression) is not None or f.layout.kind == "expr":
        return "a Toolkit expression computes its value", None
    if find_step(steps, Fragment) is not None:
        return "a read fragment computes its value", None
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


def register_bit(f: ResolvedFunction) -> tuple[int, int] | None:
    """Where a one-bit function's bit is on the wire: (register address, bit 0-15 of the register as sent,
    0 the least significant); None for a function without `bits` or with a range of them."""
    span = f.fn.bit_range
    if span is None or span[0] != span[1] or f.layout.kind != "int":
        return None
    masks = split_value(units(f.layout), len(f.layout.addresses), 1 << span[0])  # as mdl's writes place it
    address, mask = next((a, m) for a, m in zip(f.layout.addresses, masks, strict=True) if m)
    return address, mask.bit_length() - 1


def scale_factor(f: ResolvedFunction) -> ScaleFactor | None:
    """How a function scaled by another register is computed (`f.fn.factor` names that register), or None."""
    return find_step(f.codec.decode, ScaleFactor)


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


def warn_patterns(f: ResolvedFunction, notes: Notes, message: str) -> None:
    """Warn `message` for `f` if it has "not implemented" values (the detail lists them)."""
    patterns = patterns_of(f)
    if patterns:
        notes.warn(f, message, ", ".join(map(hex_pattern, patterns)))


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
    notes.note(
        f"no connection given: the configuration names {conn.host}:{conn.port}; give --host/--port or "
        "--serial for the device's own"
    )
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
