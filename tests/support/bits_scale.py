"""Bits of a register and values scaled by another register (SPEC 2.2, issue 21), shared by the Python, C++ and C
proofs: tests/data/flags_and_scale.xml with the sets and writes every driver must agree on, read back through
mdl read and raw registers; and random devices of that kind (a hypothesis strategy)."""

from __future__ import annotations

import json

from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from mdl.model import Device, Function
from support.common import DATA
from support.run import cli

DEVICE = DATA / "flags_and_scale.xml"


SETS = {
    "w_sf": "-1",
    "w": "123.4",
    "mode": "cool",
    "alarm": "1",
    "fan_speed": "50",
    "energy": "105",
    "status_high": "45",
}


# written in this order, each through every writer; the raw registers then hold exactly these bits
WRITES = {
    "mode": 3,
    "alarm": True,
    "fan_speed": 37.5,
    "enabled": True,
    "status_high": 33,
    "low_flag": True,
    "wmax_lim_pct": 55.5,
}


def _read(sim, *names: str) -> dict:
    proc = cli("read", DEVICE, *sim.connection, "--format", "json", *names)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def _raw(sim, start: int, count: int) -> list[int]:
    client = ModbusTcpClient(sim.host, port=sim.port)
    assert client.connect()
    try:
        return list(client.read_holding_registers(start, count=count, device_id=1).registers)
    finally:
        client.close()


FORMATS = {"UINT16": 16, "INT16": 16, "UINT32": 32, "INT32": 32, "UINT8": 8, "INT64": 64}


MULTIPLIERS = [1.0, 0.1, 12.5, 0.25, 3.0]


@st.composite
def devices(draw) -> tuple[Device, dict[tuple[str, int], int]]:
    fmt = draw(st.sampled_from(list(FORMATS)))
    width = FORMATS[fmt]
    word_order, byte_order = draw(st.sampled_from(["big", "little"])), draw(st.sampled_from(["big", "little"]))
    functions = []
    for i in range(draw(st.integers(1, 4))):
        low = draw(st.integers(0, width - 1))
        high = draw(st.integers(low, min(width - 1, low + 20)))
        one = low == high
        multiplier = None if one else draw(st.sampled_from(MULTIPLIERS))
        offset = None if one else draw(st.sampled_from([None, 0.0, 5.0, -2.5]))
        text = f"{low}" if one else (f"{low}-{high}" if draw(st.booleans()) else f"{high}-{low}")
        functions.append(
            Function(
                f"f{i}",
                "flag",
                [10],
                format=fmt,
                bits=text,
                multiplier=multiplier,
                offset=offset,
                word_order=word_order,
                byte_order=byte_order,
                write_function_code="22" if draw(st.booleans()) and width == 16 else None,
            )
        )
    exponent = draw(st.booleans())
    factor_fmt = "INT16" if exponent else draw(st.sampled_from(["UINT16", "INT16", "UINT32"]))
    functions.append(
        Function("sf", "factor", [20], format=factor_fmt, not_implemented=["0x8000"] if draw(st.booleans()) else None)
    )
    value_fmt = draw(st.sampled_from(["INT16", "UINT16", "INT32", "UINT32"]))
    functions.append(
        Function(
            "scaled",
            "scaled",
            [30],
            format=value_fmt,
            multiplier=draw(st.sampled_from(MULTIPLIERS)),
            offset=draw(st.sampled_from([None, 1.5])),
            **{"scale_exponent" if exponent else "scale_by": "sf"},
        )
    )
    device = Device("Fuzz", "fuzz", functions, version="1.0")
    raw = {("holding", a): draw(st.integers(0, 0xFFFF)) for a in (*range(10, 14), 20, 21, *range(30, 32))}
    if exponent and draw(st.booleans()):
        raw[("holding", 20)] = draw(st.integers(-25, 25)) & 0xFFFF  # mostly a real SunSpec exponent
    return device, raw
