"""`mdl import --from sunspec MODEL... [--base] [--repeat]` (SPEC 12): the chain's functions, their
names, formats, scale factors, enumerations, bitfields, headers and markers, and clean errors."""

from __future__ import annotations

import json

import pytest

from mdl.formats.mdl.load import read_device
from support.run import assert_clean_error, run_mdl

pytest.importorskip("sunspec2")


def imported(tmp_path, *args: str):
    out = tmp_path / "chain.xml"
    proc = run_mdl("import", "--from", "sunspec", *args, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert run_mdl("validate", out).returncode == 0
    device = read_device(out)
    return device, {fn.name: fn for fn in device.functions}, proc


def test_inverter_chain_headers_markers_and_lengths(tmp_path):
    device, fns, proc = imported(tmp_path, "103", "160", "--repeat", "2")
    assert "model 1 (common) added first" in proc.stderr and "note:" in proc.stderr
    assert device.max_registers == 125
    suns = fns["SunS"]
    assert suns.addresses == [40000] and suns.initial == [0x5375, 0x6E53]
    assert suns.marker == [0x53756E53] and suns.system and suns.access == "read"
    assert (fns["1_ID"].addresses, fns["1_ID"].initial, fns["1_L"].initial) == ([40002], [1], [66])
    assert fns["103_ID"].addresses == [40070] and fns["103_ID"].initial == [103] and fns["103_L"].initial == [50]
    # 160: 8 registers before the modules' count (N), 20 a module, twice
    assert fns["160_N"].initial == [2] and fns["160_L"].initial == [8 + 2 * 20]
    assert fns["160_module_2_ID"].format == "UINT16"
    last = fns["160_module_2_DCEvt"]  # a bitfield32, the last point
    assert fns["end_ID"].addresses == [last.addresses[0] + 2] and fns["end_ID"].initial == [0xFFFF]
    assert fns["end_L"].initial == [0]
    # every register of the chain is a function's, none twice
    used = []
    for fn in device.functions:
        n = fn.count if fn.format == "STRING" else {"UINT32": 2, "INT32": 2, "FLOAT32": 2}.get(fn.format or "", 1)
        n = 4 if fn.format in ("UINT64", "INT64", "FLOAT64") else n
        used += range(fn.addresses[0], fn.addresses[0] + n)
    assert used == list(range(40000, fns["end_L"].addresses[0] + 1))


def test_points_become_functions_with_formats_scale_factors_values_and_access(tmp_path):
    _, fns, _ = imported(tmp_path, "103", "121")
    w = fns["103_W"]
    assert (w.format, w.scale_exponent, w.units, w.access) == ("INT16", "103_W_SF", "W", "read")
    assert w.not_implemented == ["0x8000"]
    assert fns["103_W_SF"].format == "INT16"
    assert fns["103_WH"].format == "UINT32" and fns["103_WH"].not_implemented == ["0x0000"]  # acc32: 0 is none
    st = fns["103_St"]
    assert st.values is not None and st.values[4] == "MPPT" and st.not_implemented == ["0xFFFF"]
    evt = fns["103_Evt1"]
    assert evt.format == "UINT32" and evt.values is None and "Bits: 0 GROUND_FAULT" in evt.description
    assert fns["1_Mn"].format == "STRING" and fns["1_Mn"].count == 16 and fns["1_Mn"].immutable
    assert fns["1_DA"].access == "read_write"
    assert fns["1_Pad"].system and fns["1_Pad"].not_implemented is None
    wmax = fns["121_WMax"]
    assert wmax.access == "read_write" and wmax.scale_exponent == "121_WMax_SF"


def test_group_local_scale_factors_and_repeats(tmp_path):
    _, fns, _ = imported(tmp_path, "133", "--repeat", "2", "--base", "0")
    assert fns["SunS"].addresses == [0]
    assert fns["133_repeating_2_X1"].scale_exponent == "133_repeating_2_X_SF"
    assert fns["133_repeating_1_X1"].scale_exponent == "133_repeating_1_X_SF"
    assert "133_repeating_3_X1" not in fns


def test_nested_counts_and_fixed_groups(tmp_path):
    _, fns, _ = imported(tmp_path, "705", "704", "--repeat", "2")
    assert fns["705_NCrv"].initial == [2] and fns["705_NPt"].initial == [2]
    assert "705_Crv_2_Pt_2_V" in fns and "705_Crv_3_Pt_1_V" not in fns
    assert "704_PFWInj_PF" in fns  # a group that does not repeat: no index


def test_long_strings_are_split_into_readable_parts(tmp_path):
    _, fns, _ = imported(tmp_path, "64411")
    one, two = fns["64411_VHarA_1"], fns["64411_VHarA_2"]
    assert (one.count, two.count) == (125, 25)
    assert two.addresses == [one.addresses[0] + 125]
    assert "64411_VHarA" not in fns and "150 registers" not in one.description
    assert "(registers 126-150 of 150)" in two.description


def test_model_json_file_and_the_format_reader(tmp_path):
    import sunspec2

    src = tmp_path / "m.json"
    path = f"{sunspec2.__path__[0]}/models/json/model_123.json"
    src.write_text(open(path).read())
    _, fns, _ = imported(tmp_path, str(src))
    assert fns["123_WMaxLimPct"].scale_exponent == "123_WMaxLimPct_SF"
    out = run_mdl("import", "--from", "sunspec", src)
    assert out.returncode == 0 and "<name>123_WMaxLimPct</name>" in out.stdout


def test_a_model_met_twice_gets_its_own_names(tmp_path):
    _, fns, _ = imported(tmp_path, "1", "103", "103")
    assert "103_W" in fns and "103-2_W" in fns
    assert "model 1 (common) added" not in "".join(fns)


@pytest.mark.parametrize(
    "args, code, fragments",
    [
        (["99999"], 1, ["unknown SunSpec model 99999", "pysunspec2 ships"]),
        (["4242"], 1, ["unknown SunSpec model 4242"]),
        (["103", "--repeat", "-1"], 2, ["--repeat"]),
        (["103", "--repeat", "x"], 2, ["--repeat"]),
        (["103", "--base", "70000"], 2, ["--base"]),
        (["160", "--repeat", "5000"], 1, ["does not fit the address space"]),
        (["1", "--base", "65500"], 1, ["does not fit the address space"]),
        (["missing.json"], 1, ["missing.json"]),
    ],
)
def test_clean_errors(tmp_path, args, code, fragments):
    proc = run_mdl("import", "--from", "sunspec", *args, "-o", tmp_path / "out.xml", cwd=tmp_path)
    assert_clean_error(proc, code, *fragments)
    assert not (tmp_path / "out.xml").exists()


@pytest.mark.parametrize(
    "text, fragments",
    [
        ('{"id": 5, "group": {', ["bad.json:1:21", "not valid JSON"]),
        ("[1, 2]", ["no JSON object"]),
        (
            '{"id": 7, "group": {"name": "g", "type": "group", "points": []}}',
            ["must start with the uint16 points ID and L"],
        ),
        (
            '{"id": 7, "group": {"name": "g", "type": "group", "points": [{"name": "ID", "type": "uint16", "value": 7},'
            ' {"name": "L", "type": "uint16"}, {"name": "W", "type": "int16", "sf": "W_SF"}]}}',
            ["scale factor 'W_SF' is not defined"],
        ),
        (
            '{"id": 7, "group": {"name": "g", "type": "group", "points": [{"name": "ID", "type": "uint16", "value": 7},'
            ' {"name": "L", "type": "uint16"}, {"name": "S", "type": "string"}]}}',
            ["a string needs a 'size'"],
        ),
        (
            '{"id": 7, "group": {"name": "g", "type": "group", "points": [{"name": "ID", "type": "uint16", "value": 7},'
            ' {"name": "L", "type": "uint16"}, {"name": "X", "type": "int128"}]}}',
            ["unknown point type 'int128'"],
        ),
        (
            '{"id": 7, "group": {"name": "g", "type": "group", "points": [{"name": "ID", "type": "uint16", "value": 8},'
            ' {"name": "L", "type": "uint16"}]}}',
            ["Model ID does not match"],
        ),
        ('{"id": 7, "group": {"name": "g", "type": "group", "points": [], "groups": [{"count": "N"}]}}', ["'N'"]),
        (
            '{"id": 7, "group": {"name": "g", "type": "group", "points": [{"name": "ID", "type": "uint16", "value": 7},'
            ' {"name": "L", "type": "uint16"}], "groups": [{"name": "e", "type": "group", "points": [], "count": 0}]}}',
            ["group.groups[0]: a group needs at least one point"],
        ),
        (b"\xff\xfe{}", ["cannot decode byte 0xff"]),
    ],
)
def test_bad_model_json_is_a_clean_error(tmp_path, text, fragments):
    bad = tmp_path / "bad.json"
    bad.write_bytes(text if isinstance(text, bytes) else text.encode())
    proc = run_mdl("import", "--from", "sunspec", "bad.json", cwd=tmp_path)
    assert_clean_error(proc, 1, "bad.json", *fragments)
    assert proc.stdout == ""


def test_base_and_repeat_belong_to_sunspec(tmp_path):
    ini = tmp_path / "Modbus.ini"
    ini.write_text("[Platform]\nName=x\n")
    proc = run_mdl("import", ini, "--repeat", "2")
    assert_clean_error(proc, 2, "--from sunspec")
    proc = run_mdl("import", ini, ini)
    assert_clean_error(proc, 2, "one FILE")


def test_a_base_no_client_looks_at_is_a_warning(tmp_path):
    out = tmp_path / "odd.xml"
    proc = run_mdl("import", "--from", "sunspec", "1", "--base", "123", "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "warning: the chain starts at 123: SunSpec clients look for its marker at 0, 40000, 50000 only" in (
        proc.stderr
    )
    strict = run_mdl("import", "--from", "sunspec", "1", "--base", "123", "-o", out, "--fail-on-warning")
    assert strict.returncode == 1
    quiet = run_mdl("import", "--from", "sunspec", "1", "--base", "50000", "-o", out)
    assert quiet.returncode == 0 and "warning" not in quiet.stderr


@pytest.mark.commands  # serves or dials a device
def test_bare_simulation_holds_the_headers(tmp_path, sim_factory):
    """No --registers: the marker, IDs, lengths, repeat counts and end marker already answer, so
    pysunspec2's client scans the inverter chain and every model reads whole."""
    client = pytest.importorskip("sunspec2.modbus.client")
    _, fns, _ = imported(tmp_path, "103", "120", "121", "122", "123", "160", "--repeat", "2")
    sim = sim_factory(tmp_path / "chain.xml")
    names = ["SunS", "1_L", "103_ID", "160_N", "end_ID"]
    proc = run_mdl("read", tmp_path / "chain.xml", *sim.connection, "--format", "json", *names)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"SunS": 0x53756E53, "1_L": 66, "103_ID": 103, "160_N": 2, "end_ID": 0xFFFF}
    device = client.SunSpecModbusClientDeviceTCP(slave_id=1, ipaddr=sim.host, ipport=sim.port)
    try:
        device.scan()
        assert [m for m in device.models if isinstance(m, int)] == [1, 103, 120, 121, 122, 123, 160]
        assert [m.error_info for ms in device.models.values() for m in ms if m.error_info] == []
        assert len(device.models[160][0].module) == 2
    finally:
        device.close()
    proc = run_mdl("write", tmp_path / "chain.xml", *sim.connection, "121_WMax=1500")  # a scaled set point
    assert proc.returncode == 0, proc.stderr
    proc = run_mdl("read", tmp_path / "chain.xml", *sim.connection, "--format", "json", "121_WMax")
    assert json.loads(proc.stdout) == {"121_WMax": 1500}


