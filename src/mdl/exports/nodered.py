"""`mdl export --to nodered`: a Node-RED flow for node-red-contrib-modbus (SPEC 11.1, docs/nodered.md).

A JSON array of nodes, as Node-RED's import and its flow file take them: a `tab` holding the flow; one
`modbus-client` config node for the connection (TCP host and port, RTU over TCP, or a serial line with its
settings: the CONNECTION options); one `modbus-read` per request of the read plan (`ResolvedDevice.plan`,
SPEC 8) at `--interval`, for `--unit`, each with the request's function code, address and count and a topic
naming the request; a `function` node that assembles one poll's replies into one buffer (node-red-contrib-
modbus has no poll of several requests, and a `join` node in merged mode counts keys, not messages), a
`function` node that decodes that buffer as mdl does (mdl.exports.nodered_js: mdl's value IR printed as
JavaScript) into one message per poll, `{device, unit, values: {name: value}}`, and a `debug` node showing
it; with `--publish mqtt://HOST[:PORT]/PREFIX`, an `mqtt out` node (topic PREFIX/<device stem>, QoS 1,
retained, as mdl read --publish sends) and its `mqtt-broker` config node.

Node ids are derived from the device, the connection and the unit, so the export is deterministic and two
devices' flows import side by side. Whatever the flow cannot do as mdl does is one warning per kind of loss
(base.Notes).
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING, Any

from mdl.diagnostics import error
from mdl.exchange.export import Export
from mdl.exchange.text import json_text
from mdl.exports.base import Notes, connection_of, nothing_left, plain_number
from mdl.exports.nodered_js import Decoded, assemble_code, decode_code, decoded
from mdl.ir.steps import Expression, find_step

if TYPE_CHECKING:
    from mdl.exchange.connection import Endpoint
    from mdl.exchange.export import Settings
    from mdl.resolver import ResolvedDevice, ResolvedFunction

ENGINE = "Node-RED"
EXPRESSION = "a Toolkit expression computes its value, which the flow's decoder does not: left out"
BIG_INTEGER = (
    "a JavaScript number holds integers up to 2^53 - 1: a value beyond comes as its decimal digits, in a string"
)
PROTO = "a Node-RED message cannot hold a value named __proto__ (copying the message drops it): left out"
REFUSED = (
    "a request the device refuses (exception 2) fails the poll: the flow does not read its functions again in "
    "smaller requests as mdl does"
)
DATA_TYPES = {"coil": "Coil", "discrete": "Input", "holding": "HoldingRegister", "input": "InputRegister"}
PARITY = {"N": "none", "E": "even", "O": "odd"}
Node = dict[str, Any]


class _Ids:
    """Node ids: 16 hex digits from the device, the connection, the unit and the node's role."""

    def __init__(self, *seed: object) -> None:
        self.seed = "\0".join(map(str, seed))

    def __call__(self, role: str) -> str:
        return hashlib.sha256(f"{self.seed}\0{role}".encode()).hexdigest()[:16]


def _left_out(f: ResolvedFunction, notes: Notes) -> bool:
    if find_step(f.codec.decode, Expression) is not None or f.layout.kind == "expr":
        notes.warn(f, EXPRESSION)
        return True
    return False


def _decoded(resolved: ResolvedDevice, notes: Notes) -> list[Decoded]:
    """The functions the flow decodes, in decode order (a scale register before what it scales)."""
    out: list[Decoded] = []
    left: set[str] = set()
    for f in resolved.readable:
        if not f.fn.readable:
            continue  # what an expression reads only (the expression is left out)
        if _left_out(f, notes) or any(dep in left for dep in f.deps):
            left.add(f.name)
            continue
        if f.name == "__proto__":  # decoded all the same where it scales another
            notes.warn(f, PROTO)
            out.append(decoded(resolved, f, shown=False))
            continue
        value_type = f.codec.value_type
        if value_type.kind == "int" and value_type.bits > 53:
            notes.warn(f, BIG_INTEGER)
        out.append(decoded(resolved, f))
    return out


