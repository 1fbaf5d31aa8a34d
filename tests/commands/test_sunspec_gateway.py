"""SPEC 13's gateway (docs/sunspec.md, Gateway): `mdl sim DEVICE --as sunspec` and `mdl serve DEVICE --from
CONNECTION --as sunspec` serve any meter as SunSpec models 1 + 201/203, read by pysunspec2's own client.

Two vendors' meters (examples/profiles: A counts kW/kWh in integers, power positive importing; B floats in
W/Wh, power positive exporting) get raw registers packed here with struct for the same physical values;
pysunspec2 reads the same numbers from both. `mdl serve` in front of `mdl sim` serves "not implemented"
while the backend is down and the values again once it is back.
"""

from __future__ import annotations

import functools
import json
import math
import struct
import subprocess
import time

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from support.common import ROOT, fn_xml
from support.devices import Sim, read_lines
from support.run import assert_clean_error, mdl_cmd, run_mdl

sunspec_client = pytest.importorskip("sunspec2.modbus.client")

METERS = ROOT / "examples" / "profiles"
# the physical values both meters hold: W (importing), Wh imported, Wh exported, V, power factor
POWER, IMPORTED, EXPORTED, VOLTS, PF = 1500.0, 12345670.0, 5000.0, 230.1, 0.95


def _words(fmt: str, value: float) -> list[int]:
    data = struct.pack(fmt, value)
    return [int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2)]


def _image(table: str, start: int, words: list[int]) -> dict[str, dict[str, int]]:
    return {table: {str(start + i): w for i, w in enumerate(words)}}


def meter_a_raw() -> dict[str, dict[str, int]]:
    """Meter A: INT32 kW x 0.001, UINT32 kWh x 0.01, UINT16 V x 0.1, INT16 PF x 0.001 (holding 0-5)."""
    words = _words(">i", round(POWER)) + _words(">I", round(IMPORTED / 10)) + [round(VOLTS * 10)]
    return _image("holding", 0, words + _words(">h", round(PF * 1000)))


def meter_b_raw(power: float = -POWER) -> dict[str, dict[str, int]]:
    """Meter B: FLOAT32 W positive exporting, Wh, Wh, V, then INT16 PF in % (input 100-108)."""
    words = [w for v in (power, IMPORTED, EXPORTED, VOLTS) for w in _words(">f", v)]
    return _image("input", 100, words + _words(">h", round(PF * 100)))


def _write(path, image) -> str:
    path.write_text(json.dumps(image), encoding="ascii")
    return str(path)


def scan(port: int, unit: int = 1):
    device = sunspec_client.SunSpecModbusClientDeviceTCP(slave_id=unit, ipaddr="127.0.0.1", ipport=port, timeout=5)
    device.scan()
    return device


def points(port: int, model: int, names: tuple[str, ...]) -> dict[str, object]:
    device = scan(port)
    try:
        found = device.models[model][0]
        return {name: found.points[name].cvalue for name in names}
    finally:
        device.close()


def close(a: object, b: float) -> bool:
    return isinstance(a, (int, float)) and math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-9)


@pytest.mark.parametrize("meter", ["meter_a", "meter_b"])
def test_two_vendors_meters_read_alike_through_pysunspec2(meter, sim_factory, tmp_path):
    raw = _write(tmp_path / "raw.json", meter_a_raw() if meter == "meter_a" else meter_b_raw())
    sim = sim_factory(METERS / f"{meter}.xml", "--as", "sunspec", "--registers", raw)
    assert " as SunSpec 1 + 201 on " in sim.ready_line  # phase 1 only: the single-phase meter
    device = scan(sim.port)
    try:
        assert {1, 201} <= set(device.models)
        got = device.models["ac_meter_an_or_ab"][0].points
        assert close(got["W"].cvalue, POWER)  # meter B's export-positive power turned to import-positive
        assert close(got["TotWhImp"].cvalue, IMPORTED)
        assert close(got["PhVphA"].cvalue, VOLTS) and close(got["PhV"].cvalue, VOLTS)
        assert close(got["PF"].cvalue, PF * 100)  # SunSpec's PF is in percent
        assert got["Hz"].cvalue is None and got["A"].cvalue is None  # no role: not implemented
        assert got["TotWhExp"].cvalue == (EXPORTED if meter == "meter_b" else None)
        common = device.models[1][0].points
        assert common["SN"].cvalue == ("Meter A" if meter == "meter_a" else "Meter B")
        assert common["DA"].cvalue == 1
    finally:
        device.close()
    sim.stop()
    assert "served as profile meter" in sim.stderr and "Traceback" not in sim.stderr


