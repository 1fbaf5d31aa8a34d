"""`mdl export --to telegraf`, proven by reading `mdl sim` the way the exported TOML says Telegraf reads it.

Telegraf itself cannot be installed here (no Go toolchain, no binary downloads), so the test parses the TOML
with tomllib and follows each `[[inputs.modbus.request]]` section's documented meaning (the plugin's README
and its type_conversions*.go): one Modbus request per section (the fields, omit fillers included, leave no
gap, so Telegraf does not split it), each field decoded by its type and the section's byte_order, `scale`
multiplied, then the processors in their `order`: `[[processors.starlark]]` (the divisions), `[[processors.scale]]`
(factor * value + offset) and `[[processors.enum]]` (labels; 0/other for a bit in a register). Every value must
be `mdl read`'s exactly (a float bit for bit), a text without the trailing spaces Telegraf keeps (warned)."""

from __future__ import annotations

import json

import pytest
import tomllib
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.formats.loading import load_resolved
from support.common import DATA, EXAMPLE, fn_xml
from support.raw_images import ALL_TABLES_RAW, TEMCO_RAW
from support.run import assert_clean_error, run_mdl
from support.telegraf import check_config, telegraf_gather

ALL_TABLES = DATA / "all_tables.xml"
TEMCO = EXAMPLE / "temco_tstat.xml"


def export(path, *extra):
    proc = run_mdl("export", path, "--to", "telegraf", *extra)
    assert proc.returncode == 0, proc.stderr
    return proc


# --- the sections' documented meaning -------------------------------------------------------------------


def same(got, expected) -> bool:
    if isinstance(expected, float) and isinstance(got, float):
        return got == expected  # exactly: divisions are divisions (processors.starlark), not products by 0.1
    if isinstance(expected, str) and isinstance(got, str):
        return got.rstrip(" ") == expected
    return got == expected and type(got) is type(expected)


def assert_reads_like_mdl(path, sim, config, expect_fields: int):
    proc = run_mdl("read", path, *sim.connection, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    expected = json.loads(proc.stdout)
    names = {f.ident: f.name for f in load_resolved(path).functions}
    values, sent = telegraf_gather(config, sim.host, sim.port)
    assert len(values) == expect_fields, sorted(values)
    for ident, value in values.items():
        assert same(value, expected[names[ident]]), (ident, value, expected[names[ident]])
    return sent


@pytest.mark.commands  # serves or dials a device
@pytest.mark.parametrize(("path", "raw", "fields"), [(ALL_TABLES, ALL_TABLES_RAW, 17), (TEMCO, TEMCO_RAW, 14)])
def test_telegraf_sections_read_what_mdl_reads(sim_factory, tmp_path, path, raw, fields):
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", registers)
    config = tomllib.loads(export(path, *sim.connection).stdout)
    check_config(config)
    sent = assert_reads_like_mdl(path, sim, config, fields)
    plan = [(g.request.table, g.request.start, g.request.end) for g in load_resolved(path).plan]
    for table, start, count in sent:  # each request inside one request of mdl's plan
        assert any(t == table and s <= start and start + count <= e for t, s, e in plan), (table, start, count)


def test_one_section_per_plan_request(tmp_path):
    """Where one byte order reads a request's functions, each plan request is one section, with omit
    fillers for the registers no exported function reads (here: a fragment's)."""
    config = tomllib.loads(export(TEMCO, "--host", "h").stdout)
    sections = config["inputs"]["modbus"][0]["request"]
    resolved = load_resolved(TEMCO)
    readable = [
        g
        for g in resolved.plan
        if any(n not in ("serial_number", "firmware_version", "occupancy") for n in g.request.functions)
    ]
    assert len(sections) == len(readable)


@pytest.mark.commands  # serves or dials a device
def test_omit_fillers_keep_a_request_whole(sim_factory, tmp_path, write_device):
    path = write_device(
        fn_xml("a", "0", format="UINT16")
        + fn_xml("frag", "1", format="UINT16", read_function_code="arg = r1 * 2;", access="read")
        + fn_xml("b", "2", format="INT32", word_order="little")
    )
    config = tomllib.loads(export(path, "--host", "h").stdout)
    (section,) = config["inputs"]["modbus"][0]["request"]
    assert section["byte_order"] == "CDAB"
    assert {"address": 1, "type": "UINT16", "omit": True} in section["fields"]
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"holding": {"0": 7, "1": 9, "2": 0xFFFF, "3": 0xFFFE}}))
    sim = sim_factory(path, "--registers", registers)
    sent = assert_reads_like_mdl(path, sim, config, 2)
    assert sent == [("holding", 0, 4)]


