"""The configurations of the engines that poll fleets (SPEC 11: VOLTTRON, Home Assistant, Telegraf,
ESPHome, the ThingsBoard gateway) and
the WISE guide's SenML capability document, made from a resolved description (`mdl export`).

ENGINES is their registry; `outputs()` is every `mdl export --to` choice: the formats that write
themselves back (mdl.formats), then the engines. Each writer takes the resolved device and the command
line's mdl.exchange.export.Settings and returns an Export, with one warning per kind of loss
(`base.Notes`); it is imported when first called, so that commands start fast.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from mdl.formats import FORMATS
from mdl.registry import Registry, lazy

if TYPE_CHECKING:
    from mdl.exchange.export import Export, Settings, Writer
    from mdl.resolver import ResolvedDevice


@dataclass(frozen=True)
class Output:
    """One `mdl export --to` choice: its name, the line `--help` gives it, its writer, and whether it
    writes a folder of files (which needs -o DIR)."""

    name: str
    summary: str
    write: Writer
    folder: bool = False


ENGINES: Registry[Output] = Registry(
    Output("senml", "the WISE guide's SenML capability document", lazy("mdl.exports.senml", "export_capability")),
    Output(
        "volttron",
        "VOLTTRON Modbus-TK driver files (a folder)",
        lazy("mdl.exports.volttron", "export_volttron"),
        folder=True,
    ),
    Output("homeassistant", "Home Assistant modbus: YAML", lazy("mdl.exports.homeassistant", "export_homeassistant")),
    Output("telegraf", "Telegraf [[inputs.modbus]] TOML", lazy("mdl.exports.telegraf", "export_telegraf")),
    Output("esphome", "an ESPHome node with modbus_controller (YAML)", lazy("mdl.exports.esphome", "export_esphome")),
    Output(
        "thingsboard",
        "the ThingsBoard IoT Gateway's Modbus connector (JSON)",
        lazy("mdl.exports.thingsboard", "export_thingsboard"),
    ),
    Output("wot", "a W3C WoT Thing Description with Modbus forms (JSON-LD)", lazy("mdl.exports.wot", "export_wot")),
    Output("nodered", "a Node-RED flow for node-red-contrib-modbus", lazy("mdl.exports.nodered", "export_nodered")),
)


def outputs() -> Registry[Output]:
    """Every `mdl export --to` choice, in the order `--help` lists them: the formats that write, then the
    engines."""
    return Registry(*(Output(f.name, f.summary, f.write) for f in FORMATS.values() if f.write is not None)) + ENGINES


def export(resolved: ResolvedDevice, name: str, settings: Settings) -> Export:
    """The description as `mdl export --to NAME` writes it (`name`: one of `outputs()`)."""
    return outputs()[name].write(resolved, settings)