def test_the_gateway_agrees_with_mdl_read(sim_factory, tmp_path):
    """pysunspec2's value equals `mdl read`'s after the unit conversion the profile says (kW -> W)."""
    raw = _write(tmp_path / "raw.json", meter_a_raw())
    plain = sim_factory(METERS / "meter_a.xml", "--registers", raw)
    read = run_mdl("read", METERS / "meter_a.xml", *plain.connection, "--format", "json")
    assert read.returncode == 0, read.stderr
    values = json.loads(read.stdout)
    facade = sim_factory(METERS / "meter_a.xml", "--as", "sunspec", "--registers", raw)
    got = points(facade.port, 201, ("W", "TotWhImp", "PhVphA"))
    assert close(got["W"], values["total_active_power"] * 1000)
    assert close(got["TotWhImp"], values["import_energy"] * 1000)
    assert close(got["PhVphA"], values["u1"])


def roles_xml(*rows: tuple[str, str, str, str, str]) -> str:
    """Functions (name, addresses, format, units, role) as <function> elements."""
    return "".join(fn_xml(name, addr, format=fmt, units=unit, role=role) for name, addr, fmt, unit, role in rows)


THREE_PHASE = roles_xml(
    ("p", "0 1", "INT32", "W", "power_w"),
    ("e_in", "2 3", "UINT32", "kWh", "energy_import_wh"),
    *((f"u{n}", str(3 + n), "UINT16", "V", f"voltage_l{n}_v") for n in (1, 2, 3)),
    *((f"i{n}", str(6 + n), "UINT16", "A", f"current_l{n}_a") for n in (1, 2, 3)),
    ("f", "10", "UINT16", "Hz", "frequency_hz"),
)


def _three_phase(tmp_path, functions: str = THREE_PHASE, identity: str = ""):
    path = tmp_path / "three.xml"
    path.write_text(
        '<?xml version="1.0" encoding="US-ASCII"?>\n'
        '<device xmlns="http://www.ornl.gov/ModbusXMLSchema" version="1.0">\n'
        f"  <name>Three</name>\n  <description>three phases</description>\n{identity}{functions}</device>\n",
        encoding="ascii",
    )
    return path


def test_a_three_phase_meter_is_model_203_with_totals(sim_factory, tmp_path):
    identity = "  <manufacturer>ACME Meters</manufacturer>\n  <product>PM-3000</product>\n"
    sets = ["p=-2500", "e_in=42", "u1=230", "u2=231", "u3=232", "i1=10", "i2=11", "i3=12", "f=50"]
    sim = sim_factory(
        _three_phase(tmp_path, identity=identity), "--as", "sunspec", *[a for s in sets for a in ("--set", s)]
    )
    assert " as SunSpec 1 + 203 on " in sim.ready_line
    device = scan(sim.port)
    try:
        got = device.models["ac_meter_abcn"][0].points
        assert close(got["W"].cvalue, -2500) and close(got["TotWhImp"].cvalue, 42000)
        assert close(got["A"].cvalue, 33) and close(got["PhV"].cvalue, 231) and close(got["Hz"].cvalue, 50)
        assert [got[f"PhVph{x}"].cvalue for x in "ABC"] == [230, 231, 232]
        common = device.models[1][0].points
        assert (common["Mn"].cvalue, common["Md"].cvalue) == ("ACME Meters", "PM-3000")
    finally:
        device.close()


INVERTER = roles_xml(
    ("pac", "0", "UINT16", "W", "power_w"),
    ("etotal", "1 2", "UINT32", "kWh", "energy_wh"),
    ("temp", "3", "INT16", "degC", "temperature_c"),
)
BATTERY = roles_xml(
    ("soc", "0", "UINT16", "%", "soc_pct"),
    ("charge", "1", "INT16", "W", "charge_power_w"),  # the opposite role: served negated
    ("volts", "2", "UINT16", "V", "voltage_v"),
)


@pytest.mark.parametrize(
    "functions, sets, model, expected",
    [
        (INVERTER, ["pac=4321", "etotal=1234", "temp=-5"], 103, {"W": 4321, "WH": 1234000, "TmpCab": -5}),
        (BATTERY, ["soc=87", "charge=2000", "volts=52"], 802, {"SoC": 87, "W": -2000, "V": 52, "SoH": None}),
    ],
    ids=["inverter", "battery"],
)
def test_an_inverter_and_a_battery_are_served_as_their_models(functions, sets, model, expected, sim_factory, tmp_path):
    setting = [a for s in sets for a in ("--set", s)]
    sim = sim_factory(_three_phase(tmp_path, functions), "--as", "sunspec", *setting)
    assert f" as SunSpec 1 + {model} on " in sim.ready_line
    got = points(sim.port, model, tuple(expected))
    for name, value in expected.items():
        assert got[name] == value if value is None else close(got[name], value), (name, got)


