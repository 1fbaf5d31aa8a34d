"""The built wheel carries schema/ and templates/: `mdl gen` and `mdl validate` work from an install."""

from __future__ import annotations

import subprocess
import sys
import venv

import pytest
from conftest import DATA, ROOT


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                           "-w", str(out), str(ROOT)], capture_output=True, text=True)
    if proc.returncode != 0 and "No module named 'hatchling'" in proc.stderr:
        proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out), str(ROOT)],
                              capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    (whl,) = out.glob("mdl-*.whl")
    return whl


def test_installed_wheel_generates_and_validates(wheel, tmp_path):
    import zipfile

    names = zipfile.ZipFile(wheel).namelist()
    assert "mdl/schema/mdl-1.0.xsd" in names and "mdl/schema/mdl-0.9b.xsd" in names
    assert "mdl/templates/python/device.py.j2" in names
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(system_site_packages=True, with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    with zipfile.ZipFile(wheel) as zf:  # install the wheel's files as pip would, without the network
        for name in names:
            if name.startswith("mdl/"):
                zf.extract(name, site)
    work = tmp_path / "elsewhere"
    work.mkdir()
    code = ("import sys; from mdl.cli import main; sys.argv = ['mdl'] + sys.argv[1:]; main()")
    proc = subprocess.run([str(py), "-I", "-c", code, "gen", str(DATA / "all_tables.xml"), "--lang", "python",
                           "-o", str(work)], capture_output=True, text=True, cwd=work)
    assert proc.returncode == 0, proc.stderr
    assert (work / "all_tables.py").exists()
    proc = subprocess.run([str(py), "-I", "-c", "import mdl, sys; print(mdl.__file__)"], capture_output=True,
                          text=True, cwd=work)
    assert proc.stdout.startswith(site), proc.stdout  # the installed copy, not the checkout
    proc = subprocess.run([str(py), "-I", "-c", code, "validate", str(DATA / "all_tables.xml")],
                          capture_output=True, text=True, cwd=work)
    assert proc.returncode == 0, proc.stderr
