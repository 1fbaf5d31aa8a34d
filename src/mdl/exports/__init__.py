"""`mdl export`: a resolved description -> another format (SPEC 7: XIF, WISE-Agent, SenML) or the
configuration of an engine that polls fleets (SPEC 11: VOLTTRON, Home Assistant, Telegraf).

The registry names each format's writer by module and function, imported only when that format is
asked for. A writer takes the resolved device and the `Settings` of the command line and returns an
`Export`: one text (stdout or `-o FILE`) or a folder of files (`-o DIR`), and the warnings for what the
format cannot express, naming the functions (the engines: one per kind of loss, `engines.Notes`): nothing
is silently dropped or changed.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

if TYPE_CHECKING:
    from mdl.device.connection import Connection
    from mdl.diagnostics import Diagnostic
    from mdl.resolve import ResolvedDevice

DEFAULT_INTERVAL = 60.0  # seconds between polls where the command line gives no --interval (SPEC 11)


@dataclass(frozen=True)
class Settings:
    """What the command line adds to a description: where the device is and how often to poll it."""

    connection: Connection | None = None  # None: no CONNECTION option was given
    unit: int = 1
    interval: float = DEFAULT_INTERVAL
    interval_given: bool = False  # whether --interval was on the command line


@dataclass
class Export:
    """What a writer produced: `text` (one file) or `files` (a folder: file name -> content)."""

    text: str | None = None
    files: dict[str, str] = field(default_factory=dict)
    warnings: list[Diagnostic] = field(default_factory=list)


Writer = Callable[["ResolvedDevice", Settings], Export]

# --to name -> (module, function, one line for --help)
_WRITERS: dict[str, tuple[str, str, str]] = {
    "xif": ("mdl.sources.xif.write", "export_xif", "SmartServer Modbus XIF (.mod)"),
    "wise": ("mdl.sources.wise.write", "export_wise", "WISE-Agent Modbus.ini (the shipped agent's form)"),
    "senml": ("mdl.exports.senml", "export_capability", "the WISE guide's SenML capability document"),
    "volttron": ("mdl.exports.volttron", "export_volttron", "VOLTTRON Modbus-TK driver files (a folder)"),
    "homeassistant": ("mdl.exports.homeassistant", "export_homeassistant", "Home Assistant modbus: YAML"),
    "telegraf": ("mdl.exports.telegraf", "export_telegraf", "Telegraf [[inputs.modbus]] TOML"),
}
FOLDER_FORMATS = ("volttron",)  # formats that write a folder and need -o


def names() -> list[str]:
    return list(_WRITERS)


def summaries() -> dict[str, str]:
    return {name: summary for name, (_, _, summary) in _WRITERS.items()}


def writer(name: str) -> Writer:
    module, function, _ = _WRITERS[name]
    return cast(Writer, getattr(importlib.import_module(module), function))


def export(resolved: ResolvedDevice, name: str, settings: Settings) -> Export:
    """The description in format `name` (one of `names()`)."""
    return writer(name)(resolved, settings)
