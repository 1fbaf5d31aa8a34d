"""`mdl export --to volttron`, proven by VOLTTRON's own driver: the published volttron-lib-modbustk-driver,
in a venv of its own (tests/support/engines.py), builds its register map from the exported files exactly as the
platform driver hands them over (the config store turns each CSV into a list of rows and resolves the
config:// references), reads `mdl sim` through its own modbus_tk client, and writes through it."""

from __future__ import annotations

import json

import pytest

from support.common import DATA, EXAMPLE, fn_xml
from support.engines import VOLTTRON, installed_version, require
from support.raw_images import ALL_TABLES_RAW as SHARED_ALL_TABLES_RAW
from support.raw_images import TEMCO_RAW
from support.refusing_proxy import refusing_proxy
from support.run import assert_clean_error, cli, run_mdl
from support.volttron import map_rows, run_volttron, through_volttron

ALL_TABLES = DATA / "all_tables.xml"
TEMCO = EXAMPLE / "temco_tstat.xml"


# raw registers with every byte in use (a value read from the wrong byte or word cannot pass): the other
# engines' image with coil 5 (alarm_reset) clear, another holding 300, and status_bit and flow (110, 111)
ALL_TABLES_RAW = {table: dict(values) for table, values in SHARED_ALL_TABLES_RAW.items()}
ALL_TABLES_RAW["coil"]["5"] = 0
ALL_TABLES_RAW["holding"].update({"300": 100, "110": 0x0008, "111": 123})


def export(path, out, *extra):
    proc = run_mdl("export", path, "--to", "volttron", "-o", out, *extra)
    assert proc.returncode == 0, proc.stderr
    return proc


def mdl_read(path, sim) -> dict:
    proc = run_mdl("read", path, *sim.connection, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def as_mdl_reads(name: str, value, expected, values: dict[int, str] | None):
    """VOLTTRON's value in mdl's terms, where the export warned that VOLTTRON says it otherwise."""
    if values and isinstance(expected, str):  # no enumeration in VOLTTRON: the key of the label
        return values.get(value, value)
    if isinstance(expected, str) and isinstance(value, str):  # NUL padding kept (warned)
        return value.rstrip("\x00 ")
    return value


def assert_same_values(got: dict, expected: dict, resolved_values: dict[str, dict[int, str] | None]):
    assert got, "VOLTTRON read nothing"
    for point, value in got.items():
        assert point in expected, (point, sorted(expected))
        mine = as_mdl_reads(point, value, expected[point], resolved_values.get(point))
        assert mine == expected[point] and type(mine) in (type(expected[point]), int), (point, value, expected[point])


def enum_values(path) -> dict[str, dict[int, str] | None]:
    from mdl.formats.loading import load_resolved

    return {f.name: f.fn.values for f in load_resolved(path).functions}


@pytest.mark.parametrize(
    ("path", "raw", "exported"),
    [
        (ALL_TABLES, ALL_TABLES_RAW, 17),
        (TEMCO, TEMCO_RAW, 14),
    ],
)
def test_volttron_reads_what_mdl_reads(sim_factory, tmp_path, path, raw, exported):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", registers)
    out = tmp_path / "volttron"
    export(path, out, *sim.connection)
    stem = path.stem
    got = through_volttron(out, stem)["before"]
    expected = mdl_read(path, sim)
    assert len(got) == exported, sorted(got)
    readable = {name: value for name, value in got.items() if name in expected}
    assert len(readable) >= exported - 1  # a write-only coil is polled by VOLTTRON but not by mdl read
    assert_same_values(readable, expected, enum_values(path))


def test_writes_through_volttron_land_in_the_simulator(sim_factory, tmp_path):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(ALL_TABLES_RAW))
    sim = sim_factory(ALL_TABLES, "--registers", registers)
    out = tmp_path / "volttron"
    export(ALL_TABLES, out, *sim.connection)
    writes = {
        "pump": False,
        "fan": True,
        "setpoint": 22,
        "serial": 0x0A0B0C0D,
        "low_byte": -5,
        "high_byte": 200,
        "big": -2,
        "gap_low": 4321,
        "label": "XYZ",
    }
    result = through_volttron(out, "all_tables", writes)
    expected = mdl_read(ALL_TABLES, sim)
    for point, value in writes.items():
        assert expected[point] == value, (point, expected[point], value)
    with pytest.raises(AssertionError, match="required argument is not an integer"):
        through_volttron(out, "all_tables", {"setpoint": 21.5})  # as the export warns: integers only
    assert_same_values({k: v for k, v in result["after"].items() if k in expected}, expected, enum_values(ALL_TABLES))


