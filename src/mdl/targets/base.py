"""What a target registers: its name and how it renders a device."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from mdl.resolve import ResolvedDevice


@dataclass(frozen=True)
class Target:
    name: str
    render: Callable[[ResolvedDevice, str], dict[str, str]]  # (device, source file name) -> file name -> text
