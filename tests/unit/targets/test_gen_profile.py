"""`mdl gen --profile` (SPEC 13, docs/profiles.md "Generated interfaces"): one program per target,
written only against the profile's interface, runs unchanged against two vendors' generated drivers
(examples/profiles/meter_a.xml: INT32 kW, UINT32 kWh x 0.01, power factor x 0.001; meter_b.xml: FLOAT32
input registers in W and Wh, power given as export, power factor in %) served by `mdl sim` with raw
registers of the same physical values, and prints the same values (and "not provided" where a vendor
lacks a role). The interface's own files are the same bytes for both devices."""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from support.common import ROOT, device_xml, fn_xml
from support.run import assert_clean_error, run_mdl

EXAMPLES = ROOT / "examples" / "profiles"
METERS = {"a": ("meter_a", "MeterA"), "b": ("meter_b", "MeterB")}


def _f32(x: float) -> list[int]:
    data = struct.pack(">f", x)
    return [int.from_bytes(data[:2], "big"), int.from_bytes(data[2:], "big")]


def _raw_b() -> dict[str, dict[str, int]]:
    words = {}
    for address, value in ((100, -1234.0), (102, 56780.0), (104, 4321.0), (106, 230.1)):
        high, low = _f32(value)
        words[str(address)], words[str(address + 1)] = high, low
    words["108"] = 95  # %
    return {"input": words}


# the same physical values: 1234 W imported, 56780 Wh imported, 230.1 V, power factor 0.95
RAW = {
    "a": {"holding": {"0": 0, "1": 1234, "2": 0, "3": 5678, "4": 2301, "5": 950}},  # kW x 0.001, kWh x 0.01
    "b": _raw_b(),  # W, exported (-1234), Wh, V, %
}
# what the interface-only program prints for each device: the same, but for the role A lacks
COMMON = [
    "power_w: 1234.000",
    "energy_import_wh: 56780.000",
    "voltage_l1_v: 230.100",
    "power_factor: 0.950",
    "power_l1_w: not provided",
]
EXPECTED = {
    "a": [*COMMON, "energy_export_wh: not provided"],
    "b": [*COMMON, "energy_export_wh: 4321.000"],
}


