"""pysunspec2's client against mdl sim: raw images with non-trivial values for every point of a description, and
each point as the client reads it against mdl read's value."""

from __future__ import annotations

import math
import struct
from pathlib import Path

from mdl.formats.mdl.load import read_device  # noqa: E402

EXPONENTS = (-2, -1, 0, 1, 2, -3)


def _text(seed: str, nbytes: int) -> str:
    return ("".join(ch for ch in seed if ch.isalnum()) + "abcdefghijklmnopqrstuvwxyz" * 12)[:nbytes]


def _words(data: bytes) -> list[int]:
    return [int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2)]


def raw_image(xml: Path) -> dict[str, dict[str, int]]:
    """Raw values for every function that has none of its own (`initial`): scale factors from EXPONENTS,
    negative signed numbers, enumeration keys, strings filled but for their last byte (a long string's
    parts but the last one filled whole, as one string across them)."""
    device = read_device(xml)
    factors = {fn.scale_exponent for fn in device.functions if fn.scale_exponent}
    regs: dict[str, int] = {}
    for i, fn in enumerate(device.functions):
        if fn.initial is not None:
            continue
        fmt, missing = fn.format, fn.not_implemented or []
        if fn.name in factors:
            data = struct.pack(">h", EXPONENTS[i % len(EXPONENTS)])
        elif fmt == "STRING":
            n = 2 * (fn.count or 1)
            data = _text(fn.name, n if n == 250 else n - 1).encode().ljust(n, b"\0")
        elif fn.values:
            data = struct.pack(">H" if fmt == "UINT16" else ">I", sorted(fn.values)[i % len(fn.values)])
        elif fmt == "INT16":
            data = struct.pack(">h", -(100 + i % 900))
        elif fmt == "UINT16":
            data = struct.pack(">H", 1000 + i)
        elif fmt == "INT32":
            data = struct.pack(">i", -(70000 + i))
        elif fmt == "UINT32":
            data = struct.pack(">I", 70000 + i)
        elif fmt == "INT64":
            data = struct.pack(">q", -(2**40 + i))
        elif fmt == "UINT64" and "0x0000FFFFFFFFFFFF" in missing:  # eui48: its last 6 bytes
            data = struct.pack(">Q", 0x0A1B2C3D4E00 + i % 256)
        elif fmt == "UINT64":
            data = struct.pack(">Q", 2**40 + i)
        elif fmt == "FLOAT32":
            data = struct.pack(">f", -12.5 + i)
        elif fmt == "FLOAT64":
            data = struct.pack(">d", 1234.0625 + i)
        else:
            raise AssertionError(f"no raw value for {fn.name} ({fmt})")
        for k, word in enumerate(_words(data)):
            regs[str(fn.addresses[0] + k)] = word
    return {"holding": regs}


def function_names(model) -> dict[str, object]:
    """Each pysunspec2 point of `model` by the function name mdl import gives it (SPEC 12)."""
    out: dict[str, object] = {}

    def walk(group, prefix: str) -> None:
        for name, point in group.points.items():
            out[f"{prefix}_{name}"] = point
        for name, sub in group.groups.items():
            for g in sub if isinstance(sub, list) else [sub]:
                walk(g, f"{prefix}_{name}" + (f"_{g.index}" if g.index is not None else ""))

    walk(model, str(model.model_id))
    return out


def _parts(values: dict, name: str) -> list:
    if name in values:
        return [values[name]]
    parts, i = [], 1
    while f"{name}_{i}" in values:
        parts.append(values[f"{name}_{i}"])
        i += 1
    assert parts, f"no function {name} (or parts of it) in mdl read's output"
    return parts


def mdl_value(point, values: dict, name: str):
    """What mdl read says of the point, in pysunspec2's terms (a long string's parts joined, an EUI-48 and
    an IPv6 address as pysunspec2 writes them)."""
    parts = _parts(values, name)
    kind = point.pdef["type"]
    if kind == "string":
        return None if all(p is None for p in parts) else "".join(p or "" for p in parts)
    if kind == "eui48":
        v = parts[0]
        return None if v is None else ":".join(f"{(v >> (8 * k)) & 0xFF:02X}" for k in range(5, -1, -1))
    if kind == "ipv6addr":
        hexed = "".join(f"{p:016X}" for p in parts)
        return None if int(hexed, 16) == 0 else ":".join(hexed[k : k + 8] for k in range(0, 32, 8))
    return parts[0]


def client_value(point):
    """The point as pysunspec2 reads it: scaled (cvalue), an enumeration key as its symbol's name."""
    value = point.cvalue
    symbols = {s["value"]: s["name"] for s in point.pdef.get("symbols", [])}
    if point.pdef["type"].startswith("enum") and value in symbols:
        return symbols[value]
    return value


def same(a, b) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-9)
    return a == b


COMPARED = {"points": 0, "written": 0}


def differences(device, values: dict) -> list[str]:
    out = []
    for mid, models in device.models.items():
        if not isinstance(mid, int):
            continue
        for model in models:
            for name, point in function_names(model).items():
                theirs, ours = client_value(point), mdl_value(point, values, name)
                COMPARED["points"] += 1
                if not same(theirs, ours):
                    out.append(f"{name}: pysunspec2 {theirs!r}, mdl read {ours!r}")
    return out