def test_a_value_too_large_for_its_point_is_not_implemented_and_said(sim_factory, tmp_path):
    raw = _write(tmp_path / "raw.json", meter_b_raw(power=-1e12))  # 1 TW: no scale factor holds it in an int16
    sim = sim_factory(METERS / "meter_b.xml", "--as", "sunspec", "--registers", raw)
    got = points(sim.port, 201, ("W", "TotWhImp"))
    assert got["W"] is None and close(got["TotWhImp"], IMPORTED)
    sim.stop()
    assert "201_W = 1e+12 does not fit" in sim.stderr


def test_the_chain_takes_no_writes(sim_factory):
    from pymodbus.client import ModbusTcpClient

    sim = sim_factory(METERS / "meter_a.xml", "--as", "sunspec")
    client = ModbusTcpClient("127.0.0.1", port=sim.port)
    try:
        assert client.connect()
        da = 40000 + 2 + 2 + 16 + 16 + 8 + 8 + 16  # SunS, ID and L, Mn Md Opt Vr SN: model 1's DA
        assert client.read_holding_registers(da, count=1, device_id=1).registers == [1]
        refused = client.write_register(da, 7, device_id=1)
        assert refused.isError() and refused.exception_code == 2
        assert client.read_holding_registers(da, count=1, device_id=1).registers == [1]
    finally:
        client.close()


