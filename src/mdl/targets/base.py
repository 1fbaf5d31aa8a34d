"""What a target registers: its name and how it renders a device."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from mdl.model import Device


@dataclass(frozen=True)
class Target:
    name: str
    render: Callable[[Device, str], dict[str, str]]  # (device, source file name) -> file name -> text