def test_volttron_files_and_warnings(tmp_path):
    out = tmp_path / "v"
    proc = export(ALL_TABLES, out, "--host", "192.0.2.10", "--unit", "7", "--interval", "30")
    assert sorted(p.name for p in out.iterdir()) == ["all_tables.config", "all_tables.csv", "all_tables_map.csv"]
    config = json.loads((out / "all_tables.config").read_text())
    assert config["driver_type"] == "modbus_tk" and config["interval"] == 30
    assert config["driver_config"]["device_address"] == "192.0.2.10" and config["driver_config"]["slave_id"] == 7
    assert config["driver_config"]["addressing"] == "offset"
    rows = map_rows(out, "all_tables")
    assert rows["energy"]["Mixed Endian"] == "TRUE" and rows["energy"]["Transform"] == "scale(0.001)"
    assert rows["serial"]["Type"] == "<I" and rows["serial"]["Mixed Endian"] == "TRUE"  # BADC
    assert rows["low_byte"]["Type"] == ">xb" and rows["high_byte"]["Type"] == ">Bx"
    assert rows["door_open"]["Writable"] == "FALSE" and rows["door_open"]["Table"] == "discrete_input_contacts"
    for name, fragment in [
        ("status_bit", "read fragment"),
        ("flow", "read fragment"),
        ("temp_offset", "offset"),
        ("voltage", "not implemented"),
        ("mode", "enumeration"),
        ("setpoint", "minimum/maximum"),
        ("alarm_reset", "write-only"),
        ("label", "NUL"),
        ("setpoint", "integers only"),
    ]:
        assert any(
            f"'{name}'" in line.split(": VOLTTRON: ")[0] and fragment in line for line in proc.stderr.splitlines()
        ), (name, proc.stderr)
    assert "status_bit" not in rows and "temp_offset" not in rows


def test_volttron_serial_connection_and_default_note(tmp_path):
    out = tmp_path / "serial"
    export(ALL_TABLES, out, "--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E")
    driver = json.loads((out / "all_tables.config").read_text())["driver_config"]
    assert driver["device_address"] == "/dev/ttyUSB0" and "port" not in driver
    assert (driver["baudrate"], driver["parity"], driver["bytesize"], driver["stopbits"]) == (9600, "even", 8, 1)
    proc = export(ALL_TABLES, tmp_path / "none")
    assert "note: VOLTTRON: no connection given" in proc.stderr


def test_volttron_refuses_what_it_cannot_hold(tmp_path, write_device):
    only_expressions = write_device(
        fn_xml("f", "0", format="UINT16", read_function_code="arg = r1 + 1;", access="read")
    )
    proc = run_mdl("export", only_expressions, "--to", "volttron", "-o", tmp_path / "x")
    assert_clean_error(proc, 1, "VOLTTRON can hold none of this description's functions", "read fragment")
    assert not (tmp_path / "x").exists()
    proc = run_mdl(
        "export", ALL_TABLES, "--to", "volttron", "-o", tmp_path / "y", "--host", "h", "--port", "1", "--framer", "rtu"
    )
    assert_clean_error(proc, 1, "not RTU framing over TCP")


def test_volttron_needs_a_folder_and_an_empty_one(tmp_path):
    assert_clean_error(cli("export", ALL_TABLES, "--to", "volttron"), 2, "-o DIR")
    out = tmp_path / "full"
    out.mkdir()
    (out / "other.txt").write_text("x")
    assert_clean_error(cli("export", ALL_TABLES, "--to", "volttron", "-o", out), 1, "not empty")
    assert cli("export", ALL_TABLES, "--to", "volttron", "-o", out, "--force").returncode == 0
    assert (out / "all_tables_map.csv").is_file() and (out / "other.txt").is_file()


def test_volttron_version_is_the_pinned_one():
    python = require(VOLTTRON)
    assert installed_version(python, "volttron-lib-modbustk-driver") == "0.1.2rc0"
    assert installed_version(python, "modbus-tk") == "1.1.5"


def test_volttron_export_is_deterministic(tmp_path):
    for name in ("a", "b"):
        export(TEMCO, tmp_path / name, "--host", "192.0.2.10")
    for file in (tmp_path / "a").iterdir():
        assert file.read_bytes() == (tmp_path / "b" / file.name).read_bytes()


BITREG = (
    fn_xml("flag", "10", format="BIT")
    + fn_xml("ro_flag", "11", format="BIT", register_type="input")
    + fn_xml("lo", "12", length="Lower byte", format="UINT8", byte_order="little")
)