class Serve(Sim):
    """A running `mdl serve` on a free port; `stop` (Sim's) ends it with SIGTERM and keeps its stderr."""

    def __init__(self, *args):  # pylint: disable=super-init-not-called  (Sim starts `mdl sim`)
        self.proc = subprocess.Popen(
            mdl_cmd("serve", *args, "--port", "0"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        lines = read_lines(self.proc.stdout, lambda got: len(got) >= 1, self.proc, 30)
        if not lines or not lines[0].startswith("mdl serve: serving"):
            self.proc.kill()
            raise RuntimeError(f"mdl serve did not start: {lines!r} {self.proc.communicate()!r}")
        self.ready_line = lines[0].rstrip("\n")
        self.port = int(self.ready_line.rsplit(" unit ", 1)[0].rsplit(":", 1)[1])


def _until(port: int, wanted, guard: float = 30.0) -> dict[str, object]:
    """The points W and TotWhImp once `wanted(them)` holds; the guard only ends a hang (no timing asserted)."""
    end = time.monotonic() + guard
    while True:
        got = points(port, 201, ("W", "TotWhImp"))
        if wanted(got) or time.monotonic() > end:
            return got
        time.sleep(0.2)


def test_serve_follows_the_device_down_and_up(sim_factory, tmp_path):
    raw = _write(tmp_path / "raw.json", meter_a_raw())
    backend = sim_factory(METERS / "meter_a.xml", "--registers", raw)
    gateway = Serve(
        METERS / "meter_a.xml",
        "--from",
        f"127.0.0.1:{backend.port}",
        "--as",
        "sunspec",
        "--interval",
        "0.2",
        "--timeout",
        "0.5",
        "--retries",
        "0",
    )
    try:
        assert " as SunSpec 1 + 201 on " in gateway.ready_line
        got = points(gateway.port, 201, ("W", "TotWhImp"))  # the first poll comes before serving
        assert close(got["W"], POWER) and close(got["TotWhImp"], IMPORTED)
        assert backend.stop() == 0
        got = _until(gateway.port, lambda g: g["W"] is None)
        assert got == {"W": None, "TotWhImp": None}  # never the last numbers without a sign
        again = Sim(METERS / "meter_a.xml", "--registers", raw, port=backend.port)
        try:
            got = _until(gateway.port, lambda g: g["W"] is not None)
            assert close(got["W"], POWER) and close(got["TotWhImp"], IMPORTED)
        finally:
            assert again.stop() == 0
    finally:
        status = gateway.stop()
    assert status == 0, gateway.stderr
    assert "does not answer" in gateway.stderr and "answers again" in gateway.stderr
    assert "Traceback" not in gateway.stderr


def test_serve_with_the_device_down_from_the_start_serves_not_implemented(tmp_path):
    gateway = Serve(
        METERS / "meter_b.xml", "--from", "127.0.0.1:1", "--as", "sunspec", "--timeout", "0.2", "--retries", "0"
    )
    try:
        assert points(gateway.port, 201, ("W", "TotWhImp", "PhVphA")) == {"W": None, "TotWhImp": None, "PhVphA": None}
    finally:
        status = gateway.stop()
    assert status == 0 and "does not answer" in gateway.stderr, gateway.stderr


@pytest.mark.parametrize(
    "args, fragments",
    [
        (["--profile", "evcharger"], ["profile evcharger has no SunSpec model", "meter"]),
        (["--profile", "thermostat"], ["profile thermostat has no SunSpec model"]),
        (["--profile", "nonesuch"], ["no profile named 'nonesuch'"]),
        (["--profile", "battery"], ["required role soc_pct is not provided"]),
    ],
)
def test_sim_as_sunspec_refuses_cleanly(args, fragments):
    assert_clean_error(run_mdl("sim", METERS / "meter_a.xml", "--as", "sunspec", "--port", "0", *args), 1, *fragments)


def test_a_device_that_fits_no_profile_with_a_model_is_refused(tmp_path):
    plain = _three_phase(tmp_path, fn_xml("x", "0", format="UINT16"))
    assert_clean_error(
        run_mdl("sim", plain, "--as", "sunspec", "--port", "0"),
        1,
        "fits no profile with a SunSpec model (battery, inverter, meter)",
        "meter lacks power_w, energy_import_wh",
    )


def test_a_missing_required_role_is_refused(tmp_path):
    text = (METERS / "meter_a.xml").read_text(encoding="ascii").replace("<role>energy_import_wh</role>", "")
    path = tmp_path / "no_energy.xml"
    path.write_text(text, encoding="ascii")
    assert_clean_error(
        run_mdl("sim", path, "--as", "sunspec", "--port", "0", "--profile", "meter"),
        1,
        "profile meter: required role energy_import_wh is not provided",
    )


@pytest.mark.parametrize(
    "args, status, fragment",
    [
        (["--profile", "meter"], 2, "--profile goes with --as sunspec"),
        (["--as", "sunspec", METERS / "meter_b.xml"], 2, "--as sunspec serves one FILE, not 2"),
    ],
)
def test_sim_usage_errors(args, status, fragment):
    assert_clean_error(run_mdl("sim", METERS / "meter_a.xml", "--port", "0", *args), status, fragment)


@pytest.mark.parametrize(
    "source, fragment",
    [
        ("ftp://h", "unknown scheme 'ftp://'"),
        ("tcp://h:99999", "not in the range 1 to 65535"),
        ("h:x", "is not a number"),
        ("rtu://", "rtu:// needs the serial device"),
        ("rtu:///dev/null?speed=9", "unknown setting 'speed'"),
        ("rtu:///dev/null?baud=fast", "baud=fast: not a number"),
        ("rtu:///dev/null?baud=-5", "baud=-5: not in the range 50 to 4e+06"),
        ("rtu:///dev/null?bytesize=3", "bytesize=3: not in the range 7 to 8"),
        ("rtu:///dev/null?stopbits=7", "stopbits=7: not in the range 1 to 2"),
        ("rtu:///dev/null?parity=Q", "parity=Q: write N, E or O"),
        ("tcp://h#300", "is not a number from 0 to 255"),
        ("/dev/ttyUSB0", "a serial device is rtu:///dev/"),
    ],
)
def test_serve_refuses_a_bad_from(source, fragment):
    assert_clean_error(run_mdl("serve", METERS / "meter_a.xml", "--from", source, "--as", "sunspec"), 1, fragment)


# --- properties: the --from parser, and what a point holds for any value -------------------------------


@settings(max_examples=150, deadline=None)
@given(st.text(max_size=40))
def test_any_from_text_is_a_connection_or_a_clean_error(text):
    from mdl.device.server.serve import parse_from
    from mdl.diagnostics import MdlError

    try:
        conn, unit = parse_from(text, 1.0, 0)
    except MdlError as exc:
        assert str(exc).startswith("error: --from")
    else:
        assert conn.serial is not None or 1 <= conn.port <= 65535
        assert unit is None or 0 <= unit <= 255


@functools.cache
def _facade():
    """One facade of meter B whose source is `CURRENT` (a test sets the values it wants served)."""
    from mdl.device.sunspec.gateway import FacadeRegisters, choose
    from mdl.formats.loading import load_resolved

    resolved = load_resolved(METERS / "meter_b.xml")
    fitted, _ = choose(resolved, None, METERS / "meter_b.xml")
    return FacadeRegisters(fitted, lambda: dict(CURRENT), resolved.device, 1, warn=_Null())


CURRENT: dict[str, float | None] = {}


class _Null:
    def write(self, text: str) -> int:
        return len(text)

    def flush(self) -> None:
        pass


NUMBERS = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**12), 10**12))


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(power=NUMBERS, volts=NUMBERS)
@example(power=None, volts=1.797693134862316e307)  # finite, but not once divided by 10^-1
def test_a_point_holds_the_value_to_its_scale_or_not_implemented(power, volts):
    """Whatever the device gives, a point decodes (value x 10^SF) to the value within half a step of its
    scale, or is "not implemented": never a wrong number."""
    CURRENT.clear()
    CURRENT.update({"power_w": power, "voltage_l1_v": volts, "energy_import_wh": 1.0})
    facade = _facade()
    facade.refresh()

    def read(point: str, sf: str, signed: bool) -> tuple[float, float] | None:
        raw = facade.get_each("holding", facade.layouts[f"201_{point}"].addresses)[0]
        exp = facade.get_each("holding", facade.layouts[f"201_{sf}"].addresses)[0]
        exp -= 0x10000 if exp >= 0x8000 else 0
        if raw == (0x8000 if signed else 0xFFFF):
            return None
        raw -= 0x10000 if signed and raw >= 0x8000 else 0
        return raw * 10.0**exp, 10.0**exp

    for point, sf, given_value, signed in (("W", "W_SF", power, True), ("PhVphA", "V_SF", volts, True)):
        got = read(point, sf, signed)
        if got is None:
            continue
        value, step = got
        assert given_value is not None and math.isfinite(given_value)
        assert abs(value - given_value) <= step / 2 + 1e-9 * abs(given_value), (point, given_value, value)


