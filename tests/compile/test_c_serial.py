"""The generated C driver over a `modbus_new_rtu` context on real RTU framing: the C harness on one end of a
socat pseudo terminal pair, `mdl sim --serial` on the other, and `mdl read` on the same line to agree with
exactly (SPEC section 9). Without socat or libmodbus the tests are skipped, under CI=true they fail."""

from __future__ import annotations

import pytest
from test_c_driver import assert_exactly
from test_cpp_driver import ALL_SETTINGS
from test_cpp_serial import RUN, TIMEOUT_MS, mdl_read

from mdl.formats.mdl import load_device
from support.c_harness import build
from support.common import DATA, EXAMPLE
from support.cpp_harness import MODBUS_ENOBASE, Harness, rtu

ALL = DATA / "all_tables.xml"
TSTAT = EXAMPLE / "temco_tstat.xml"


@pytest.fixture(scope="module")
def all_tables_c(tmp_path_factory):
    return build(load_device(ALL), tmp_path_factory.mktemp("c_all"), ALL.name)


@pytest.fixture(scope="module")
def tstat_c(tmp_path_factory):
    return build(load_device(TSTAT), tmp_path_factory.mktemp("c_tstat"), TSTAT.name)


def read_all(exe, path, client_end: str, unit: int = 1) -> dict:
    """read_all by the C harness, enumerations as `mdl read` prints them; the line is closed on return."""
    with Harness(exe, rtu(client_end), TIMEOUT_MS, unit=unit, ask_timeout=RUN) as h:
        values = h.values()
    assert "error" not in values, values
    for fn in load_device(path).functions:
        if fn.values and fn.name in values:
            values[fn.name] = fn.values.get(values[fn.name], values[fn.name])
    return values


def test_read_all_and_writes_agree_with_mdl_read_on_the_line(all_tables_c, serial_line, sim_factory):
    device, client_end = serial_line.ends
    sim_factory(ALL, *ALL_SETTINGS, serial=device)
    c = read_all(all_tables_c, ALL, client_end)
    assert c["setpoint"] == 21.5 and c["mode"] == "Cool" and c["label"] == "Hall" and c["pump"] is True
    assert_exactly(c, mdl_read(ALL, client_end))
    with Harness(all_tables_c, rtu(client_end), TIMEOUT_MS, ask_timeout=RUN) as h:
        for write in ("setpoint 19.5", f"label {b'Den'.hex()}", "fan 1", "big 7", "low_byte -7", "serial 4000000000"):
            assert h.ask(f"write {write}") == ["ok"], write
    assert mdl_read(ALL, client_end, "setpoint", "label", "fan", "big", "low_byte", "serial") == {
        "setpoint": 19.5,
        "label": "Den",
        "fan": True,
        "big": 7,
        "low_byte": -7,
        "serial": 4000000000,
    }
    assert_exactly(read_all(all_tables_c, ALL, client_end), mdl_read(ALL, client_end))


def test_two_devices_on_one_line_at_their_unit_ids(all_tables_c, tstat_c, serial_line, sim_factory):
    device, client_end = serial_line.ends
    sim_factory([ALL, TSTAT], "--set", "setpoint=19.5", "--set", "room_temperature=21.5", serial=device)
    assert_exactly(read_all(all_tables_c, ALL, client_end, unit=1), mdl_read(ALL, client_end, "--unit", "1"))
    assert_exactly(read_all(tstat_c, TSTAT, client_end, unit=2), mdl_read(TSTAT, client_end, "--unit", "2"))


def test_a_unit_that_does_not_answer_times_out(tstat_c, serial_line, sim_factory):
    device, client_end = serial_line.ends
    sim_factory(TSTAT, serial=device)
    with Harness(tstat_c, rtu(client_end), TIMEOUT_MS, unit=5, ask_timeout=RUN) as h:
        for ask in ("read occupied_setpoint", "all", "write fan_speed 2"):
            answer = h.values(ask)
            assert answer.get("error") in (110, MODBUS_ENOBASE + 12), (ask, answer)  # ETIMEDOUT (or EMBBADCRC)