def test_a_bit_in_a_register_is_left_out(sim_factory, tmp_path, write_device):
    """mdl reads a BIT in a holding/input register as true when the register is not 0. The driver's bool
    type there unpacks one byte of the two and fails the whole poll (the control below), and nothing else
    tests a register for 0: the export leaves it out, says so, and the rest reads as mdl reads it."""
    path = write_device(BITREG)
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"holding": {"10": 2, "12": 0x1234}, "input": {"11": 1}}))
    sim = sim_factory(path, "--registers", registers)
    out = tmp_path / "v"
    proc = export(path, out, *sim.connection)
    for name, table in (("flag", "holding"), ("ro_flag", "input")):
        assert f"function '{name}': VOLTTRON: a BIT in the {table} registers" in proc.stderr, proc.stderr
    rows = map_rows(out, "test_device")
    assert sorted(rows) == ["lo"]
    got = through_volttron(out, "test_device")["before"]
    assert got == {"lo": 0x34} and mdl_read(path, sim)["lo"] == 0x34
    # the control: the driver's own bool in a holding register
    with open(out / "test_device_map.csv", "a", encoding="utf-8") as handle:
        handle.write("flag,10,bool,,FALSE,,,analog_output_holding_registers,FALSE,flag\n")
    with open(out / "test_device.csv", "a", encoding="utf-8") as handle:
        handle.write("flag,flag\n")
    failed = run_volttron(out, "test_device")
    assert failed.returncode != 0 and "unpack requires a buffer of 1 bytes" in failed.stderr, failed.stderr[-2000:]


def test_writes_use_the_function_codes_the_driver_has(sim_factory, tmp_path, write_device):
    """The driver writes one coil with function 5 (write_multiple cannot change it: warned), and every register
    with 16 when write_multiple_registers is true, else with 6. The export sets it false where every writable
    register is one int16/uint16 that mdl writes with 6; a proxy records what the driver sends."""
    single = write_device(
        fn_xml("sp", "7", format="UINT16")
        + fn_xml("neg", "8", format="INT16")
        + fn_xml("relay", "3", format="BIT", register_type="coil"),
        filename="single.xml",
    )
    multiple = write_device(
        fn_xml("sp", "7", format="UINT16", write_multiple="true")
        + fn_xml("neg", "8", format="INT16")
        + fn_xml("relay", "3", format="BIT", register_type="coil", write_multiple="true"),
        filename="multiple.xml",
    )
    writes = {"sp": 1234, "neg": -5, "relay": True}
    for path, flag, codes in (
        (single, False, {"sp": 6, "neg": 6, "relay": 5}),
        (multiple, True, {"sp": 16, "neg": 16, "relay": 5}),
    ):
        sim = sim_factory(path)
        with refusing_proxy(sim.host, sim.port) as proxy:
            out = tmp_path / path.stem
            proc = export(path, out, "--host", proxy.host, "--port", str(proxy.port))
            config = json.loads((out / "test_device.config").read_text())
            assert config["driver_config"]["write_multiple_registers"] is flag
            for point, value in writes.items():
                before = len(proxy.codes)
                through_volttron(out, "test_device", {point: value})
                assert codes[point] in proxy.codes[before:], (point, proxy.codes[before:])
                assert not {5, 6, 15, 16} - {codes[point]} & set(proxy.codes[before:]), (point, proxy.codes[before:])
        assert mdl_read(path, sim) == writes
        if flag:
            assert "'relay': VOLTTRON: write_multiple: the driver writes one coil with function 5" in proc.stderr
            assert "write_multiple_registers is one setting for the device: true, as 'sp' needs" in proc.stderr
            assert "with function 6: neg" in proc.stderr
        else:
            assert "function 5" not in proc.stderr and "write_multiple_registers" not in proc.stderr, proc.stderr


def test_byte_orders_all_four(sim_factory, tmp_path, write_device):
    """Every byte/word order of 32- and 64-bit integers and floats reads right through VOLTTRON."""
    functions = ""
    raw: dict[str, int] = {}
    address = 0
    for fmt, words in (("INT32", 2), ("UINT32", 2), ("FLOAT32", 2), ("INT64", 4), ("FLOAT64", 4), ("INT16", 1)):
        for byte_order in ("big", "little"):
            for word_order in ("big", "little"):
                functions += fn_xml(
                    f"{fmt}_{byte_order}_{word_order}".lower(),
                    address,
                    format=fmt,
                    byte_order=byte_order,
                    word_order=word_order,
                )
                for i in range(words):
                    raw[str(address + i)] = (0x4111 + 0x1357 * (address + i)) & 0xFFFF
                address += words
    path = write_device(functions)
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"holding": raw}))
    sim = sim_factory(path, "--registers", registers)
    out = tmp_path / "v"
    export(path, out, *sim.connection)
    got = through_volttron(out, "test_device")["before"]
    expected = mdl_read(path, sim)
    assert len(got) == len(expected) == 24
    assert_same_values(got, expected, {})