def test_serve_keeps_serving_when_the_device_refuses_one_register(sim_factory, write_device, tmp_path):
    """A backend that answers but refuses one bound register (exception 2 even alone): that role is
    'not implemented', the others are served, and it is said once, not as a device that does not answer."""
    meter = (METERS / "meter_a.xml").read_text()
    backend_xml = tmp_path / "backend.xml"  # the same meter without its import energy registers
    start = meter.index("  <function>\n    <name>import_energy</name>")
    end = meter.index("</function>", start) + len("</function>\n")
    backend_xml.write_text(meter[:start] + meter[end:])
    raw = _write(
        tmp_path / "raw.json", {"holding": {k: v for k, v in meter_a_raw()["holding"].items() if k not in ("2", "3")}}
    )
    backend = sim_factory(backend_xml, "--registers", raw)
    gateway = Serve(METERS / "meter_a.xml", "--from", f"127.0.0.1:{backend.port}", "--as", "sunspec")
    try:
        got = points(gateway.port, 201, ("W", "TotWhImp"))
        assert close(got["W"], POWER) and got["TotWhImp"] is None
    finally:
        status = gateway.stop()
    assert status == 0, gateway.stderr
    assert "the device refuses import_energy" in gateway.stderr and "does not answer" not in gateway.stderr


def test_an_outlier_never_coarsens_its_neighbours_and_zero_energy_is_a_note(sim_factory, tmp_path):
    """meter_b's power of 1 TW fits no W_SF: it is 'not implemented', and the phase powers sharing W_SF
    keep their own scale; an export energy of 0 Wh (SunSpec's accumulators count from 1) is a note."""
    phases = (
        fn_xml("p", "0 1", format="FLOAT32", units="W", role="power_w")
        + fn_xml("p1", "2 3", format="FLOAT32", units="W", role="power_l1_w")
        + fn_xml("e_in", "4 5", format="FLOAT32", units="Wh", role="energy_import_wh")
        + fn_xml("e_out", "6 7", format="FLOAT32", units="Wh", role="energy_export_wh")
        + fn_xml("u2", "8", format="UINT16", units="V", role="voltage_l2_v")
    )
    sets = ["p=1e12", "p1=1500", "e_in=42", "e_out=0", "u2=230"]
    sim = sim_factory(_three_phase(tmp_path, phases), "--as", "sunspec", *[a for s in sets for a in ("--set", s)])
    got = points(sim.port, 203, ("W", "WphA", "TotWhExp"))
    assert got["W"] is None and close(got["WphA"], 1500.0) and got["TotWhExp"] is None
    sim.stop()
    assert "203_TotWhExp = 0: 0 is the point's 'not implemented' value" in sim.stderr
    assert "warning: 203_TotWhExp" not in sim.stderr