def _client(conn: Endpoint, unit: int, node_id: str, name: str) -> Node:
    """The modbus-client config node of the connection. RTU frames over TCP are modbus-serial's TELNET port
    (frames as they are, CRC included); its TCP-RTU-BUFFERED port sends Modbus TCP frames instead.

    A serial line is one client for all its units (a fleet's flow, mdl.exports.fleet), so, as node-red-contrib-
    modbus 5.23.3 behaves with it (seen in Node-RED, tests/fleet/test_nodered_at_scale.py):
    - `parallelUnitIdsAllowed` off for a serial line: on, the client sends one request of every unit id with
      requests queued at once, and RTU frames carry no transaction id to tell the replies apart (every request
      on a line of several units timed out). A TCP client (RTU over TCP included) keeps it on: it serves one
      device, and off, its state machine (which does not wait for a reply before the next send on a TCP
      client) loses queued requests once a request times out;
    - `reconnectOnTimeout` off for a serial line: on, a unit that does not answer makes the client close the
      port, empty every unit's queue and stop every `modbus-read` until it reconnects, so one silent unit
      silenced the whole line. Over TCP (a client per device) a timeout still reconnects: the connection may
      be what broke, and the device's queued requests are dropped with it (one timeout a poll, not one a
      request)."""
    serial = conn.serial is not None
    return {
        "id": node_id,
        "type": "modbus-client",
        "name": name,
        "clienttype": "simpleser" if serial else "tcp",
        "bufferCommands": True,
        "stateLogEnabled": False,
        "queueLogEnabled": False,
        "failureLogEnabled": True,
        "tcpHost": conn.host,
        "tcpPort": str(conn.port),
        "tcpType": "TELNET" if conn.rtu else "DEFAULT",
        "serialPort": conn.serial if serial else "/dev/ttyUSB0",
        "serialType": "RTU-BUFFERD",
        "serialBaudrate": str(conn.baud),
        "serialDatabits": str(conn.bytesize),
        "serialStopbits": str(conn.stopbits),
        "serialParity": PARITY[conn.parity.upper()],
        "serialConnectionDelay": "100",
        "serialAsciiResponseStartDelimiter": "0x3A",
        "unit_id": str(unit),
        "commandDelay": "1",
        "clientTimeout": str(max(1, round(conn.timeout * 1000))),
        "reconnectOnTimeout": not serial,
        "reconnectTimeout": "2000",
        "parallelUnitIdsAllowed": not serial,
    }


def _rate(settings: Settings, notes: Notes) -> int:
    """The poll interval in milliseconds, modbus-read's finest unit (said where it changes)."""
    rate = max(1, round(settings.interval * 1000))
    if abs(rate - settings.interval * 1000) > 1e-6:
        notes.device_warning(
            f"polls in whole milliseconds: --interval {plain_number(settings.interval)} becomes {rate} ms"
        )
    return rate


def _broker(url_text: str, node_id: str, notes: Notes) -> tuple[Node, str]:
    """The mqtt-broker config node of a --publish URL, and the topic prefix."""
    from mdl.device.fleet.mqtt import parse_url
    from mdl.device.fleet.run import redacted

    try:
        url = parse_url(url_text)
    except ValueError as exc:
        raise error(f"--publish {redacted(url_text)!r}: {exc}") from None
    if url.username is not None:
        notes.device_warning(
            "the broker's user name and password are not written into the flow: give them in the mqtt-broker "
            "node (Node-RED keeps them in its credentials file)"
        )
    notes.note(
        "a poll sent while the broker is away is lost: Node-RED's mqtt out publishes only while connected "
        "(mdl read --publish queues the polls)"
    )
    node = {
        "id": node_id,
        "type": "mqtt-broker",
        "name": str(url).partition("://")[2],
        "broker": url.host,
        "port": str(url.port),
        "clientid": "",
        "autoConnect": True,
        "usetls": url.tls,
        "verifyservercert": url.tls,
        "protocolVersion": "4",
        "keepalive": "60",
        "cleansession": True,
        "autoUnsubscribe": True,
        "birthTopic": "",
        "closeTopic": "",
        "willTopic": "",
        "userProps": "",
        "sessionExpiry": "",
    }
    return node, url.prefix


