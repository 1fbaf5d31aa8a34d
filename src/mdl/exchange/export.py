"""What `mdl export` hands a writer and gets back (SPEC 7, 11): the command line's `Settings` (where the
device is, its unit, how often to poll it) and an `Export`: one text (stdout or `-o FILE`) or a folder of
files (`-o DIR`), and a warning for each thing the format cannot express, naming the functions: nothing
is silently dropped or changed. A `Writer` is a format's (mdl.formats) or an engine's (mdl.exports)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mdl.diagnostics import Diagnostic
    from mdl.exchange.connection import Endpoint
    from mdl.resolver import ResolvedDevice

DEFAULT_INTERVAL = 60.0  # seconds between polls where the command line gives no --interval (SPEC 11)


@dataclass(frozen=True)
class Settings:
    """What the command line adds to a description: where the device is and how often to poll it."""

    connection: Endpoint | None = None  # None: no CONNECTION option was given
    unit: int = 1
    interval: float = DEFAULT_INTERVAL
    interval_given: bool = False  # whether --interval was on the command line
    board: str = "esp32dev"  # esphome: the ESP32 board (--board)
    tx_pin: str = "GPIO17"  # esphome: the UART's pins to the RS-485 transceiver (--tx-pin, --rx-pin)
    rx_pin: str = "GPIO16"
    flow_control_pin: str | None = None  # esphome: the RS-485 transceiver's DE/RE pin (--flow-control-pin)
    thing_model: bool = False  # wot: the device type's Thing Model, not a Thing Description (--tm)
    publish: str | None = None  # nodered: the MQTT broker each poll's message goes to (--publish mqtt://...)
    profile: str | None = None  # the profile the functions are named after (--names roles --profile NAME|FILE)
    name: str | None = None  # the device's name in the configuration (an inventory's id; None: the description's)
    tags: tuple[tuple[str, str], ...] = ()  # an inventory's tags, where the engine carries them


@dataclass
class Export:
    """What a writer produced: `text` (one file) or `files` (a folder: file name -> content)."""

    text: str | None = None
    files: dict[str, str] = field(default_factory=dict)
    warnings: list[Diagnostic] = field(default_factory=list)


Writer = Callable[["ResolvedDevice", Settings], Export]