def test_a_request_of_mixed_byte_orders_becomes_sections(write_device):
    path = write_device(
        fn_xml("a", "0", format="INT32")
        + fn_xml("b", "2", format="INT32", byte_order="little")
        + fn_xml("c", "4", format="UINT16")
    )
    sections = tomllib.loads(export(path, "--host", "h").stdout)["inputs"]["modbus"][0]["request"]
    assert [(s["byte_order"], [f["name"] for f in s["fields"]]) for s in sections] == [
        ("ABCD", ["a"]),
        ("BADC", ["b"]),
        ("ABCD", ["c"]),
    ]


_FORMATS = [
    ("INT16", 1),
    ("UINT16", 1),
    ("INT32", 2),
    ("UINT32", 2),
    ("FLOAT32", 2),
    ("INT64", 4),
    ("UINT64", 4),
    ("FLOAT64", 4),
]


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.lists(
        st.tuples(
            st.sampled_from(_FORMATS),
            st.sampled_from(["big", "little"]),
            st.sampled_from(["big", "little"]),
            st.sampled_from([None, 0.1, 0.5, 3.0]),
            st.sampled_from(["Full word", "Lower byte", "Upper byte"]),
        ),
        min_size=1,
        max_size=6,
    ),
    st.randoms(use_true_random=False),
)
def test_random_layouts_read_alike(sim_factory, tmp_path_factory, functions, rng):
    """Random formats, orders and scalings in one device: Telegraf's reading is mdl's."""
    tmp = tmp_path_factory.mktemp("t")
    xml, raw, address = "", {}, 0
    for i, ((fmt, words), byte_order, word_order, multiplier, length) in enumerate(functions):
        fields = {"format": fmt, "byte_order": byte_order, "word_order": word_order}
        if length != "Full word" and words == 1:
            fields = {"format": "INT8" if fmt == "INT16" else "UINT8", "length": length}
        if multiplier is not None and not fmt.startswith("FLOAT"):
            fields["multiplier"] = multiplier
        xml += fn_xml(f"f{i}", address, **fields)
        for k in range(words):
            raw[str(address + k)] = rng.randrange(0x10000) if not fmt.startswith("FLOAT") else 0x3F80 + k
        address += words
    path = tmp / "d.xml"
    from support.common import device_xml

    path.write_text(device_xml(xml), encoding="ascii")
    (tmp / "raw.json").write_text(json.dumps({"holding": raw}))
    sim = sim_factory(path, "--registers", tmp / "raw.json")
    try:
        config = tomllib.loads(export(path, *sim.connection).stdout)
        check_config(config)
        assert_reads_like_mdl(path, sim, config, len(functions))
    finally:
        sim.stop()


BITREG = (
    fn_xml("flag", "10", format="BIT")
    + fn_xml("ro_flag", "11", format="BIT", register_type="input")
    + fn_xml("lo", "12", length="Lower byte", format="UINT8", byte_order="little")
)


