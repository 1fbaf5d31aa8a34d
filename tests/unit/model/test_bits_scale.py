"""Issue 21: bits inside registers (`bits`) and values scaled by another register (`scale_exponent`,
`scale_by`), SPEC 2.2: validated, kept by the XML reader and writer, read and written by `mdl read`/`write`,
`mdl sim` and the generated Python driver (sync and asyncio) alike, on a device whose flag register holds
four functions and whose set point is scaled SunSpec-style (tests/data/flags_and_scale.xml)."""

from __future__ import annotations

import asyncio
import json

import pytest
from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient

from mdl.formats.mdl import device_to_xml, load_device
from support.bits_scale import DEVICE, SETS, WRITES, _raw, _read
from support.common import MDL_NS, import_generated
from support.refusing_proxy import refusing_proxy
from support.run import assert_clean_error, cli, run_mdl

READ_AFTER_SETS = {
    "alarm": True,
    "mode": "cool",
    "fan_speed": 50.0,
    "enabled": False,
    "status_high": 45,
    "low_flag": False,
    "w_sf": -1,
    "w": 123.4,
    "wmax_lim_pct": 0.0,
    "wmax_lim_pct_sf": -2,
    "energy_scale": 10,
    "energy": 105.0,
    "suns": 0x53756E53,
}


def _xml(functions: str) -> str:
    return (
        f'<?xml version="1.0" encoding="US-ASCII"?>\n<device xmlns="{MDL_NS}" version="1.0">\n'
        f"  <name>Bad</name>\n  <description>test</description>\n{functions}</device>\n"
    )


def _fn(name: str, address: int, body: str) -> str:
    return (
        f"  <function>\n    <name>{name}</name>\n    <description>{name}</description>\n"
        f"    <addresses>{address}</addresses>\n{body}  </function>\n"
    )


# ---- schema, model, validate