def _gen(source: Path, outdir: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return run_mdl("gen", source, "-o", outdir, *extra)


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> dict[str, Path]:
    """Each meter's drivers (--lang all) with the meter profile, each in its own folder."""
    out = {}
    for key, (stem, _) in METERS.items():
        folder = tmp_path_factory.mktemp(f"meter_{key}")
        proc = _gen(EXAMPLES / f"{stem}.xml", folder, "--profile", "meter")
        assert proc.returncode == 0, proc.stderr
        out[key] = folder
    return out


@pytest.fixture
def served(sim_factory, tmp_path):
    """key -> the port of `mdl sim` serving that meter with the raw registers of RAW."""
    ports = {}
    for key, (stem, _) in METERS.items():
        raw = tmp_path / f"{key}.json"
        raw.write_text(json.dumps(RAW[key]))
        ports[key] = sim_factory(EXAMPLES / f"{stem}.xml", "--registers", raw).port
    return ports


# ---- the interface's own files


def test_interface_files_are_the_same_bytes_for_both_vendors(generated):
    for name in ("mdl_meter.h", "meter_profile.py"):
        assert (generated["a"] / name).read_bytes() == (generated["b"] / name).read_bytes(), name
    header = (generated["a"] / "mdl_meter.h").read_text()
    assert "class Meter {" in header and "struct mdl_meter {" in header
    assert "virtual int read_power_w(double *out) = 0;" in header  # 0, or -1 with errno, as SPEC 5
    assert "int (*read_power_w)(void *ctx, double *out);" in header


@pytest.mark.parametrize("lang", ["python", "cpp", "c"])
def test_each_target_alone_writes_the_same_interface_for_both(tmp_path, lang):
    files = {}
    for key, (stem, _) in METERS.items():
        proc = _gen(EXAMPLES / f"{stem}.xml", tmp_path / key, "--lang", lang, "--profile", "meter")
        assert proc.returncode == 0, proc.stderr
        files[key] = {p.name: p.read_bytes() for p in (tmp_path / key).iterdir() if not p.name.startswith(stem)}
    assert files["a"] == files["b"] and len(files["a"]) == 1, files["a"].keys()


def test_without_profile_the_driver_is_unchanged(tmp_path):
    """--profile only adds: the driver without it is the one mdl gen always wrote."""
    plain, with_profile = tmp_path / "plain", tmp_path / "profile"
    assert _gen(EXAMPLES / "meter_a.xml", plain, "--lang", "python").returncode == 0
    assert _gen(EXAMPLES / "meter_a.xml", with_profile, "--lang", "python", "--profile", "meter").returncode == 0
    text = (plain / "meter_a.py").read_text()
    assert "_profile" not in text and "read_power_w" not in text
    assert "class MeterA(_profile.Meter):" in (with_profile / "meter_a.py").read_text()


# ---- Python: one program over the Protocol

PROGRAM_PY = '''"""Written only against the meter interface: each role's value, or "not provided"."""

from __future__ import annotations

import asyncio
import importlib
import sys
from collections.abc import Awaitable, Callable

from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient

from meter_profile import AsyncMeter, Meter, NotProvided


def line(role: str, read: Callable[[], float | None]) -> str:
    try:
        value = read()
    except NotProvided:
        return f"{role}: not provided"
    return f"{role}: {'null' if value is None else format(value, '.3f')}"


def show(meter: Meter) -> list[str]:
    return [
        line("power_w", meter.read_power_w),
        line("energy_import_wh", meter.read_energy_import_wh),
        line("voltage_l1_v", meter.read_voltage_l1_v),
        line("power_factor", meter.read_power_factor),
        line("power_l1_w", meter.read_power_l1_w),
        line("energy_export_wh", meter.read_energy_export_wh),
    ]


async def aline(role: str, read: Callable[[], Awaitable[float | None]]) -> str:
    try:
        value = await read()
    except NotProvided:
        return f"{role}: not provided"
    return f"{role}: {'null' if value is None else format(value, '.3f')}"


async def ashow(meter: AsyncMeter) -> list[str]:
    return [
        await aline("power_w", meter.read_power_w),
        await aline("energy_import_wh", meter.read_energy_import_wh),
        await aline("voltage_l1_v", meter.read_voltage_l1_v),
        await aline("power_factor", meter.read_power_factor),
        await aline("power_l1_w", meter.read_power_l1_w),
        await aline("energy_export_wh", meter.read_energy_export_wh),
    ]


async def run_async(cls: Callable[[AsyncModbusTcpClient], AsyncMeter], port: int) -> list[str]:
    client = AsyncModbusTcpClient("127.0.0.1", port=port)
    await client.connect()
    close: Callable[[], None] = client.close  # typed here: pymodbus leaves it unannotated
    try:
        return await ashow(cls(client))
    finally:
        close()


def main() -> None:
    driver = importlib.import_module(sys.argv[1])
    port = int(sys.argv[3])
    client = ModbusTcpClient("127.0.0.1", port=port)
    close: Callable[[], None] = client.close
    try:
        print("\\n".join(show(getattr(driver, sys.argv[2])(client))))
    finally:
        close()
    print("\\n".join(asyncio.run(run_async(getattr(driver, "Async" + sys.argv[2]), port))))


if __name__ == "__main__":
    main()
'''

# the drivers implement the Protocols: mypy checks each passed where the interface is taken
TYPECHECK_PY = """from __future__ import annotations

from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient

from {module} import Async{cls}, {cls}
from use_meter import ashow, show


def check(client: ModbusTcpClient, aclient: AsyncModbusTcpClient) -> None:
    show({cls}(client))
    ashow(Async{cls}(aclient)).close()
"""


@pytest.mark.commands  # serves or dials a device
def test_python_program_prints_the_same_for_both_vendors(generated, served, tmp_path):
    program = tmp_path / "use_meter.py"
    program.write_text(PROGRAM_PY)
    for key, (stem, cls) in METERS.items():
        proc = subprocess.run(
            [sys.executable, str(program), stem, cls, str(served[key])],
            capture_output=True,
            text=True,
            timeout=60,
            env={"PYTHONPATH": str(generated[key]), "PATH": "/usr/bin:/bin"},
        )
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.splitlines() == EXPECTED[key] * 2, (key, proc.stdout)  # sync, then asyncio


def _python_tool(module: str) -> list[str]:
    import importlib.util

    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} is not installed")
    return [sys.executable, "-m", module]