@pytest.mark.commands  # serves or dials a device
def test_a_bit_in_a_register_reads_true_for_any_nonzero_value(sim_factory, tmp_path, write_device):
    """mdl reads a BIT in a holding/input register as true when the register is not 0; Telegraf's BIT type
    reads bit 0 (2 -> 0), so the export reads the register as UINT16 and processors.enum maps 0 to false
    and every other value to true."""
    path = write_device(BITREG)
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"holding": {"10": 2, "12": 0x1234}, "input": {"11": 0x8000}}))
    sim = sim_factory(path, "--registers", registers)
    proc = export(path, *sim.connection)
    config = tomllib.loads(proc.stdout)
    check_config(config)
    fields = {f["name"]: f for r in config["inputs"]["modbus"][0]["request"] for f in r["fields"]}
    assert fields["flag"]["type"] == fields["ro_flag"]["type"] == "UINT16"
    values, _ = telegraf_gather({**config, "processors": {}}, sim.host, sim.port)
    assert (values["flag"], values["ro_flag"]) == (2, 0x8000)  # bit 0 of both is 0: a BIT field would say false
    assert_reads_like_mdl(path, sim, config, 3)
    got, _ = telegraf_gather(config, sim.host, sim.port)
    assert got["flag"] is True and got["ro_flag"] is True
    zero = tmp_path / "zero.json"
    zero.write_text(json.dumps({"holding": {"10": 0}, "input": {"11": 0}}))
    sim0 = sim_factory(path, "--registers", zero)
    got0, _ = telegraf_gather(tomllib.loads(export(path, *sim0.connection).stdout), sim0.host, sim0.port)
    assert got0["flag"] is False and got0["ro_flag"] is False


@pytest.mark.commands  # serves or dials a device
def test_divisions_are_divisions(sim_factory, tmp_path, write_device):
    """A multiplier 1/d is a division in mdl (87 at 0.1 reads 8.7); Telegraf's field scale would multiply
    (87 * 0.1 = 8.700000000000001): the export divides in processors.starlark, bit for bit as mdl."""
    assert 87 * 0.1 != 8.7 == 87 / 10
    path = write_device(
        fn_xml("t", "0", format="INT16", multiplier="0.1")
        + fn_xml("u", "1", format="UINT16", multiplier="0.001", offset="-40")
        + fn_xml("v", "2", format="UINT16", multiplier="0.3")
    )
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps({"holding": {"0": 87, "1": 12345, "2": 7}}))
    sim = sim_factory(path, "--registers", registers)
    config = tomllib.loads(export(path, *sim.connection).stdout)
    fields = {f["name"]: f for r in config["inputs"]["modbus"][0]["request"] for f in r["fields"]}
    assert "scale" not in fields["t"] and "scale" not in fields["u"] and fields["v"]["scale"] == 0.3
    (starlark,) = config["processors"]["starlark"]
    assert starlark["namepass"] == ["test_device"] and starlark["order"] == 1
    assert config["processors"]["scale"][0]["order"] == 2  # the offset after the division, as mdl
    assert_reads_like_mdl(path, sim, config, 3)
    values, _ = telegraf_gather(config, sim.host, sim.port)
    assert values["t"] == 8.7 and values["u"] == 12345 / 1000 - 40.0 and values["v"] == 7 * 0.3


def test_telegraf_connection_forms():
    serial = tomllib.loads(
        export(
            ALL_TABLES,
            "--serial",
            "/dev/ttyUSB0",
            "--baud",
            "9600",
            "--parity",
            "E",
            "--unit",
            "5",
            "--interval",
            "2.5",
        ).stdout
    )["inputs"]["modbus"][0]
    assert serial["controller"] == "file:///dev/ttyUSB0" and serial["transmission_mode"] == "RTU"
    assert (serial["baud_rate"], serial["parity"], serial["data_bits"], serial["stop_bits"]) == (9600, "E", 8, 1)
    assert serial["slave_id"] == 5 and serial["interval"] == "2.5s"
    assert all(r["slave_id"] == 5 for r in serial["request"])
    rtu = tomllib.loads(export(ALL_TABLES, "--host", "::1", "--port", "1502", "--framer", "rtu").stdout)
    plugin = rtu["inputs"]["modbus"][0]
    assert plugin["controller"] == "tcp://[::1]:1502" and plugin["transmission_mode"] == "RTUoverTCP"


