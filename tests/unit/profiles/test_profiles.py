"""Profiles (SPEC 13): the shipped ones load and list, a user's own YAML is checked with file, line and
column, and `mdl validate --profile` says which roles a device provides, how each converts, and fails
on a missing required role or one that cannot be bound."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from support.common import (
    ROOT,  # noqa: E402
    device_xml,
    fn_xml,
)
from support.run import assert_clean_error, cli

METER_A = ROOT / "examples" / "profiles" / "meter_a.xml"
METER_B = ROOT / "examples" / "profiles" / "meter_b.xml"

METER_ROLES = [
    "power_w",
    "energy_import_wh",
    "energy_export_wh",
    "power_l1_w",
    "power_l2_w",
    "power_l3_w",
    "voltage_l1_v",
    "voltage_l2_v",
    "voltage_l3_v",
    "current_l1_a",
    "current_l2_a",
    "current_l3_a",
    "frequency_hz",
    "power_factor",
    "reactive_power_var",
    "apparent_power_va",
]


def test_the_shipped_profiles_list_and_show():
    proc = cli("profiles")
    assert proc.returncode == 0, proc.stderr
    names = [line.split()[0] for line in proc.stdout.splitlines()]
    assert names == ["battery", "evcharger", "inverter", "meter", "thermostat"]
    assert json.loads(cli("profiles", "--format", "json").stdout) == names
    meter = json.loads(cli("profiles", "meter", "--format", "json").stdout)
    assert [r["role"] for r in meter["roles"]] == METER_ROLES  # exactly SPEC 13's list, in its order
    assert [r["role"] for r in meter["roles"] if r["required"]] == ["power_w", "energy_import_wh"]
    assert {r["role"]: r["unit"] for r in meter["roles"]}["energy_import_wh"] == "Wh"
    table = cli("profiles", "inverter").stdout
    assert "power_limit_pct" in table and "read_write" in table
    assert_clean_error(cli("profiles", "toaster"), 1, "no profile named 'toaster': mdl ships battery, evcharger")


def test_validate_says_which_roles_and_how_they_convert():
    proc = cli("validate", METER_A, METER_B, "--profile", "meter")
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert f"{METER_A}: profile meter: 4 of 16 roles (2 of 2 required)" in out
    assert "power_w             <- total_active_power (kW x 1000)" in out
    assert "power_w             <- p_export (W x -1)" in out  # its role is power_export_w: the sign turned
    assert "power_factor        <- cos_phi (% x 0.01)" in out
    assert "not provided: energy_export_wh, power_l1_w" in out


def _device(tmp_path, *functions: str) -> Path:
    path = tmp_path / "d.xml"
    path.write_text(device_xml("".join(functions)))
    return path


def test_a_missing_required_role_or_an_unbindable_one_fails(tmp_path):
    only_voltage = _device(tmp_path, fn_xml("u", 0, format="UINT16", units="V", role="voltage_l1_v"))
    proc = cli("validate", only_voltage, "--profile", "meter")
    assert_clean_error(proc, 1, "required role power_w is not provided", "required role energy_import_wh")
    wrong_unit = _device(
        tmp_path,
        fn_xml("p", 0, format="INT16", units="kvar", role="power_w"),
        fn_xml("e", 1, format="UINT16", units="kWh", role="energy_import_wh"),
        fn_xml("e2", 2, format="UINT16", units="kWh", role="energy_import_wh"),
        fn_xml("x", 3, format="UINT16", role="toaster_w"),
    )
    proc = cli("validate", wrong_unit, "--profile", "meter")
    assert proc.returncode == 1
    assert "p: as power_w: units 'kvar' cannot be converted to W" in proc.stderr
    assert "e2: plays energy_import_wh, which e plays already" in proc.stderr
    assert "note: x: role 'toaster_w' is not one of profile meter's: left out" in proc.stderr
    assert f"{wrong_unit}:" in proc.stderr.splitlines()[0]


def test_a_plain_number_may_say_its_unit_is_1(tmp_path):
    path = _device(
        tmp_path,
        fn_xml("p", 0, format="INT16", units="W", role="power_w"),
        fn_xml("e", 1, format="UINT16", units="kWh", role="energy_import_wh"),
        fn_xml("pf", 2, format="INT16", multiplier="0.001", units="1", role="power_factor"),
    )
    proc = cli("validate", path, "--profile", "meter")
    assert proc.returncode == 0, proc.stderr
    assert "power_factor        <- pf (1)" in proc.stdout


def test_a_role_without_units_is_a_guess_said(tmp_path):
    path = _device(
        tmp_path,
        fn_xml("p", 0, format="INT16", role="power_w"),
        fn_xml("e", 1, format="UINT16", units="kWh", role="energy_import_wh"),
    )
    proc = cli("validate", path, "--profile", "meter")
    assert proc.returncode == 0, proc.stderr
    assert "note: p: as power_w: no units given: taken as W" in proc.stderr


BAD_PROFILES = [
    ("name: meter\n", "1:1", "missing 'roles'"),
    ("name: Meter\nroles: {a: {unit: W}}\n", "1:7", "is not a name"),
    ("name: m\nroles:\n  a: {unit: furlongs}\n", "3:13", "unit 'furlongs' is not the base unit"),
    ("name: m\nroles:\n  a: {unit: kW}\n", "3:13", "unit 'kW' is not the base unit"),
    ("name: m\nroles:\n  a: {unit: W, colour: red}\n", "3:24", "unknown key 'colour' in role a"),
    ("name: m\nroles:\n  a: {type: int, unit: W}\n", "3:24", "an int role has no unit"),
    ("name: m\nroles:\n  a: {type: complex}\n", "3:13", "type must be one of float, int, bool"),
    ("name: m\nroles:\n  a: {unit: W, required: maybe}\n", "3:26", "required must be true or false"),
    ("name: m\nroles:\n  a: {unit: W, opposite: b}\n  b: {unit: W}\n", "3:6", "opposite 'b' is a role of the profile"),
    ("name: m\nroles: {}\n", "2:8", "at least one role"),
    ("- a\n", "1", "not a profile"),
    ("name: m\nroles: &x {a: {unit: W}}\nb: *x\n", "3:4", "aliases are not supported"),
    ("name: m\nroles:\n  a: {unit: W}\n  a: {unit: V}\n", "4:3", "key 'a' appears twice"),
    (
        "name: m\nroles:\n  a: {unit: W, opposite: x}\n  b: {unit: W, opposite: x}\n",
        "4:6",
        "opposite 'x' is role a's already",
    ),
]


@pytest.mark.parametrize(("text", "where", "message"), BAD_PROFILES)
def test_a_users_profile_is_checked_where_it_is_wrong(tmp_path, text, where, message):
    path = tmp_path / "mine.yaml"
    path.write_text(text)
    assert_clean_error(cli("profiles", path), 1, f"{path}:{where}", message)
    assert_clean_error(cli("validate", METER_A, "--profile", path), 1, f"{path}:{where}", message)


def test_a_users_profile_is_used(tmp_path):
    path = tmp_path / "grid.yaml"
    path.write_text("name: grid\ntitle: Grid point\nroles:\n  power_w: {unit: W, required: true}\n")
    proc = cli("validate", METER_A, "--profile", path)
    assert proc.returncode == 0, proc.stderr
    assert "profile grid: 1 of 1 roles (1 of 1 required)" in proc.stdout
    assert_clean_error(cli("profiles", tmp_path / "nope.yaml"), 1, "no such profile file")


@pytest.mark.parametrize(
    ("models", "profile", "fitted"),
    [
        (["203"], "meter", "16 of 16 roles"),
        (["103", "123"], "inverter", "9 of 9 roles"),
        (["701", "704"], "inverter", "8 of 9 roles"),  # the DER models: all but dc_power_w (model 714's)
        (["713"], "battery", ""),
    ],
)
def test_sunspec_imports_carry_their_roles(tmp_path, models, profile, fitted):
    """SunSpec fixes what its points mean: an imported meter, inverter or storage model plays the
    profile's roles, with its units converted (PF in Pct, % WMax) and a note listing them."""
    out = tmp_path / "chain.xml"
    proc = cli("import", "--from", "sunspec", *models, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "note: roles from the SunSpec points:" in proc.stderr
    check = cli("validate", out, "--profile", profile)
    if fitted:
        assert check.returncode == 0, check.stderr
        assert fitted in check.stdout
    else:  # model 713 gives soc_pct, not a battery's power: the profile's required power_w is missing
        assert_clean_error(check, 1, "required role power_w is not provided")
        assert "soc_pct" in check.stdout


def test_a_role_played_twice_in_a_chain_is_said(tmp_path):
    out = tmp_path / "two.xml"
    proc = cli("import", "--from", "sunspec", "203", "203", "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "left without a role: 203-2_W (power_w: 203_W plays it)" in proc.stderr


def test_csv2xml_gives_roles_to_functions_named_after_them(tmp_path):
    """A vendor table converted with an INI whose functions are named after the meter's roles gives a
    description that fits the meter profile; `role =` in [function NAME] wins."""
    table = tmp_path / "m.csv"
    table.write_text(
        "Address,Description,Type,Unit,Scale\n0,Total active power,int32,kW,0.001\n"
        "2,Import energy,uint32,kWh,0.01\n4,Voltage L1,uint16,V,0.1\n5,Grid frequency,uint16,Hz,0.01\n"
    )
    ini = tmp_path / "m.ini"
    ini.write_text(
        "[Column/Field Indices]\nmultiplier = Scale\n\n[Function Name Search Synonyms]\n"
        "power_w = Total active power\nenergy_import_wh = Import energy\nvoltage_l1_v = Voltage L1\n"
        "grid_frequency = Grid frequency\n\n[function grid_frequency]\nrole = frequency_hz\n"
    )
    out = tmp_path / "m.xml"
    proc = cli("csv2xml", table, "--ini", ini, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "functions named after a profile's role play it: power_w (battery/evcharger/inverter/meter)" in proc.stderr
    check = cli("validate", out, "--profile", "meter")
    assert check.returncode == 0, check.stderr
    assert "power_w             <- power_w (kW x 1000)" in check.stdout
    assert "frequency_hz        <- grid_frequency (Hz)" in check.stdout


def _telegraf_fields(path: Path, *args: str) -> dict[str, dict]:
    import tomllib

    proc = cli("export", path, "--to", "telegraf", "--host", "192.0.2.10", *args)
    assert proc.returncode == 0, proc.stderr
    config = tomllib.loads(proc.stdout)
    return {f["name"]: f for r in config["inputs"]["modbus"][0]["request"] for f in r["fields"]}


def test_export_names_points_after_roles_in_the_roles_units():
    """`--names roles --profile meter`: two vendors' meters give one engine the same point names, in W
    and Wh with the meter's sign (meter A's kW x 0.001 becomes W; meter B's export-positive power is
    negated, its power factor in % becomes a ratio)."""
    a = _telegraf_fields(METER_A, "--names", "roles", "--profile", "meter")
    b = _telegraf_fields(METER_B, "--names", "roles", "--profile", "meter")
    assert {"power_w", "energy_import_wh", "voltage_l1_v", "power_factor"} <= set(a) & set(b)
    assert "scale" not in a["power_w"] and a["energy_import_wh"]["scale"] == 10.0  # 0.01 kWh = 10 Wh
    assert b["power_w"]["scale"] == -1.0 and "scale" not in b["power_factor"]  # divided exactly, below
    text = cli("export", METER_B, "--to", "telegraf", "--host", "h", "--names", "roles", "--profile", "meter").stdout
    assert '"power_factor": 100,' in text  # Telegraf's starlark divisor: 95 % reads 0.95
    plain = _telegraf_fields(METER_B, "--names", "roles")  # without a profile: names only
    assert "power_export_w" in plain and "scale" not in plain["power_export_w"]
    assert set(_telegraf_fields(METER_A)) == {"total_active_power", "import_energy", "u1", "pf"}
    assert_clean_error(cli("export", METER_A, "--to", "telegraf", "--profile", "meter"), 2, "--names roles")


def test_export_names_roles_with_a_profile_refuses_what_cannot_be_converted(tmp_path):
    path = _device(
        tmp_path,
        fn_xml("p", 0, format="INT16", units="hp", role="power_w"),
        fn_xml("e", 1, format="UINT16", units="kWh", role="energy_import_wh"),
    )
    proc = cli("export", path, "--to", "telegraf", "--host", "h", "--names", "roles", "--profile", "meter")
    assert_clean_error(proc, 1, "p: as power_w: units 'hp' cannot be converted to W")
