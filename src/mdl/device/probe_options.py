"""The options of `mdl probe` (SPEC 14) as the probe takes them: unit ids (mdl discover's list), baud rates
and parities to try on a serial line, tables, the address range; each bad one a click.BadParameter naming it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import click

from mdl.device.connection import Connection
from mdl.device.rawread import RAW_TABLES, parse_raw_range

Span = tuple[int, int]  # first, last address (both included)


@dataclass(frozen=True)
class ProbeOptions:
    units: list[int]
    settings: list[tuple[int, str]]  # (baud, parity) to try on a serial line; ignored on TCP
    tables: list[str]
    low: int
    high: int
    max_requests: int
    rate: float


def parse_list(text: str, what: str, allowed: dict[str, str]) -> list[str]:
    """A comma-separated list of the `allowed` words (case-insensitive; aliases map to names), each once,
    in the order given. ValueError naming the first bad item."""
    out: list[str] = []
    for item in text.split(","):
        word = allowed.get(item.strip().lower())
        if word is None:
            raise ValueError(
                f"'{item.strip()[:20]}' is not {what} (expected {', '.join(dict.fromkeys(allowed.values()))})"
            )
        if word not in out:
            out.append(word)
    return out


def parse_bauds(text: str) -> list[int]:
    """`9600,19200`: baud rates, each once, in the order given. ValueError naming the first bad one."""
    out: list[int] = []
    for item in text.split(","):
        word = item.strip()
        if not (word.isascii() and word.isdigit() and 50 <= int(word[:8]) <= 4_000_000):
            raise ValueError(f"'{word[:20]}' is not a baud rate (50 to 4000000), e.g. 9600,19200")
        if int(word) not in out:
            out.append(int(word))
    return out


def parse_span(text: str) -> Span:
    """`A-B` (both included) or `A`: wire addresses 0-65535. ValueError saying what is wrong."""
    found = parse_raw_range(f"hr:{text}")
    return found.first, found.last


def probe_options(
    connection: Connection,
    units: str,
    bauds: str | None,
    parities: str | None,
    tables: str,
    span: str,
    max_requests: int,
    rate: float,
) -> ProbeOptions:
    """The options of `mdl probe` as the probe takes them; click.BadParameter (exit 2) naming the option
    that is wrong. --bauds and --parities default to the connection's --baud and --parity, and need
    --serial."""
    from mdl.device.discover import parse_units

    if connection.serial is None and (bauds or parities):
        raise click.UsageError(f"{'--bauds' if bauds else '--parities'} tries serial settings: it needs --serial")
    baud_list = _checked("--bauds", lambda: parse_bauds(bauds) if bauds else [connection.baud])
    parity_list = _checked(
        "--parities", lambda: parse_list(parities, "a parity", PARITIES) if parities else [connection.parity]
    )
    low, high = _checked("--range", lambda: parse_span(span))
    return ProbeOptions(
        _checked("--units", lambda: parse_units(units)),
        [(b, p) for b in baud_list for p in parity_list],
        _checked("--tables", lambda: parse_list(tables, "a table", RAW_TABLES)),
        low,
        high,
        max_requests,
        rate,
    )


T = TypeVar("T")


def _checked(option: str, parse: Callable[[], T]) -> T:
    """What `parse` gives; click.BadParameter naming `option` where it raises ValueError."""
    try:
        return parse()
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint=f"'{option}'") from None


PARITIES = {"n": "N", "e": "E", "o": "O", "none": "N", "even": "E", "odd": "O"}