def test_telegraf_warnings_and_refusal(write_device):
    proc = export(ALL_TABLES)
    for name, fragment in [
        ("status_bit", "read fragment"),
        ("flow", "read fragment"),
        ("alarm_reset", "only reads"),
        ("voltage", "not implemented"),
        ("label", "trailing spaces"),
    ]:
        assert any(
            f"'{name}'" in line.split(": Telegraf: ")[0] and fragment in line for line in proc.stderr.splitlines()
        ), (name, proc.stderr)
    assert "note: Telegraf: no connection given" in proc.stderr
    only_expressions = write_device(
        fn_xml("f", "0", format="UINT16", read_function_code="arg = r1 + 1;", access="read")
        + fn_xml("g", "1", format="UINT16", access="write")
    )
    proc = run_mdl("export", only_expressions, "--to", "telegraf")
    assert_clean_error(proc, 1, "Telegraf can hold none of this description's functions", "read fragment", "only reads")
    assert proc.stdout == ""


@pytest.mark.parametrize("engine", ["telegraf", "homeassistant", "volttron"])
def test_a_description_of_expressions_only_is_refused(tmp_path, engine):
    """The Toolkit heat pump computes every field with an expression: no engine can hold any of it."""
    proc = run_mdl(
        "export", EXAMPLE.parent / "toolkit_heat_pump" / "heat_pump.yaml", "--to", engine, "-o", tmp_path / "out"
    )
    assert_clean_error(proc, 1, "can hold none of this description's functions", "expression")
    assert not (tmp_path / "out").exists()


def test_telegraf_export_is_deterministic():
    assert export(TEMCO, "--host", "h").stdout == export(TEMCO, "--host", "h").stdout


_FUNCTION = st.fixed_dictionaries(
    {
        "format": st.sampled_from(
            [
                "INT8",
                "UINT8",
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
            ]
        ),
        "register_type": st.sampled_from(["holding", "input", "coil", "discrete"]),
    },
    optional={
        "length": st.sampled_from(["Lower byte", "Upper byte", "Full word"]),
        "count": st.integers(1, 5),
        "multiplier": st.sampled_from([0.1, 0.001, 2.0, -1.0, 1e-07, 0.3]),
        "offset": st.sampled_from([-40.0, 0.5, 0.0]),
        "byte_order": st.sampled_from(["big", "little"]),
        "word_order": st.sampled_from(["big", "little"]),
        "access": st.sampled_from(["read", "write", "read_write"]),
        "not_implemented": st.sampled_from(["0x8000", "0xFFFF 0x0000", "0x0000"]),
        "values": st.just({0: "Off", 1: "On"}),
        "read_function_code": st.just("arg = r1 * 2;"),
        "write_multiple": st.just("true"),
    },
)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(_FUNCTION, st.integers(0, 20)), min_size=1, max_size=5))
def test_random_descriptions_export_or_refuse_cleanly(functions):
    """Every engine writer, on random descriptions: an export that its format's parser reads, or MdlError."""
    import csv
    import io
    import tempfile
    from pathlib import Path

    import yaml

    from mdl.diagnostics import MdlError
    from mdl.exchange.export import Settings
    from mdl.exports import export
    from support.common import device_xml

    xml = "".join(fn_xml(f"f{i}", address, **fields) for i, (fields, address) in enumerate(functions))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "d.xml"
        path.write_text(device_xml(xml), encoding="ascii")
        try:
            resolved = load_resolved(path)
        except MdlError:
            return
    for engine in ("volttron", "homeassistant", "telegraf"):
        try:
            result = export(resolved, engine, Settings())
        except MdlError as exc:
            assert "can hold none" in str(exc)
            continue
        assert all(d.severity in ("warning", "note") for d in result.warnings)
        if engine == "telegraf":
            check_config(tomllib.loads(result.text or ""))
        elif engine == "homeassistant":
            assert yaml.safe_load(result.text or "")[0]["name"]  # a list of hubs (modbus: !include)
        else:
            for name, text in result.files.items():
                if name.endswith(".csv"):
                    assert list(csv.DictReader(io.StringIO(text)))
                else:
                    assert json.loads(text)["driver_type"] == "modbus_tk"
