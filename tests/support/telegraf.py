"""Telegraf's Modbus input as its documentation and code say it reads an export (Telegraf itself cannot be
installed here): the configuration checks it makes, one gather against a device, its processors."""

from __future__ import annotations

import struct

from pymodbus.client import ModbusTcpClient

TYPES = {
    "INT8L",
    "INT8H",
    "UINT8L",
    "UINT8H",
    "INT16",
    "UINT16",
    "INT32",
    "UINT32",
    "INT64",
    "UINT64",
    "FLOAT32",
    "FLOAT64",
    "STRING",
    "BIT",
}


LENGTH = {
    "INT8L": 1,
    "INT8H": 1,
    "UINT8L": 1,
    "UINT8H": 1,
    "INT16": 1,
    "UINT16": 1,
    "INT32": 2,
    "UINT32": 2,
    "FLOAT32": 2,
    "INT64": 4,
    "UINT64": 4,
    "FLOAT64": 4,
}


def to_host16(register: int, order: str) -> int:
    """A register as Telegraf's 16-bit converters see it: ABCD/CDAB as sent, DCBA/BADC bytes swapped."""
    return register if order in ("ABCD", "CDAB") else ((register & 0xFF) << 8) | (register >> 8)


def raw_bytes(registers: list[int], order: str) -> bytes:
    """The value's bytes, most significant first, for a 32/64-bit type in `order` (type_conversions32/64.go)."""
    wire = b"".join(r.to_bytes(2, "big") for r in registers)
    if order == "ABCD":
        return wire
    if order == "DCBA":
        return wire[::-1]
    if order == "BADC":  # most significant word first, each word's bytes swapped
        return b"".join(wire[i : i + 2][::-1] for i in range(0, len(wire), 2))
    return b"".join(wire[i : i + 2] for i in reversed(range(0, len(wire), 2)))  # CDAB: least significant word first


def decode(field: dict, registers: list[int], order: str):
    kind = field["type"]
    if kind.startswith(("INT8", "UINT8")):
        data = registers[0].to_bytes(2, "big")
        index = {("ABCD", True): 1, ("ABCD", False): 0, ("DCBA", True): 0, ("DCBA", False): 1}[
            (order, kind.endswith("L"))
        ]
        value = data[index]
        return value - 256 if kind.startswith("INT") and value > 127 else value
    if kind == "BIT":  # type_conversions_bit.go: the register converted as a 16-bit one, then v >> bit & 1
        return (to_host16(registers[0], order) >> field["bit"]) & 1
    if kind == "STRING":
        text = b"".join(to_host16(r, order).to_bytes(2, "big") for r in registers)
        return text.split(b"\x00", 1)[0].decode()
    if LENGTH[kind] == 1:
        word = to_host16(registers[0], order)
        return word - 65536 if kind == "INT16" and word > 32767 else word
    data = raw_bytes(registers, order)
    code = {"INT32": ">i", "UINT32": ">I", "FLOAT32": ">f", "INT64": ">q", "UINT64": ">Q", "FLOAT64": ">d"}[kind]
    return struct.unpack(code, data)[0]


def check_config(config: dict) -> None:
    """What Telegraf's ConfigurationPerRequest.Check refuses, checked here too."""
    plugin = config["inputs"]["modbus"][0]
    assert plugin["configuration_type"] == "request"
    seen = set()
    for request in plugin["request"]:
        assert request["byte_order"] in ("ABCD", "DCBA", "BADC", "CDAB")
        assert request["register"] in ("coil", "discrete", "holding", "input")
        for field in request["fields"]:
            if request["register"] in ("holding", "input"):
                assert field["type"] in TYPES, field
            if field.get("omit"):
                continue
            key = (request["slave_id"], request["register"], request["measurement"], field["name"])
            assert key not in seen, key
            seen.add(key)


def telegraf_gather(config: dict, host: str, port: int) -> tuple[dict, list[tuple[str, int, int]]]:
    """One gather: field name -> value, and the requests sent (table, start, count)."""
    plugin = config["inputs"]["modbus"][0]
    client = ModbusTcpClient(host, port=port)
    assert client.connect()
    values: dict = {}
    sent = []
    try:
        for request in plugin["request"]:
            fields = sorted(request["fields"], key=lambda f: f["address"])
            table = request["register"]
            bits = table in ("coil", "discrete")
            length = [1 if bits else f.get("length", LENGTH.get(f["type"], 1)) for f in fields]
            start = fields[0]["address"]
            reach = start
            for field, n in zip(fields, length, strict=True):  # no gap: Telegraf keeps the section one request
                assert field["address"] <= reach, (field, reach)
                reach = max(reach, field["address"] + n)
            count = reach - start
            method = {
                "coil": client.read_coils,
                "discrete": client.read_discrete_inputs,
                "holding": client.read_holding_registers,
                "input": client.read_input_registers,
            }[table]
            reply = method(start, count=count, device_id=request["slave_id"])
            assert not reply.isError(), (table, start, count, reply)
            sent.append((table, start, count))
            data = reply.bits[:count] if bits else list(reply.registers)
            for field, n in zip(fields, length, strict=True):
                if field.get("omit"):
                    continue
                at = field["address"] - start
                if bits:
                    values[field["name"]] = bool(data[at])
                    continue
                value = decode(field, data[at : at + n], request["byte_order"])
                if field.get("scale"):
                    value = float(value) * field["scale"]
                values[field["name"]] = value
    finally:
        client.close()
    return run_processors(config, values), sent


def run_processors(config: dict, values: dict) -> dict:
    """The exported processors, in their `order`, as their READMEs define them:
    - starlark: the script's `apply(metric)` (Starlark is a Python dialect; the script uses nothing whose
      meaning differs: a dict, a for loop, `float(x) / d`, `!= None`);
    - scale: factor * value + offset for the listed fields;
    - enum: the string of the value looked up in value_mappings, else `default` where given."""
    processors = [(kind, p) for kind, ps in config.get("processors", {}).items() for p in ps]
    assert sorted(p["order"] for _, p in processors) == list(range(1, len(processors) + 1))
    for kind, processor in sorted(processors, key=lambda kp: kp[1]["order"]):
        if kind == "starlark":
            namespace: dict = {}
            exec(processor["source"], namespace)  # noqa: S102 - the exported script, run as Starlark would
            values = namespace["apply"](StarlarkMetric(values)).fields
        elif kind == "scale":
            for scaling in processor["scaling"]:
                for name in scaling["fields"]:
                    values[name] = scaling["factor"] * values[name] + scaling["offset"]
        elif kind == "enum":
            for mapping in processor["mapping"]:
                value = values[mapping["field"]]
                key = str(value).lower() if isinstance(value, bool) else str(value)  # Go's FormatBool/Uint
                if key in mapping["value_mappings"]:
                    values[mapping["field"]] = mapping["value_mappings"][key]
                elif "default" in mapping:
                    values[mapping["field"]] = mapping["default"]
        else:
            raise AssertionError(f"unexpected processor {kind}")
    return values


class StarlarkMetric:
    """The part of Telegraf's Starlark metric the exported script uses: `fields`, a dict."""

    def __init__(self, fields: dict):
        self.fields = fields