@pytest.mark.compile
def test_generated_python_with_profile_is_ruff_and_mypy_strict_clean(generated, tmp_path):
    for key, (stem, cls) in METERS.items():
        folder = tmp_path / key
        folder.mkdir()
        for name in (f"{stem}.py", "meter_profile.py"):
            shutil.copyfile(generated[key] / name, folder / name)
        (folder / "use_meter.py").write_text(PROGRAM_PY)
        (folder / "typecheck.py").write_text(TYPECHECK_PY.format(module=stem, cls=cls))
        files = sorted(p.name for p in folder.glob("*.py"))
        ruff = subprocess.run(
            [*_python_tool("ruff"), "check", "--isolated", "--no-cache", *files],
            cwd=folder,
            capture_output=True,
            text=True,
        )
        assert ruff.returncode == 0, ruff.stdout + ruff.stderr
        mypy = subprocess.run(
            [*_python_tool("mypy"), "--config-file", "", "--strict", "--cache-dir", str(tmp_path / ".mypy"), *files],
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert mypy.returncode == 0, mypy.stdout + mypy.stderr


# ---- C++: one program over mdl::Meter, compiled once, linked with each driver

PROGRAM_CPP = r"""// Written only against the meter interface (mdl_meter.h): each role's value, or "not provided".
#include <cerrno>
#include <cstdio>
#include <cstdlib>

#include <modbus.h>

#include "mdl_meter.h"

mdl::Meter *make_meter(modbus_t *ctx);  // glue.cc: the one place that names the device's class

namespace {

void line(const char *role, bool ok, double value) {
    if (ok) {
        std::printf("%s: %.3f\n", role, value);
    } else if (errno == MDL_ENOTPROVIDED) {
        std::printf("%s: not provided\n", role);
    } else {
        std::printf("%s: error %d\n", role, errno);
    }
}

void show(mdl::Meter &meter) {
    double v = 0.0;
    bool ok = meter.read_power_w(&v) == 0;
    line("power_w", ok, v);
    ok = meter.read_energy_import_wh(&v) == 0;
    line("energy_import_wh", ok, v);
    ok = meter.read_voltage_l1_v(&v) == 0;
    line("voltage_l1_v", ok, v);
    ok = meter.read_power_factor(&v) == 0;
    line("power_factor", ok, v);
    ok = meter.read_power_l1_w(&v) == 0;
    line("power_l1_w", ok, v);
    ok = meter.read_energy_export_wh(&v) == 0;
    line("energy_export_wh", ok, v);
}

}  // namespace

int main(int argc, char **argv) {
    if (argc != 2) {
        return 2;
    }
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", std::atoi(argv[1]));
    if (ctx == nullptr || modbus_set_slave(ctx, 1) == -1 || modbus_connect(ctx) == -1) {
        std::printf("connect failed\n");
        return 1;
    }
    mdl::Meter *meter = make_meter(ctx);
    show(*meter);
    delete meter;
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}
"""


def _run_program(exe: Path, port: int) -> list[str]:
    proc = subprocess.run([str(exe), str(port)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout.splitlines()


def _build(cmd: list[str]) -> None:
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, " ".join(cmd) + "\n" + proc.stderr


def _one_program_two_drivers(
    compiler: str, strict: list[str], ext: str, program: str, glue: list[str], generated, served, tmp_path
) -> None:
    """Compile `program` once against the interface alone, link it with each meter's driver (and a
    glue file naming the device, compiled with `glue` formatted per meter), run each against its
    `mdl sim`: each prints EXPECTED."""
    from support.cpp_harness import modbus_flags

    cflags, libs = modbus_flags()
    main_source, glue_source = tmp_path / f"main.{ext}", tmp_path / f"glue.{ext}"
    main_source.write_text(program)
    glue_source.write_text("#include DRIVER_HEADER\n\n" + GLUE[ext])
    main = tmp_path / "main.o"  # compiled once, against the interface alone
    _build([compiler, *strict, *cflags, "-I", str(generated["a"]), "-c", str(main_source), "-o", str(main)])
    for key, (stem, cls) in METERS.items():
        folder = generated[key]
        objects = []
        defines = [d.format(stem=stem, cls=cls) for d in glue]
        for source, flags in ((folder / f"{stem}.{ext}", []), (glue_source, defines)):
            obj = tmp_path / f"{key}_{source.stem}.o"
            _build([compiler, *strict, *cflags, *flags, "-I", str(folder), "-c", str(source), "-o", str(obj)])
            objects.append(str(obj))
        exe = tmp_path / f"meter_{key}"
        _build([compiler, str(main), *objects, *libs, "-lm", "-o", str(exe)])
        assert _run_program(exe, served[key]) == EXPECTED[key], key


@pytest.mark.compile
@pytest.mark.parametrize("compiler", ["g++", "clang++"])
def test_cpp_program_prints_the_same_for_both_vendors(generated, served, tmp_path, compiler):
    from support.cpp_harness import STRICT, tool

    glue = ['-DDRIVER_HEADER="{stem}.h"', "-DDRIVER_CLASS={cls}"]
    _one_program_two_drivers(tool(compiler), STRICT, "cc", PROGRAM_CPP, glue, generated, served, tmp_path)


# ---- C: one program over struct mdl_meter, compiled once, linked with each driver

PROGRAM_C = r"""/* Written only against the meter interface (mdl_meter.h): each role's value, or "not provided". */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

#include <modbus.h>

#include "mdl_meter.h"

void fill_meter(struct mdl_meter *meter); /* glue.c: the one place that names the device */

static void line(const char *role, int rc, double value) {
    if (rc == 0) {
        printf("%s: %.3f\n", role, value);
    } else if (errno == MDL_ENOTPROVIDED) {
        printf("%s: not provided\n", role);
    } else {
        printf("%s: error %d\n", role, errno);
    }
}

static void show(const struct mdl_meter *m, void *ctx) {
    double v = 0.0;
    int rc = m->read_power_w(ctx, &v);
    line("power_w", rc, v);
    rc = m->read_energy_import_wh(ctx, &v);
    line("energy_import_wh", rc, v);
    rc = m->read_voltage_l1_v(ctx, &v);
    line("voltage_l1_v", rc, v);
    rc = m->read_power_factor(ctx, &v);
    line("power_factor", rc, v);
    rc = m->read_power_l1_w(ctx, &v);
    line("power_l1_w", rc, v);
    rc = m->read_energy_export_wh(ctx, &v);
    line("energy_export_wh", rc, v);
}

int main(int argc, char **argv) {
    modbus_t *ctx;
    struct mdl_meter meter;
    if (argc != 2) {
        return 2;
    }
    ctx = modbus_new_tcp("127.0.0.1", atoi(argv[1]));
    if (ctx == NULL || modbus_set_slave(ctx, 1) == -1 || modbus_connect(ctx) == -1) {
        printf("connect failed\n");
        return 1;
    }
    fill_meter(&meter);
    show(&meter, ctx);
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}
"""

# the one place that names the device: `make_meter` (C++) or `fill_meter` (C) for DRIVER_HEADER's driver
GLUE = {
    "cc": "mdl::Meter *make_meter(modbus_t *ctx) { return new DRIVER_CLASS(ctx); }\n",
    "c": "void fill_meter(struct mdl_meter *meter) { DRIVER_FILL(meter); }\n",
}


@pytest.mark.compile
@pytest.mark.parametrize("compiler", ["gcc", "clang"])
def test_c_program_prints_the_same_for_both_vendors(generated, served, tmp_path, compiler):
    from support.c_harness import STRICT, tool

    glue = ['-DDRIVER_HEADER="{stem}.h"', "-DDRIVER_FILL={stem}_meter"]
    _one_program_two_drivers(tool(compiler), STRICT, "c", PROGRAM_C, glue, generated, served, tmp_path)


# ---- written roles: a charger whose limit is in mA (UINT16) and one whose limit is FLOAT32 A

CHARGER_X = (
    fn_xml("state", "0", format="INT16", access="read", role="status")
    + fn_xml("limit", "1", format="UINT16", units="mA", access="read_write", role="current_limit_a")
    + fn_xml("on", "2", register_type="coil", access="read_write", role="enabled")
    + fn_xml("p", "3 4", format="FLOAT32", units="kW", access="read", role="power_w", not_implemented="0xFFFF 0xFFFF")
)
CHARGER_Y = (
    fn_xml("status_code", "10", format="UINT16", access="read_write", role="status")
    + fn_xml("i_max", "11 12", format="FLOAT32", units="A", access="read_write", role="current_limit_a")
    + fn_xml("allowed", "13", register_type="coil", access="read", role="enabled")
)
CHARGER_PROGRAM = """from __future__ import annotations

import importlib
import sys

from pymodbus.client import ModbusTcpClient

from evcharger_profile import Evcharger, NotProvided


def use(charger: Evcharger) -> None:
    charger.write_current_limit_a(16.0)
    print("limit", charger.read_current_limit_a())
    try:
        charger.write_enabled(True)
        print("enabled", charger.read_enabled())
    except NotProvided as exc:
        print("enabled: not provided:", exc)
    print("power", charger.read_power_w() if sys.argv[2] == "ChargerX" else "-")


client = ModbusTcpClient("127.0.0.1", port=int(sys.argv[3]))
use(getattr(importlib.import_module(sys.argv[1]), sys.argv[2])(client))
client.close()
"""


@pytest.mark.compile
def test_written_roles_convert_back_in_every_target(tmp_path, sim_factory):
    from support.c_harness import STRICT as C_STRICT
    from support.cpp_harness import STRICT, modbus_flags, tool

    cflags, _ = modbus_flags()
    (tmp_path / "use.py").write_text(CHARGER_PROGRAM)
    outputs = {}
    for stem, cls, functions in (("charger_x", "ChargerX", CHARGER_X), ("charger_y", "ChargerY", CHARGER_Y)):
        source = tmp_path / f"{stem}.xml"
        source.write_text(device_xml(functions, name=cls.replace("Charger", "Charger ")))
        folder = tmp_path / stem
        proc = _gen(source, folder, "--profile", "evcharger")
        assert proc.returncode == 0, proc.stderr
        _build([tool("g++"), *STRICT, *cflags, "-c", str(folder / f"{stem}.cc"), "-o", str(tmp_path / "x.o")])
        _build([tool("gcc"), *C_STRICT, *cflags, "-c", str(folder / f"{stem}.c"), "-o", str(tmp_path / "y.o")])
        sim = sim_factory(source)
        run = subprocess.run(
            [sys.executable, str(tmp_path / "use.py"), stem, cls, str(sim.port)],
            capture_output=True,
            text=True,
            timeout=60,
            env={"PYTHONPATH": str(folder), "PATH": "/usr/bin:/bin"},
        )
        assert run.returncode == 0, run.stderr
        outputs[stem] = run.stdout.splitlines()
        read = run_mdl("read", source, *sim.connection, "--format", "json")
        assert read.returncode == 0, read.stderr
        outputs[stem + " registers"] = json.loads(read.stdout)
    # 16 A is 16000 mA in X's register and 16.0 in Y's; Y's coil is read-only: writing it is "not provided"
    assert outputs["charger_x"] == ["limit 16.0", "enabled True", "power 0.0"]
    assert outputs["charger_x registers"]["limit"] == 16000
    assert outputs["charger_y"] == ["limit 16.0", "enabled: not provided: Charger Y cannot write enabled", "power -"]
    assert outputs["charger_y registers"]["i_max"] == 16.0


# ---- errors: nothing written


def test_unknown_profile_is_a_clean_error(tmp_path):
    proc = _gen(EXAMPLES / "meter_a.xml", tmp_path / "out", "--profile", "no_such_profile")
    assert_clean_error(proc, 1, "no profile named 'no_such_profile'")
    assert not (tmp_path / "out").exists()


def test_a_device_that_does_not_fit_is_an_error_listing_each_problem(tmp_path):
    proc = _gen(EXAMPLES / "meter_a.xml", tmp_path / "out", "--profile", "inverter")
    assert_clean_error(proc, 1, "error: profile inverter: required role energy_wh is not provided")
    assert "note: import_energy: role 'energy_import_wh' is not one of profile inverter's" in proc.stderr
    assert not (tmp_path / "out").exists()


def test_a_role_bound_twice_is_the_fit_error_at_its_line(tmp_path, write_device):
    path = write_device(
        fn_xml("p1", "0", format="INT16", units="W", role="power_w")
        + fn_xml("p2", "1", format="INT16", units="W", role="power_w")
        + fn_xml("e", "2", format="UINT16", units="Wh", role="energy_import_wh")
    )
    proc = _gen(path, tmp_path / "out", "--profile", "meter")
    assert_clean_error(proc, 1, "p2: plays power_w, which p1 plays already")
    assert f"{path}:" in proc.stderr.split("p2:")[0].splitlines()[-1]
    assert not (tmp_path / "out").exists()


def test_a_function_whose_method_is_a_roles_method_is_an_error(tmp_path, write_device):
    """A function that plays no role but is named like one's method: renaming it is the only way."""
    path = write_device(
        fn_xml("power_w", "0", format="INT16", units="kW")
        + fn_xml("p", "2", format="INT16", units="W", role="power_w")
        + fn_xml("e", "1", format="UINT16", units="Wh", role="energy_import_wh")
    )
    proc = _gen(path, tmp_path / "out", "--profile", "meter")
    assert_clean_error(proc, 1, "function power_w: its method read_power_w would also be role power_w's")
    assert not (tmp_path / "out").exists()


@pytest.mark.commands  # serves or dials a device
def test_a_function_named_after_its_role_gives_the_role_its_method(tmp_path, sim_factory, write_device):
    """csv2xml names functions after the roles they play (`power_w` read in kW): the role's
    read_power_w reads W, the function's own value is read_power_w_device, and a note says so."""
    path = write_device(
        fn_xml("power_w", "0", format="INT16", units="kW", multiplier="0.1", role="power_w")
        + fn_xml("energy_import_wh", "1", format="UINT16", units="Wh", role="energy_import_wh"),
        name="Named Meter",
    )
    out = tmp_path / "out"
    proc = _gen(path, out, "--lang", "python", "--profile", "meter")
    assert proc.returncode == 0, proc.stderr
    assert "power_w's own methods are read_power_w_device/write_power_w_device" in proc.stderr
    raw = tmp_path / "raw.json"
    raw.write_text(json.dumps({"holding": {"0": 15, "1": 700}}))
    sim = sim_factory(path, "--registers", raw)
    script = (
        "from pymodbus.client import ModbusTcpClient\nfrom named_meter import NamedMeter\n"
        f"c = ModbusTcpClient('127.0.0.1', port={sim.port}); c.connect(); m = NamedMeter(c)\n"
        "print(m.read_power_w(), m.read_power_w_device(), m.read_energy_import_wh())\n"
    )
    ran = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=out,
        env={"PATH": "/usr/bin:/bin"},
    )
    assert ran.returncode == 0, ran.stderr
    assert ran.stdout.split() == ["1500.0", "1.5", "700.0"]


def test_a_device_file_named_like_the_interface_module_is_an_error(tmp_path):
    source = tmp_path / "d.xml"
    source.write_text(
        (EXAMPLES / "meter_b.xml").read_text().replace("<name>Meter B</name>", "<name>Meter Profile</name>")
    )
    proc = _gen(source, tmp_path / "out", "--lang", "python", "--profile", "meter")
    assert_clean_error(proc, 1, "meter_profile.py has the name of profile meter's interface file")
    assert not (tmp_path / "out").exists()


def test_notes_say_each_guess_and_each_renamed_role(tmp_path, write_device):
    profile = tmp_path / "odd.yaml"
    profile.write_text("name: odd\nroles:\n  class: {type: int, required: true}\n  all: {unit: W}\n")
    path = write_device(fn_xml("c", "0", format="INT16", role="class") + fn_xml("w", "1", format="INT16", role="all"))
    proc = _gen(path, tmp_path / "out", "--profile", str(profile))
    assert proc.returncode == 0, proc.stderr
    assert "note: profile odd: role class is read_class_ in generated code" in proc.stderr
    assert "note: w: as all: no units given: taken as W" in proc.stderr
    module = (tmp_path / "out" / "odd_profile.py").read_text()
    assert "def read_class_(self) -> int | None:" in module and "def read_all_(self) -> float | None:" in module
    compile(module, "odd_profile.py", "exec")
    compile((tmp_path / "out" / "test_device.py").read_text(), "test_device.py", "exec")


# ---- fuzz: any profile a user may write gives code that parses, or a clean error

_TEXT = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=40)


def _quoted(text: str) -> str:
    """A YAML double-quoted scalar of the text (JSON's string syntax is YAML's)."""
    return json.dumps(text, ensure_ascii=False)


@st.composite
def _profiles(draw) -> tuple[str, list[str]]:
    names = draw(st.lists(st.from_regex(r"[a-z][a-z0-9_]{0,12}", fullmatch=True), min_size=1, max_size=5, unique=True))
    lines = [
        f"name: {draw(st.from_regex(r'[a-z][a-z0-9_]{0,12}', fullmatch=True))}",
        "title: " + _quoted(draw(_TEXT)),
        "roles:",
    ]
    for name in names:
        kind = draw(st.sampled_from(["float", "int", "bool"]))
        unit = f", unit: {draw(st.sampled_from(['W', 'Wh', 'V', '1']))}" if kind == "float" else ""
        access = draw(st.sampled_from(["read", "read_write"]))
        lines.append(
            f"  {name}: {{type: {kind}{unit}, access: {access}, description: {_quoted(draw(_TEXT))},"
            f" sign: {_quoted(draw(_TEXT))}}}"
        )
    return "\n".join(lines) + "\n", names


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_profiles())
def test_fuzz_any_profile_renders_parsable_code_or_a_clean_error(tmp_path, case):
    from mdl.diagnostics import MdlError
    from mdl.formats.loading import load_resolved
    from mdl.targets import render
    from mdl.targets.profile import prepare

    text, _ = case
    path = tmp_path / "p.yaml"
    path.write_text(text, encoding="utf-8")
    resolved = load_resolved(EXAMPLES / "meter_b.xml", None)
    try:
        interface, _, _ = prepare(str(path), resolved, "meter_b.xml")
    except MdlError as exc:
        assert all(d.message for d in exc.diagnostics)
        return
    files = render(resolved, "meter_b.xml", "all", interface)
    for name, content in files.items():
        if name.endswith(".py"):
            compile(content, name, "exec")  # every text escaped: a docstring cannot end early
    for line in files[interface.header].splitlines():  # a comment never ends early, nor runs past its line
        assert "*/" not in line or (line.count("*/") == 1 and line.rstrip().endswith("*/")), line