BAD = {
    "bits outside the format": (
        _fn("a", 1, "    <format>UINT16</format>\n    <bits>3-16</bits>\n"),
        "bits 3-16 are outside the 16-bit value",
    ),
    "bits of an 8-bit format": (
        _fn("a", 1, "    <format>UINT8</format>\n    <bits>8</bits>\n"),
        "outside the 8-bit value",
    ),
    "bits of a float": (_fn("a", 1, "    <format>FLOAT32</format>\n    <bits>1</bits>\n"), "format FLOAT32 has none"),
    "bits of a string": (
        _fn("a", 1, "    <count>2</count>\n    <format>STRING</format>\n    <bits>1</bits>\n"),
        "format STRING has none",
    ),
    "bits of a BIT": (_fn("a", 1, "    <format>BIT</format>\n    <bits>0</bits>\n"), "a BIT has none"),
    "bits with a read fragment": (
        _fn(
            "a",
            1,
            "    <format>UINT16</format>\n    <read_function_code>arg = r1;</read_function_code>\n    <bits>1</bits>\n",
        ),
        "read_function_code",
    ),
    "one bit scaled": (
        _fn("a", 1, "    <format>UINT16</format>\n    <multiplier>2</multiplier>\n    <bits>1</bits>\n"),
        "one bit is a boolean",
    ),
    "function 22 without bits": (
        _fn("a", 1, "    <format>UINT16</format>\n    <write_function_code>22</write_function_code>\n"),
        "needs <bits>",
    ),
    "a missing factor": (
        _fn("a", 1, "    <format>INT16</format>\n    <scale_exponent>nope</scale_exponent>\n"),
        "scale_exponent names no function 'nope'",
    ),
    "scaled by itself": (
        _fn("a", 1, "    <format>INT16</format>\n    <scale_by>a</scale_by>\n"),
        "names the function itself",
    ),
    "a float factor": (
        _fn("sf", 2, "    <format>INT16</format>\n    <multiplier>0.5</multiplier>\n")
        + _fn("a", 1, "    <format>INT16</format>\n    <scale_exponent>sf</scale_exponent>\n"),
        "'sf' is not an integer",
    ),
    "a scaled factor (a cycle)": (
        _fn("b", 2, "    <format>INT16</format>\n    <scale_by>a</scale_by>\n")
        + _fn("a", 1, "    <format>INT16</format>\n    <scale_by>b</scale_by>\n"),
        "is itself scaled by",
    ),
    "a write-only factor": (
        _fn("sf", 2, "    <format>INT16</format>\n    <access>write</access>\n")
        + _fn("a", 1, "    <format>INT16</format>\n    <scale_exponent>sf</scale_exponent>\n"),
        "cannot be read",
    ),
    "a scaled float": (
        _fn("sf", 2, "    <format>INT16</format>\n")
        + _fn("a", 1, "    <format>FLOAT32</format>\n    <scale_exponent>sf</scale_exponent>\n"),
        "format FLOAT32 cannot be scaled",
    ),
    "both scales": (
        _fn("sf", 2, "    <format>INT16</format>\n")
        + _fn(
            "a", 1, "    <format>INT16</format>\n    <scale_exponent>sf</scale_exponent>\n    <scale_by>sf</scale_by>\n"
        ),
        "cannot both apply",
    ),
    "initial of the wrong size": (
        _fn("a", 1, "    <format>UINT32</format>\n    <initial>1</initial>\n"),
        "initial gives 1 value(s) for 2 register(s)",
    ),
    "initial too large": (
        _fn("a", 1, "    <format>UINT16</format>\n    <initial>65536</initial>\n"),
        "initial value 65536 is outside 0..65535",
    ),
    "a role that is no name": (
        _fn("a", 1, "    <format>UINT16</format>\n    <role>power w</role>\n"),
        "Element",
    ),  # the XSD's pattern
    "bits that are no range": (_fn("a", 1, "    <format>UINT16</format>\n    <bits>1-2-3</bits>\n"), "Element"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_validate_refuses_each_misuse_at_its_element(case, tmp_path):
    functions, said = BAD[case]
    path = tmp_path / "bad.xml"
    path.write_text(_xml(functions), encoding="ascii")
    proc = cli("validate", path)
    assert_clean_error(proc, 1, said)
    assert f"{path}:" in proc.stderr and ": error: " in proc.stderr
    line = next(x for x in proc.stderr.splitlines() if said in x)
    assert line.split(":")[1].isdigit() and line.split(":")[2].isdigit(), line  # FILE:LINE:COL


def test_two_functions_share_a_register_with_different_bits_and_validate_names_the_extensions():
    proc = cli("validate", DEVICE)
    assert proc.returncode == 0, proc.stderr
    for ext in ("bits", "scale_exponent", "scale_by", "role", "initial"):
        assert ext in proc.stdout


def test_the_writer_keeps_every_new_element(tmp_path):
    device = load_device(DEVICE)
    text = device_to_xml(device)
    path = tmp_path / "again.xml"
    path.write_text(text, encoding="ascii")
    again = load_device(path)
    assert again == device
    by_name = {fn.name: fn for fn in again.functions}
    assert by_name["mode"].bits == "4-5" and by_name["enabled"].write_function_code == "22"
    assert by_name["w"].scale_exponent == "w_sf" and by_name["energy"].scale_by == "energy_scale"
    assert by_name["wmax_lim_pct"].role == "power_limit_pct" and by_name["suns"].initial == [0x5375, 0x6E53]


def test_bits_written_high_to_low_are_the_same_bits(tmp_path):
    path = tmp_path / "d.xml"
    path.write_text(_xml(_fn("a", 1, "    <format>UINT16</format>\n    <bits>11-8</bits>\n")), encoding="ascii")
    assert load_device(path).functions[0].bit_range == (8, 11)


# ---- mdl sim, mdl read, mdl write


@pytest.mark.commands  # serves or dials a device
def test_sim_initial_and_set_encode_as_the_drivers_and_read_back(sim_factory):
    sim = sim_factory(DEVICE, *[x for name, value in SETS.items() for x in ("--set", f"{name}={value}")])
    assert _read(sim) == READ_AFTER_SETS
    # the flag register holds alarm (bit 0), mode cool (2 in bits 4-5) and fan speed 4 (bits 8-11)
    assert _raw(sim, 100, 1) == [0x0421]
    assert _read(sim, "w") == {"w": 123.4}  # the plan of one scaled function reads its factor with it


def test_sim_refuses_a_set_that_does_not_fit_its_bits_or_has_no_factor(tmp_path):
    proc = run_mdl("sim", DEVICE, "--port", "0", "--set", "fan_speed=200")
    assert_clean_error(proc, 1, "fan_speed=200", "does not fit its 4 bits")
    proc = run_mdl("sim", DEVICE, "--port", "0", "--set", "w_sf=-32768", "--set", "w=5")
    assert_clean_error(proc, 1, "w=5", "scale factor has no value", "'w_sf' holds null")


@pytest.mark.commands  # serves or dials a device
def test_mdl_write_changes_only_its_bits_and_uses_function_22_where_asked(sim_factory):
    sim = sim_factory(DEVICE, "--set", "status_high=63")
    with refusing_proxy(sim.host, sim.port) as proxy:
        for name, value in WRITES.items():
            before = len(proxy.codes)
            text = "1" if value is True else str(value)
            proc = cli("write", DEVICE, "--host", proxy.host, "--port", proxy.port, f"{name}={text}")
            assert proc.returncode == 0, proc.stderr
            codes = proxy.codes[before:]
            if name == "enabled":
                assert codes == [22]  # no read: the device changes the bit
            elif name == "wmax_lim_pct":
                assert codes == [3, 6]  # the factor first, then the value
            elif name == "status_high":
                assert codes == [3, 16]
            else:
                assert codes == [3, 6], (name, codes)  # read, change the bits, write back
    got = _read(sim)
    assert {name: got[name] for name in WRITES} == {**WRITES, "mode": "auto"}
    assert _raw(sim, 100, 1) == [0x8000 | 0x0300 | 0x30 | 1]
    assert _raw(sim, 202, 2) == [5550, (-2) & 0xFFFF]


@pytest.mark.commands  # serves or dials a device
def test_a_scaled_set_point_written_after_its_scale_register_changes(sim_factory):
    sim = sim_factory(DEVICE)
    assert cli("write", DEVICE, *sim.connection, "wmax_lim_pct=55.5").returncode == 0
    assert _raw(sim, 202, 1) == [5550]
    assert cli("write", DEVICE, *sim.connection, "wmax_lim_pct_sf=-1").returncode == 0
    assert _read(sim, "wmax_lim_pct") == {"wmax_lim_pct": 555.0}  # the old raw value, the new factor
    assert cli("write", DEVICE, *sim.connection, "wmax_lim_pct=55.5").returncode == 0
    assert _raw(sim, 202, 1) == [555]
    assert _read(sim, "wmax_lim_pct") == {"wmax_lim_pct": 55.5}


@pytest.mark.commands  # serves or dials a device
def test_mdl_write_refuses_before_sending_what_does_not_fit(sim_factory):
    sim = sim_factory(DEVICE, "--set", "mode=heat")
    with refusing_proxy(sim.host, sim.port) as proxy:
        proc = cli("write", DEVICE, "--host", proxy.host, "--port", proxy.port, "fan_speed=200")
        assert_clean_error(proc, 1, "fan_speed=200", "does not fit its 4 bits")
        assert proxy.codes == []  # refused before it connected
        proc = cli("write", DEVICE, "--host", proxy.host, "--port", proxy.port, "mode=5")
        assert_clean_error(proc, 1, "mode=5", "does not fit")
        assert cli("write", DEVICE, "--host", proxy.host, "--port", proxy.port, "w_sf=-32768").returncode == 0
        before = len(proxy.codes)
        proc = cli("write", DEVICE, "--host", proxy.host, "--port", proxy.port, "w=5")
        assert_clean_error(proc, 1, "w=5", "scale factor has no value", "'w_sf' reads null")
        assert 6 not in proxy.codes[before:] and 16 not in proxy.codes[before:]  # only the factor was read
        proc = cli("write", DEVICE, "--host", proxy.host, "--port", proxy.port, "wmax_lim_pct=100", "wmax_lim_pct_sf=3")
        assert proc.returncode == 0, proc.stderr  # each value checked with the factor it then has
    assert _read(sim, "mode", "w", "wmax_lim_pct") == {"mode": "heat", "w": None, "wmax_lim_pct": 10000 * 1000.0}
    assert _raw(sim, 202, 1) == [10000]


# ---- the generated Python driver


@pytest.fixture(scope="module")
def driver(tmp_path_factory):
    out = tmp_path_factory.mktemp("py")
    proc = run_mdl("gen", DEVICE, "--lang", "python", "-o", out)
    assert proc.returncode == 0, proc.stderr
    return import_generated(out / "flags_and_scale.py", "flags_and_scale_issue21")


@pytest.mark.commands  # serves or dials a device
def test_python_driver_reads_as_mdl_read(driver, sim_factory):
    sim = sim_factory(DEVICE, *[x for name, value in SETS.items() for x in ("--set", f"{name}={value}")])
    client = ModbusTcpClient(sim.host, port=sim.port)
    assert client.connect()
    try:
        dev = driver.FlagsAndScale(client)
        values = dict(dev.read_all())
        assert values == {**READ_AFTER_SETS, "mode": 2}  # a driver gives the number of an enumeration
        assert dev.read_w() == 123.4 and dev.read_fan_speed() == 50.0 and dev.read_alarm() is True
    finally:
        client.close()


@pytest.mark.commands  # serves or dials a device
@pytest.mark.parametrize("flavour", ["sync", "async"])
def test_python_driver_writes_land_as_mdl_read_reads_them(flavour, driver, sim_factory):
    sim = sim_factory(DEVICE, "--set", "status_high=63")
    with refusing_proxy(sim.host, sim.port) as proxy:
        codes = _write_with_driver(driver, flavour, proxy)
    assert codes["enabled"] == [22] and codes["alarm"] == [3, 6] and codes["wmax_lim_pct"] == [3, 6]
    assert codes["status_high"] == [3, 16]
    got = _read(sim)
    assert {name: got[name] for name in WRITES} == {**WRITES, "mode": "auto"}
    assert _raw(sim, 100, 1) == [0x8331]
    assert got["w"] is None  # its factor was set to "not implemented"


def _write_with_driver(driver, flavour: str, proxy) -> dict[str, list[int]]:
    """Each value of WRITES written with the driver, then the refusals; the function codes of each write."""
    codes: dict[str, list[int]] = {}

    async def run(dev, call) -> None:
        for name, value in WRITES.items():
            before = len(proxy.codes)
            await call(getattr(dev, f"write_{name}"), value)
            codes[name] = proxy.codes[before:]
        before = len(proxy.codes)
        with pytest.raises(driver.ValueRangeError):
            await call(dev.write_fan_speed, 200.0)
        assert proxy.codes[before:] == []  # refused before anything is sent
        await call(dev.write_w_sf, -32768)
        before = len(proxy.codes)
        with pytest.raises(driver.ValueRangeError, match="scale factor has no value"):
            await call(dev.write_w, 5.0)
        assert proxy.codes[before:] == [3]  # the factor read, nothing written

    async def sync_call(method, value) -> None:
        method(value)

    async def async_call(method, value) -> None:
        await method(value)

    async def main() -> None:
        if flavour == "sync":
            client = ModbusTcpClient(proxy.host, port=proxy.port)
            assert client.connect()
            try:
                await run(driver.FlagsAndScale(client), sync_call)
            finally:
                client.close()
        else:
            client = AsyncModbusTcpClient(proxy.host, port=proxy.port)
            assert await client.connect()
            try:
                await run(driver.AsyncFlagsAndScale(client), async_call)
            finally:
                client.close()

    asyncio.run(main())
    return codes


# ---- exports: what each carries is tests/engines/test_bits_scale_exports.py (the C++ and C drivers:
# tests/compile/test_bits_scale_native.py)


def test_exports_leave_them_out_with_a_warning(tmp_path):
    for to in ("xif", "wise", "telegraf", "homeassistant"):
        proc = cli("export", DEVICE, "--to", to, "-o", tmp_path / f"out.{to}")
        assert proc.returncode == 0, proc.stderr
        assert "'mode' (bits 4-5)" in proc.stderr, (to, proc.stderr)  # no export carries a range of bits


@pytest.mark.commands  # serves or dials a device
def test_function_22_over_rtu_framing_checks_and_accepts_its_echo(sim_factory):
    """The runtime frames RTU replies itself (their size from the function code): function 22's echo is whole."""
    sim = sim_factory(DEVICE, "--framer", "rtu", "--set", "mode=heat")
    proc = cli("write", DEVICE, *sim.connection, "--framer", "rtu", "enabled=1", "alarm=1")
    assert proc.returncode == 0, proc.stderr
    proc = cli("read", DEVICE, *sim.connection, "--framer", "rtu", "--format", "json", "enabled", "alarm", "mode")
    assert json.loads(proc.stdout) == {"enabled": True, "alarm": True, "mode": "heat"}