FLOAT_WITH_SF = (
    '{"id": 64999, "group": {"name": "f", "type": "group", "points": [{"name": "ID", "type": "uint16", "value": 64999},'
    ' {"name": "L", "type": "uint16"}, {"name": "E", "type": "sunssf"}, {"name": "T", "type": "float32", "sf": "E"},'
    ' {"name": "C", "type": "float32", "sf": -1}]}}'
)


def test_what_mdl_cannot_scale_is_said_and_kept_unscaled(tmp_path):
    (tmp_path / "f.json").write_text(FLOAT_WITH_SF)
    _, fns, proc = imported(tmp_path, str(tmp_path / "f.json"))
    assert "warning: '64999_T' (float32): scale factor 'E' left out: MDL scales an integer" in proc.stderr
    assert fns["64999_T"].scale_exponent is None and fns["64999_T"].format == "FLOAT32"
    assert fns["64999_C"].multiplier == pytest.approx(0.1)  # a constant exponent is a multiplier, floats too
    proc = run_mdl("import", "--from", "sunspec", "f.json", "--fail-on-warning", cwd=tmp_path)
    assert_clean_error(proc, 1, "--fail-on-warning")
    assert proc.stdout == ""


def test_a_model_from_standard_input(tmp_path):
    proc = run_mdl("import", "--from", "sunspec", "-", input=FLOAT_WITH_SF)
    assert proc.returncode == 0 and "<name>64999_T</name>" in proc.stdout
    proc = run_mdl("import", "--from", "sunspec", "-", input='{"id": 3')
    assert_clean_error(proc, 1, "<stdin>:1:9: error: not valid JSON")


