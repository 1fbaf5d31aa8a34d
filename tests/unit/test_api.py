"""`import mdl` as a library (SPEC 16): the surface is exactly `mdl.__all__`, and nothing but those names
takes a vendor's table and INI through validate, generate, `mdl sim`, a Session's reads and writes and
an export, without printing, exiting or changing logging."""

from __future__ import annotations

import asyncio
import logging
import shutil
import subprocess
import sys

import pytest

import mdl
from support.common import EXAMPLE, ROOT
from support.devices import Sim

SURFACE = ["Diagnostic", "MdlError", "Session", "export", "generate", "load", "resolve", "validate"]


def test_the_surface_is_exactly_the_spec():
    assert sorted(mdl.__all__) == SURFACE
    for name in SURFACE:
        assert getattr(mdl, name) is not None
    assert [name for name in dir(mdl) if not name.startswith("_")] == SURFACE


def test_the_names_stay_the_calls_after_every_module_is_imported():
    """`mdl.resolve` is the call, not a package of that name imported later (the import system would set
    the package's attribute to the module)."""
    code = (
        "import pkgutil, importlib, mdl\n"
        "for m in pkgutil.walk_packages(mdl.__path__, 'mdl.'):\n"
        "    if m.name != 'mdl.__main__':\n"
        "        importlib.import_module(m.name)\n"
        "shadowed = [n for n in mdl.__all__ if not callable(getattr(mdl, n))]\n"
        "assert not shadowed, shadowed\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_import_mdl_is_cheap():
    code = (
        "import sys, mdl; heavy = {'lxml', 'pymodbus', 'jinja2', 'click'} & set(sys.modules); assert not heavy, heavy"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr


def _levels() -> dict[str, int]:
    return {name: logging.getLogger(name).level for name in ("", "pymodbus", "pymodbus.logging")}


def test_table_to_device_through_the_public_names_only(tmp_path, capsys):
    shutil.copy(EXAMPLE / "temco_tstat.csv", tmp_path)
    shutil.copy(EXAMPLE / "temco_tstat.ini", tmp_path)
    levels = _levels()

    document = mdl.load(tmp_path / "temco_tstat.csv", ini=tmp_path / "temco_tstat.ini")
    assert mdl.validate(document) == []
    device = mdl.resolve(document)
    written = mdl.generate(device, "python", tmp_path / "drivers")
    assert [p.name for p in written] == ["temco_tstat.py"]
    assert mdl.generate(device, "python", tmp_path / "drivers") == []  # unchanged: not written again

    xml = tmp_path / "tstat.xml"
    warnings = mdl.export(device, "xif", tmp_path / "tstat.mod")
    assert (tmp_path / "tstat.mod").read_text().startswith("#filetype")
    assert all(isinstance(w, mdl.Diagnostic) for w in warnings)
    mdl.export(device, "esphome", tmp_path / "node.yaml", flow_control_pin="GPIO4")  # as --flow-control-pin
    assert "flow_control_pin: GPIO4" in (tmp_path / "node.yaml").read_text()
    with pytest.raises(mdl.MdlError, match="flow_control_pin: 'GPIO4: x' is no pin"):
        mdl.export(device, "esphome", tmp_path / "bad.yaml", flow_control_pin="GPIO4: x")
    assert not (tmp_path / "bad.yaml").exists()
    shutil.copy(EXAMPLE / "temco_tstat.xml", xml)
    sim = Sim(xml)
    try:
        with mdl.Session(device, f"tcp://127.0.0.1:{sim.port}") as session:
            session.write(occupied_setpoint=22.5, fan_speed=2)
            values = session.read("occupied_setpoint", "fan_speed")
            assert values == {"occupied_setpoint": 22.5, "fan_speed": 2}
            everything = session.read()
            assert set(everything) == {fn.name for fn in document.functions if fn.readable}

        async def twins() -> dict:
            async with mdl.Session(device, f"tcp://127.0.0.1:{sim.port}", unit=1) as session:
                await session.awrite(unoccupied_setpoint=18)
                return await session.aread("unoccupied_setpoint")

        assert asyncio.run(twins()) == {"unoccupied_setpoint": 18.0}
        with pytest.raises(mdl.MdlError, match="read-only"):
            mdl.Session(device, f"tcp://127.0.0.1:{sim.port}").write(room_temperature=1)
    finally:
        assert sim.stop() == 0
    warnings = mdl.export(device, "volttron", tmp_path / "volttron", connection=f"tcp://127.0.0.1:{sim.port}")
    assert sorted(p.name for p in (tmp_path / "volttron").iterdir()) == [
        "temco_tstat.config",
        "temco_tstat.csv",
        "temco_tstat_map.csv",
    ]
    assert warnings  # VOLTTRON cannot carry every function: said, not printed

    assert capsys.readouterr() == ("", "")  # the library never prints
    assert _levels() == levels  # nor changes logging


def test_errors_carry_their_place(tmp_path):
    broken = tmp_path / "broken.xml"
    broken.write_text((EXAMPLE / "temco_tstat.xml").read_text().replace("<name>", "<nom>", 1))
    problems = mdl.validate(broken)
    assert problems and problems[0].file == str(broken) and problems[0].line == 3
    with pytest.raises(mdl.MdlError) as raised:
        mdl.load(broken)
    assert raised.value.diagnostics[0].line == 3
    with pytest.raises(mdl.MdlError, match="unknown language"):
        mdl.generate(mdl.resolve(mdl.load(EXAMPLE / "temco_tstat.xml")), "cobol", tmp_path)


def test_a_silent_device_is_an_error_not_an_exit():
    device = mdl.resolve(mdl.load(EXAMPLE / "temco_tstat.xml"))
    with pytest.raises(mdl.MdlError) as raised:
        mdl.Session(device, "tcp://127.0.0.1:1?timeout=0.2&retries=0").read("room_temperature")
    assert "127.0.0.1:1" in raised.value.diagnostics[0].message


def test_load_reads_every_kind_of_description(tmp_path):
    root = ROOT / "examples"
    assert mdl.load(root / "xif_meter" / "meter.mod").functions
    assert mdl.load(root / "wise_4012e" / "Modbus.ini").functions
    assert mdl.load(root / "toolkit_heat_pump" / "heat_pump.yaml").functions
    assert mdl.load(EXAMPLE / "temco_tstat.ini").functions  # an INI naming its table
