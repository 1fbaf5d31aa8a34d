"""`mdl export --inventory FLEET --to ENGINE -o DIR [--shards K]` (SPEC 15): one engine configuration for
the devices of an inventory, each device's part what the single export gives for it (its connection, unit
and interval from the inventory), named after the device's id and carrying its tags where the engine has
a place for them.

- `thingsboard`: one connector, `modbus.json`, with each device's slaves (`deviceName`: its id).
- `telegraf`: K agent folders, `shard-1/telegraf.conf` ...: each device an `[[inputs.modbus]]` named
  after its id with `[inputs.modbus.tags]` (`device` and the inventory's tags), each kind's processors
  once per agent; the devices of one serial line or one gateway (a host and port) stay in one shard,
  the lines spread so that the shards' device counts are as even as whole lines allow.
- `nodered`: one flow, `flows.json`, with a tab per line (a serial line, or a host and port): the line's
  devices' nodes on it, one `modbus-client` for a serial line (node-red-contrib-modbus queues its
  requests) and one per device behind a TCP gateway (its client times out requests for several unit ids
  queued on one connection), one `mqtt-broker` for the fleet with `--publish`; messages and topics name
  each device by its id.
- `volttron`, `wot`: each device's own files in a folder named after its id (VOLTTRON's driver files,
  the Thing Description `ID.td.jsonld`).

- `homeassistant`: one `modbus.yaml` with a hub per line (a serial port, or a host and port), each
  device's entities on it, named `ID NAME` (Home Assistant's entity names are one namespace).

ESPHome is a node per device on its own RS-485 line: not written for a fleet (a clear error).
Warnings are the single exports', each kind said once for the fleet.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.exchange.export import Export, Settings

if TYPE_CHECKING:
    from collections.abc import Callable

    from mdl.device.fleet.inventory import Member

Node = dict[str, Any]

FLEET_ENGINES = ("telegraf", "thingsboard", "homeassistant", "nodered", "volttron", "wot")


def _settings(member: Member, base: Settings) -> Settings:
    entry = member.entry
    return replace(
        base,
        connection=entry.connection,
        unit=entry.unit,
        interval=entry.interval,
        interval_given=True,
        name=entry.id,
        tags=tuple(sorted(entry.tags.items())),
    )


def line_of(member: Member) -> tuple[object, ...]:
    """What a shard never splits: a serial line, or a host and port (a gateway's units, a TCP device)."""
    conn = member.entry.connection
    return ("serial", conn.serial) if conn.serial is not None else ("tcp", conn.host, conn.port)


def shards_of(members: list[Member], k: int) -> list[list[Member]]:
    """At most k shards of whole lines, the largest lines placed first on the emptiest shard; each shard's
    devices in the inventory's order."""
    lines: dict[tuple[object, ...], list[Member]] = {}
    for m in members:
        lines.setdefault(line_of(m), []).append(m)
    shards: list[list[Member]] = [[] for _ in range(min(k, len(lines)))]
    for group in sorted(lines.values(), key=len, reverse=True):
        min(shards, key=len).extend(group)
    order = {id(m): i for i, m in enumerate(members)}
    return [sorted(shard, key=lambda m: order[id(m)]) for shard in shards]


def _hub_name(member: Member) -> str:
    """A Home Assistant hub's name for a line: its port or host and port, in the characters a name keeps."""
    conn = member.entry.connection
    where = conn.serial if conn.serial is not None else f"{conn.host}_{conn.port}"
    return "line_" + "".join(ch if ch.isalnum() else "_" for ch in where).strip("_")


def _one(member: Member, to: str, base: Settings) -> Export:
    """One device's export; its errors name the device's id and its line in the inventory."""
    from mdl.exports import export

    try:
        return export(member.resolved, to, _settings(member, base))
    except MdlError as exc:
        entry = member.entry
        raise MdlError(
            [
                Diagnostic(d.file, d.line, d.col, f"device {entry.id} (inventory line {entry.line}): {d.message}")
                for d in exc.diagnostics
            ]
        ) from None


def export_fleet(members: list[Member], to: str, base: Settings, shards: int = 1) -> tuple[Export, list[str]]:
    """The fleet's files, and the notes saying how it was split."""

    if to not in FLEET_ENGINES:
        raise error(f"--inventory: --to {to} is not written for a fleet yet (one of {', '.join(FLEET_ENGINES)})")
    if shards != 1 and to != "telegraf":
        raise error("--shards splits Telegraf's agents: it needs --to telegraf")
    files: dict[str, str] = {}
    warnings: list[Diagnostic] = []
    notes: list[str] = []

    def said(found: list[Diagnostic]) -> None:
        warnings.extend(w for w in found if w not in warnings)

    if to == "telegraf":
        from mdl.exports.telegraf import export_telegraf_fleet

        split = shards_of(members, shards)
        if len(split) < shards:
            notes.append(f"--shards {shards}: the fleet has {len(split)} lines, and a line is not split")
        for i, shard in enumerate(split, 1):
            result = export_telegraf_fleet([(m.resolved, _settings(m, base)) for m in shard])
            files[f"shard-{i}/telegraf.conf"] = result.text or ""
            said(result.warnings)
        return Export(files=files, warnings=warnings), notes
    if to == "thingsboard":
        import json

        from mdl.exchange.text import json_text

        slaves = []
        for m in members:
            result = _one(m, to, base)
            slaves += json.loads(result.text or "{}")["master"]["slaves"]
            said(result.warnings)
        tagged = [m.entry.id for m in members if m.entry.tags]
        if tagged:
            notes.append(f"ThingsBoard's connector has no place for tags: those of {', '.join(tagged)} are not in it")
        return Export(files={"modbus.json": json_text({"master": {"slaves": slaves}}, 2)}, warnings=warnings), notes
    if to == "homeassistant":
        from mdl.exports.homeassistant import fleet_text, hub_of

        hubs: dict[tuple[object, ...], dict[str, Any]] = {}
        for m in members:
            result = _one(m, to, base)
            said(result.warnings)
            hub = hub_of(result.text or "")
            line = line_of(m)
            if line not in hubs:
                hubs[line] = {**hub, "name": _hub_name(m)}
                continue
            for key, value in hub.items():
                if isinstance(value, list):
                    hubs[line].setdefault(key, []).extend(value)
        return Export(files={"modbus.yaml": fleet_text(list(hubs.values()))}, warnings=warnings), notes
    if to == "nodered":
        return Export(files={"flows.json": _nodered_flow(members, base, said)}, warnings=warnings), notes
    for m in members:
        result = _one(m, to, base)
        said(result.warnings)
        if result.text is not None:
            files[f"{m.entry.id}/{m.entry.id}.td.jsonld" if to == "wot" else f"{m.entry.id}/{to}"] = result.text
        for name, text in result.files.items():
            files[f"{m.entry.id}/{name}"] = text
    return Export(files=files, warnings=warnings), notes


def _nodered_flow(members: list[Member], base: Settings, said: Callable[[list[Diagnostic]], None]) -> str:
    """Each device's flow, its nodes moved onto its line's tab (below the devices before it) and its reads
    to the line's one client; the brokers one."""
    import json

    from mdl.exchange.text import json_text

    tabs: dict[tuple[object, ...], tuple[Node, Node]] = {}  # line -> (its tab, its client)
    flow: list[Node] = []
    brokers: dict[str, str] = {}  # a broker's settings -> its node id
    depth: dict[tuple[object, ...], int] = {}
    for m in members:
        result = _one(m, "nodered", base)
        said(result.warnings)
        nodes: list[Node] = json.loads(result.text or "[]")
        line = line_of(m)
        tab = next(n for n in nodes if n["type"] == "tab")
        client = next(n for n in nodes if n["type"] == "modbus-client")
        if line not in tabs:
            label = f"mdl: {m.entry.connection}"
            tabs[line] = ({**tab, "label": label}, client)
            flow += [tabs[line][0], client]
        line_tab, line_client = tabs[line]
        if m.entry.connection.serial is None and line_client is not client:
            # a TCP gateway takes a connection per device: node-red-contrib-modbus times out requests for
            # several unit ids queued on one client (seen with 5.23.3), where a serial port can only be one
            flow.append(client)
            line_client = client
        shift = depth.get(line, 0)
        bottom = 0
        for node in nodes:
            if node["type"] in ("tab", "modbus-client"):
                continue
            if node["type"] == "mqtt-broker":
                key = json.dumps({k: v for k, v in node.items() if k != "id"}, sort_keys=True)
                if key in brokers:
                    continue
                brokers[key] = node["id"]
                flow.append(node)
                continue
            if "z" in node:
                node["z"] = line_tab["id"]
            if node.get("server") == client["id"]:
                node["server"] = line_client["id"]
            if "broker" in node:
                key = json.dumps(
                    {k: v for k, v in next(n for n in nodes if n["id"] == node["broker"]).items() if k != "id"},
                    sort_keys=True,
                )
                node["broker"] = brokers.get(key, node["broker"])
            if "y" in node:
                node["y"] += shift
                bottom = max(bottom, node["y"])
            flow.append(node)
        depth[line] = bottom + 80
    return json_text(flow, 2)
