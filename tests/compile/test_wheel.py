"""The built wheel installs into a new virtual environment with nothing else in it (dependencies come
from the package registry, as they do for a user) and every file-level command works from that
install, outside the checkout."""

from __future__ import annotations

import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

from support.common import DATA, ROOT, skip_or_fail

pytestmark = pytest.mark.exhaustive  # slow (sanitizer builds / a venv from the registry): CI runs it

HEAT_PUMP = ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml"


def _run(*cmd, cwd=None, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, cwd=cwd, timeout=timeout)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    proc = _run(sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", out, ROOT)
    if proc.returncode != 0:
        skip_or_fail(
            f"cannot build the wheel (the build backend comes from the package registry): {proc.stderr.strip()[-500:]}"
        )
    (whl,) = out.glob("mdl-*.whl")
    return whl


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """A venv without system site packages holding the wheel and what pip resolved for it; its bin folder."""
    env_dir = tmp_path_factory.mktemp("venv")
    venv.EnvBuilder(system_site_packages=False, with_pip=True).create(env_dir)
    bindir = env_dir / "bin"
    proc = _run(bindir / "python", "-m", "pip", "install", "-q", "--disable-pip-version-check", wheel)
    if proc.returncode != 0:
        skip_or_fail(f"cannot install the wheel's dependencies from the package registry: {proc.stderr.strip()[-500:]}")
    return bindir


def test_wheel_carries_schemas_and_templates(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    assert "mdl/schema/mdl-1.0.xsd" in names and "mdl/schema/mdl-0.9b.xsd" in names
    assert "mdl/targets/python/templates/device.py.j2" in names
    assert any(n.startswith("mdl/targets/cpp/templates/") for n in names)
    assert "mdl/py.typed" in names  # PEP 561: users' type checkers read mdl's annotations


def test_installed_wheel_runs_every_file_command(installed, tmp_path):
    work = tmp_path / "elsewhere"
    work.mkdir()
    mdl = installed / "mdl"
    where = _run(installed / "python", "-c", "import mdl; print(mdl.__file__)", cwd=work)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(installed.parent), where.stdout  # the install, not the checkout

    proc = _run(mdl, "validate", DATA / "all_tables.xml", cwd=work)
    assert proc.returncode == 0 and "valid MDL 1.0" in proc.stdout, proc.stderr
    proc = _run(mdl, "gen", DATA / "all_tables.xml", "--lang", "all", "-o", work, cwd=work)
    assert proc.returncode == 0, proc.stderr
    assert {"all_tables.py", "all_tables.h", "all_tables.cc"} <= {p.name for p in work.iterdir()}
    proc = _run(mdl, "import", HEAT_PUMP, "-o", work / "heat_pump.xml", cwd=work)
    assert proc.returncode == 0, proc.stderr
    proc = _run(mdl, "test", HEAT_PUMP, work / "heat_pump.xml", cwd=work)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.splitlines()[-1] == "4 passed, 0 failed"
    proc = _run(mdl, "gen", work / "heat_pump.xml", "--lang", "python", "-o", work, cwd=work)
    assert proc.returncode == 0, proc.stderr
    proc = _run(installed / "python", "-c", "import heat_pump; print(heat_pump.__name__)", cwd=work)
    assert proc.returncode == 0 and proc.stdout.strip() == "heat_pump", proc.stderr
