"""The options of `mdl probe` (SPEC 14) as the probe takes them (ProbeOptions): unit ids (mdl discover's
list), baud rates and parities to try on a serial line, tables, the address range; each parser a
ValueError saying what is wrong (mdl.cli.survey names the option)."""

from __future__ import annotations

from dataclasses import dataclass

from mdl.device.survey.rawread import parse_raw_range

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


PARITIES = {"n": "N", "e": "E", "o": "O", "none": "N", "even": "E", "odd": "O"}
