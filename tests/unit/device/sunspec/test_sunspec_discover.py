"""`mdl discover --sunspec` (SPEC 12, docs/sunspec.md "Discovering a SunSpec device"): the chain `mdl sim`
serves of an imported chain is found again, model for model, at every base, with the device's repeat
counts; unknown models and lengths that fit no repeat count are kept as raw registers with a warning; a
device answering garbage (a length past 65535, a loop, no end marker, too many models, no marker, replies
of the wrong size) is refused with exit 3 and nothing written. pysunspec2's client scans the simulation
of a discovered file, and its drivers compile.

A longer run of the walk's property test by hand:
MDL_FUZZ_SUNSPEC=5000 python -m pytest tests/unit/device/sunspec/test_sunspec_discover.py --exhaustive -k any_chain
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from types import SimpleNamespace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.device.link import ModbusExceptionError
from mdl.device.sunspec.discover import MAX_MODELS, _Walk, count_points, fit, group_length
from mdl.diagnostics import MdlError
from mdl.formats.mdl.load import read_device
from mdl.formats.sunspec.build import build_chain
from mdl.formats.sunspec.models import load_model, shipped_ids
from support.common import fn_xml
from support.hostile_server import hostile_server
from support.run import assert_clean_error, run_mdl

INVERTER = ["103", "120", "121", "122", "123", "160"]
SUNS = [0x5375, 0x6E53]
FUZZ_EXAMPLES = int(os.environ.get("MDL_FUZZ_SUNSPEC", "200"))


def names(xml: Path) -> list[str]:
    return [fn.name for fn in read_device(xml).functions]


def imported(tmp_path: Path, *args: str, name: str = "imported.xml") -> Path:
    out = tmp_path / name
    proc = run_mdl("import", "--from", "sunspec", *args, "-o", out)
    assert proc.returncode == 0, proc.stderr
    return out


def discovered(sim, out: Path, *extra: str) -> tuple[Path, str]:
    proc = run_mdl("discover", "--sunspec", *sim.connection, *extra, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    return out, proc.stderr


def words_device(write_device, chunks: dict[int, list[int]], filename: str = "hostile.xml") -> Path:
    """A plain MDL device whose registers (a UINT16 function each, with `initial`) hold `chunks`:
    start address -> raw words."""
    functions = "".join(
        fn_xml(f"r{start + i}", start + i, format="UINT16", initial=word)
        for start, words in chunks.items()
        for i, word in enumerate(words)
    )
    return write_device(functions, filename=filename)


@pytest.mark.commands  # serves or dials a device
def test_the_inverter_chain_is_found_again_with_its_repeat_count(tmp_path, sim_factory):
    source = imported(tmp_path, *INVERTER, "--repeat", "3")
    sim = sim_factory(source, "--set", "1_Mn=Acme Solar", "--set", "1_Md=AS-10K", "--set", "1_Vr=1.2.3")
    out, stderr = discovered(sim, tmp_path / "found.xml")
    assert names(out) == names(source)
    device = read_device(out)  # model 1's texts are the device's identity, served again by mdl sim
    assert (device.manufacturer, device.product, device.product_version) == ("Acme Solar", "AS-10K", "1.2.3")
    found = set(names(out))
    assert {"160_module_3_DCA", "160_N"} <= found and "160_module_4_DCA" not in found
    assert "SunSpec marker 'SunS' at 40000" in stderr
    assert re.search(r"7 models at 40000 \(1, 103, 120, 121, 122, 123, 160\), end marker at \d+; 13 requests", stderr)
    assert "warning" not in stderr
    assert run_mdl("validate", out).returncode == 0
    again = sim_factory(out)  # discover -> sim -> discover: the same file
    twice, _ = discovered(again, tmp_path / "again.xml")
    assert twice.read_text() == out.read_text()
    first = run_mdl("read", source, *sim.connection, "--format", "json")
    second = run_mdl("read", out, *again.connection, "--format", "json")
    assert first.returncode == second.returncode == 0, (first.stderr, second.stderr)
    assert json.loads(first.stdout) == json.loads(second.stdout)


@pytest.mark.commands  # serves or dials a device
@pytest.mark.parametrize("base", ["0", "50000"])
def test_the_chain_is_found_at_bases_0_and_50000(base, tmp_path, sim_factory):
    source = imported(tmp_path, "103", "160", "--repeat", "2", "--base", base)
    sim = sim_factory(source, "--unit", "7")
    out, stderr = discovered(sim, tmp_path / "found.xml", "--unit", "7")
    assert names(out) == names(source)
    assert read_device(out).functions[0].addresses == [int(base)]
    assert f"SunSpec marker 'SunS' at {base}" in stderr


CUSTOM = {
    "id": 64900,
    "group": {
        "name": "custom",
        "type": "group",
        "points": [
            {"name": "ID", "type": "uint16", "value": 64900, "mandatory": "M", "static": "S"},
            {"name": "L", "type": "uint16", "mandatory": "M", "static": "S"},
            {"name": "Temp", "type": "int16", "label": "Temperature"},
            {"name": "Count", "type": "uint32"},
            {"name": "Mode", "type": "uint16", "access": "RW"},
        ],
    },
}


@pytest.mark.commands  # serves or dials a device
def test_a_model_pysunspec2_lacks_is_kept_as_raw_registers_with_a_warning(tmp_path, sim_factory):
    model = tmp_path / "custom_64900.json"
    model.write_text(json.dumps(CUSTOM))
    source = imported(tmp_path, "103", str(model), "160", "--repeat", "2")
    sim = sim_factory(source, "--set", "64900_Temp=-5")
    out, stderr = discovered(sim, tmp_path / "found.xml")
    assert "warning: model 64900 at 40122 (L 4): pysunspec2 does not define model 64900" in stderr
    device = read_device(out)
    raw = [fn for fn in device.functions if fn.name.startswith("64900_reg_")]
    assert [fn.name for fn in raw] == [f"64900_reg_{n}" for n in range(1, 5)]
    assert all(fn.format == "UINT16" and fn.not_implemented is None and fn.access == "read" for fn in raw)
    assert [fn.addresses[0] for fn in raw] == list(range(40124, 40128))
    assert {"160_module_2_DCA", "103_W"} <= set(names(out))  # the models around it as they are
    values = json.loads(run_mdl("read", out, *sim.connection, "--format", "json").stdout)
    assert values["64900_reg_1"] == 0xFFFB  # the raw register: -5
    again = sim_factory(out)
    twice, stderr2 = discovered(again, tmp_path / "again.xml")
    assert twice.read_text() == out.read_text() and "pysunspec2 does not define model 64900" in stderr2
    refused = run_mdl("discover", "--sunspec", *sim.connection, "--fail-on-warning", "-o", tmp_path / "no.xml")
    assert_clean_error(refused, 1, "pysunspec2 does not define model 64900", "--fail-on-warning")
    assert not (tmp_path / "no.xml").exists()


@pytest.mark.commands  # serves or dials a device
def test_a_length_no_repeat_count_fits_is_kept_raw_with_a_warning(tmp_path, write_device, sim_factory):
    device = words_device(write_device, {40000: [*SUNS, 103, 51, *[0] * 51, 0xFFFF, 0]})
    out, stderr = discovered(sim_factory(device), tmp_path / "found.xml")
    assert "warning: model 103 at 40002 (L 51): no repeat count gives this length" in stderr
    assert [n for n in names(out) if n.startswith("103_")] == ["103_ID", "103_L"] + [
        f"103_reg_{n}" for n in range(1, 52)
    ]


@pytest.mark.commands  # serves or dials a device
def test_count_points_that_disagree_with_l_keep_the_model_raw(tmp_path, sim_factory):
    source = imported(tmp_path, "160", "--repeat", "3")
    at = read_device(source).functions
    n_address = next(fn.addresses[0] for fn in at if fn.name == "160_N")
    image = tmp_path / "n.json"
    image.write_text(json.dumps({"holding": {str(n_address): 2}}))
    out, stderr = discovered(sim_factory(source, "--registers", image), tmp_path / "found.xml")
    assert "N reads 2, but L means 3: kept as" in stderr
    assert "160_reg_1" in names(out) and "160_module_1_DCA" not in names(out)


HOSTILE = {
    "length past 65535": ({40000: [*SUNS, 64900, 65000]}, "model 64900 at 40002 has L 65000, which runs past 65535"),
    "a loop": ({40000: [*SUNS, 64900, 65534]}, "the chain loops: model 64900 at 40002 has L 65534, which wraps around"),
    "no end marker": ({40000: [*SUNS, 64900, 2, 7, 7]}, "no end marker: the chain breaks off at 40006 (after 1 model)"),
    "address space ends": (
        {0: [*SUNS, 64900, 65530], 65534: [64901, 0]},
        "no end marker (model ID 0xFFFF) before the address space ends (after 2 models)",
    ),
    "too many models": ({40000: [*SUNS, *[64900, 0] * (MAX_MODELS + 1)]}, f"more than {MAX_MODELS} models before"),
    "no marker": (
        {40000: [0x5375, 0x6E54], 0: [1, 2, 3]},
        "no SunSpec marker 'SunS' (0x5375 0x6E53) at 40000, 0 or 50000 (40000: 0x5375 0x6E54; 0: 0x0001 0x0002; "
        "50000: exception 2)",
    ),
}


@pytest.mark.commands  # serves or dials a device
@pytest.mark.parametrize("case", list(HOSTILE))
def test_a_device_answering_garbage_is_refused_and_nothing_is_written(case, tmp_path, write_device, sim_factory):
    chunks, message = HOSTILE[case]
    sim = sim_factory(words_device(write_device, chunks))
    out = tmp_path / "found.xml"
    proc = run_mdl("discover", "--sunspec", *sim.connection, "-o", out)
    assert_clean_error(proc, 3, message)
    assert not out.exists() and proc.stdout == ""


@pytest.mark.parametrize("mode", ["short", "extra_registers", "bad_byte_count", "garbage", "silent"])
def test_replies_of_the_wrong_size_or_none_are_refused(mode, tmp_path):
    out = tmp_path / "found.xml"
    with hostile_server(mode) as (host, port):
        proc = run_mdl("discover", "--sunspec", "--host", host, "--port", port, "--timeout", "0.3", "-o", out)
    assert_clean_error(proc, 3, "reading 2 holding from 40000")
    assert not out.exists()


def test_an_honest_device_without_sunspec_is_refused(tmp_path):
    with hostile_server("honest") as (host, port):  # each register holds its own address
        proc = run_mdl("discover", "--sunspec", "--host", host, "--port", port)
    assert_clean_error(proc, 3, "(40000: 0x9C40 0x9C41; 0: 0x0000 0x0001; 50000: 0xC350 0xC351)")


@pytest.mark.parametrize(
    "args, message",
    [
        (["--sunspec", "device.xml"], "--sunspec takes no FILE"),
        (["--sunspec", "--units", "1-3"], "--units does not go with --sunspec"),
        (["--sunspec", "--format", "json"], "--format does not go with --sunspec"),
        (["device.xml", "--unit", "3"], "--unit goes with --sunspec"),
        (["device.xml", "-o", "x.xml"], "-o/--output goes with --sunspec"),
        ([], "give the description FILE... to look for, or --sunspec"),
        (["--sunspec", "--unit", "0", "--serial", "/dev/null"], "unit 0 is the broadcast address"),
    ],
)
def test_usage_errors(args, message, tmp_path, write_device):
    write_device(fn_xml("a", 1, format="UINT16"))
    where = [] if "--serial" in args else ["--host", "127.0.0.1", "--port", "1"]
    proc = run_mdl("discover", *args, *where, cwd=tmp_path)
    assert_clean_error(proc, 2, message)


def test_no_device_is_exit_3(tmp_path):
    with hostile_server("honest") as (host, port):
        pass  # the port is free again: nothing listens
    proc = run_mdl("discover", "--sunspec", "--host", host, "--port", port)
    assert_clean_error(proc, 3, "cannot connect")


@pytest.mark.commands  # serves or dials a device
def test_pysunspec2_scans_the_simulation_of_a_discovered_chain(tmp_path, sim_factory):
    client = pytest.importorskip("sunspec2.modbus.client")
    from support.sunspec import differences, raw_image

    source = imported(tmp_path, *INVERTER, "--repeat", "3")
    out, _ = discovered(sim_factory(source), tmp_path / "found.xml")
    image = tmp_path / "image.json"
    image.write_text(json.dumps(raw_image(out)))
    sim = sim_factory(out, "--registers", image)
    device = client.SunSpecModbusClientDeviceTCP(slave_id=1, ipaddr=sim.host, ipport=sim.port)
    try:
        device.scan()
        assert [m for m in device.models if isinstance(m, int)] == [1, 103, 120, 121, 122, 123, 160]
        assert len(device.models[160][0].groups["module"]) == 3
        values = json.loads(run_mdl("read", out, *sim.connection, "--format", "json").stdout)
        assert differences(device, values) == []
    finally:
        device.close()


@pytest.mark.compile
def test_drivers_of_a_discovered_inverter_chain_compile(tmp_path, sim_factory):
    from support.c_harness import compile_driver as compile_c
    from support.cpp_harness import compile_driver as compile_cxx

    source = imported(tmp_path, *INVERTER, "--repeat", "2")
    out, _ = discovered(sim_factory(source), tmp_path / "found.xml")
    proc = run_mdl("gen", out, "--lang", "all", "-o", tmp_path / "gen")
    assert proc.returncode == 0, proc.stderr
    c_file = next((tmp_path / "gen").glob("*.c"))
    assert compile_c(c_file, "gcc").exists()
    assert compile_cxx(c_file.with_suffix(".cc"), "g++").exists()


# the pure parts, without a device


@pytest.mark.parametrize("mid", shipped_ids())
def test_fit_finds_the_repeat_count_build_chain_used(mid):
    model = load_model(str(mid))
    varies = group_length(model["group"], 0) != group_length(model["group"], 1)
    for repeat in (0, 1, 3) if varies else (1,):
        device = build_chain([(model, repeat)])
        length = next(fn.initial[0] for fn in device.functions if fn.name == f"{mid}_L")
        assert length == group_length(model["group"], repeat) - 2
        assert fit(model, length) == repeat
        for name, offset in count_points(model).items():
            fn = next(fn for fn in device.functions if fn.name == f"{mid}_{name}")
            assert fn.addresses[0] - device.functions[1].addresses[0] == offset and fn.initial == [repeat]
    sizes = [group_length(model["group"], r) - 2 for r in (0, 1, 2)]
    between = [n for n in (sizes[0] - 1, sizes[1] + 1) if 0 <= n and n not in sizes]
    assert all(fit(model, n) is None for n in between)  # a length between two repeat counts'


class _Image(_Walk):
    """The walk over a register image instead of a device: an address without a value is exception 2."""

    def __init__(self, image: dict[int, int]) -> None:
        super().__init__(SimpleNamespace(where=lambda what: f"image: {what}"), 1)  # type: ignore[arg-type]
        self.image = image

    def read(self, start: int, count: int) -> list[int]:
        self.requests += 1
        if any(a not in self.image for a in range(start, start + count)):
            raise ModbusExceptionError(f"reading {count} holding from {start}", 2)
        return [self.image[a] for a in range(start, start + count)]


WORD = st.one_of(st.integers(0, 0xFFFF), st.sampled_from([0xFFFF, 0, 1, 2, 3, 103, 160, 64900, 65534]))
# a chain's shape: (model id, L, the count point's value) each, then maybe an end marker
MODELS = st.lists(
    st.tuples(st.sampled_from([1, 103, 160, 705, 64900]), st.integers(0, 120), st.integers(0, 4)), max_size=6
)


@st.composite
def chain_words(draw) -> list[int]:
    """Register words after the marker: a chain of plausible headers (L that fits or not, count points
    that agree or not) with an end marker or none, or any words at all."""
    if draw(st.booleans()):
        return draw(st.lists(WORD, max_size=60))
    words: list[int] = []
    for mid, length, count in draw(MODELS):
        if mid != 64900 and draw(st.booleans()):  # the length of `count` repeats
            length = group_length(load_model(str(mid))["group"], count) - 2
        body = [count] * length  # every register the count: count points agree where they are read
        words += [mid, length, *body]
    if draw(st.booleans()):
        words += [0xFFFF, draw(st.sampled_from([0, 1]))]
    return words


@pytest.mark.fuzz
@settings(max_examples=FUZZ_EXAMPLES, deadline=None)
@given(base=st.sampled_from([0, 40000, 50000, 65000]), words=chain_words())
def test_any_chain_image_is_walked_or_refused(base, words):
    """Whatever the registers hold, the walk ends with the headers of a chain that fits the address space,
    or a clean refusal; it never asks more than MAX_MODELS + 1 headers."""
    image = {base + i: w for i, w in enumerate([*SUNS, *words]) if base + i < 65536}
    walk = _Image(image)
    try:
        headers, end = walk.chain(base, lambda _: None)
    except MdlError as exc:
        assert exc.exit_code == 3 and "not a SunSpec chain" in str(exc)
        return
    assert walk.requests == len(headers) + 1 <= MAX_MODELS + 1
    assert image[end] == 0xFFFF and end + 1 < 65536
    addresses = [h.address for h in headers]
    assert addresses == sorted(set(addresses)) and all(h.address + 2 + h.length <= end for h in headers)
    for header in headers:
        model, repeat = walk.model(header)
        assert int(model["id"]) == header.model_id
        assert group_length(model["group"], repeat) - 2 == header.length