def test_the_chain_builder_takes_ids_and_repeat_counts():
    """What `mdl discover --sunspec` will call: (model, repeat) pairs at a base, nothing added."""
    from mdl.formats.sunspec.read import chain_device

    device = chain_device([(1, 0), (160, 3)], base=50000)
    fns = {fn.name: fn for fn in device.functions}
    assert device.functions[0].addresses == [50000] and fns["160_N"].initial == [3]
    assert "160_module_3_DCA" in fns and not device.notes


def test_hostile_model_files_are_clean_errors(tmp_path):
    head = '{"id": 7, "group": {"name": "g", "type": "group", "points": [{"name": "ID", "type": "uint16"}, '
    head += '{"name": "L", "type": "uint16"}]'
    group = '{"name": "x", "type": "group", "points": [{"name": "a", "type": "uint16"}], "groups": ['
    cases = {
        "deep_groups.json": (head + ', "groups": [' + group * 400 + "]}" * 400 + "]}}", "nest deeper than 16"),
        "deep_json.json": ("[" * 100_000, "nests too deeply"),
        "many.json": (
            head[:-1] + "".join(f', {{"name": "p{i}", "type": "zz"}}' for i in range(30)) + "]}}",
            "and 20 more problems",
        ),
    }
    for name, (text, fragment) in cases.items():
        (tmp_path / name).write_text(text)
        proc = run_mdl("import", "--from", "sunspec", name, cwd=tmp_path)
        assert_clean_error(proc, 1, name, fragment)