def export_nodered(resolved: ResolvedDevice, settings: Settings) -> Export:
    notes = Notes(resolved, ENGINE)
    conn = connection_of(settings, notes)
    functions = _decoded(resolved, notes)
    if not any(d.shown for d in functions):
        raise nothing_left(resolved, ENGINE, notes)
    kept = {d.name for d in functions}
    groups = [g for g in resolved.plan if kept.intersection(g.request.functions)]
    if any(g.smaller for g in groups):
        notes.note(REFUSED)
    rate = _rate(settings, notes)
    device = settings.name or resolved.name  # an inventory's id names the device where it is given
    ids = _Ids(device, conn, settings.unit)
    tab, client, assemble, decode, debug = (ids(role) for role in ("tab", "client", "assemble", "decode", "debug"))
    publish = None
    if settings.publish is not None:
        publish = _broker(settings.publish, ids("broker"), notes)
    stem = settings.name or resolved.stem
    topic = f"{publish[1]}/{stem}" if publish is not None else stem
    reads: list[Node] = []
    requests: list[tuple[str, int, int]] = []
    for i, g in enumerate(groups):
        req = g.request
        name = f"{req.table} {req.start}-{req.end - 1}"
        requests.append((name, g.offset, req.count))
        reads.append(
            {
                "id": ids(f"read {i}"),
                "type": "modbus-read",
                "z": tab,
                "name": name,
                "topic": name,
                "showStatusActivities": False,
                "logIOActivities": False,
                "showErrors": False,  # the assembling node says each failed poll once, with the reason
                "unitid": str(settings.unit),
                "dataType": DATA_TYPES[req.table],
                "adr": str(req.start),
                "quantity": str(req.count),
                "rate": str(rate),
                "rateUnit": "ms",
                "delayOnStart": False,
                "startDelayTime": "",
                "server": client,
                "useIOFile": False,
                "ioFile": "",
                "useIOForPayload": False,
                "emptyMsgOnFail": True,
                "x": 170,
                "y": 100 + 60 * i,
                "wires": [[assemble], []],
            }
        )
    middle = 100 + 30 * (len(groups) - 1)
    outputs = [debug] + ([ids("mqtt out")] if publish is not None else [])
    nodes: list[Node] = [
        {"id": tab, "type": "tab", "label": f"mdl: {device}", "disabled": False, "info": ""},
        *reads,
        _function(assemble, tab, "assemble the poll", assemble_code(requests, resolved.buffer_size), decode, middle),
        {
            **_function(decode, tab, f"decode {device}", "", None, middle),
            "func": decode_code(device, settings.unit, topic, functions),
            "x": 690,
            "wires": [outputs],
        },
        {
            "id": debug,
            "type": "debug",
            "z": tab,
            "name": f"{device} values",
            "active": True,
            "tosidebar": True,
            "console": False,
            "tostatus": False,
            "complete": "payload",
            "targetType": "msg",
            "statusVal": "",
            "statusType": "auto",
            "x": 950,
            "y": middle,
            "wires": [],
        },
    ]
    if publish is not None:
        broker, _ = publish
        nodes.append(
            {
                "id": outputs[1],
                "type": "mqtt out",
                "z": tab,
                "name": "",
                "topic": topic,
                "qos": "1",
                "retain": "true",
                "respTopic": "",
                "contentType": "",
                "userProps": "",
                "correl": "",
                "expiry": "",
                "broker": broker["id"],
                "x": 950,
                "y": middle + 60,
                "wires": [],
            }
        )
    nodes.append(_client(conn, settings.unit, client, f"{device} ({conn})"))
    if publish is not None:
        nodes.append(publish[0])
    return Export(text=json_text(nodes, 2), warnings=notes.found)


def _function(node_id: str, tab: str, name: str, code: str, wire: str | None, y: int) -> Node:
    return {
        "id": node_id,
        "type": "function",
        "z": tab,
        "name": name,
        "func": code,
        "outputs": 1,
        "timeout": 0,
        "noerr": 0,
        "initialize": "",
        "finalize": "",
        "libs": [],
        "x": 440,
        "y": y,
        "wires": [[wire]] if wire is not None else [[]],
    }
