"""Generated Python drivers pass their users' linters (ruff's default rules, `mypy --strict` against
the real pymodbus), carry only the helpers and imports they use, and run on the lowest pymodbus
their header names."""

from __future__ import annotations

import ast
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from support.common import DATA, REFERENCE, ROOT, device_xml, fn_xml, skip_or_fail
from support.run import run_mdl

GOLDEN = sorted([*(ROOT / "tests" / "golden").glob("**/*.py"), ROOT / "examples" / "temco_tstat" / "temco_tstat.py"])
DEVICES = sorted([*DATA.glob("*.xml"), *(ROOT / "examples").glob("*/*.xml"), *(ROOT / "examples").glob("*/*.yaml")])
# fragments calling every helper of the fragment runtime, both ways (docs/fragments.md)
FRAGMENTS = (
    fn_xml("quotient", "10 11", format="UINT32", read_function_code="arg = 1000 / r1 + r2 % 7u;")
    + fn_xml(
        "shifted",
        "12 13",
        format="UINT32",
        read_function_code="arg = (int)(r1 &lt;&lt; r2) &gt;&gt; 3;",
        write_function_code="r1 = (uint32_t)(arg * 10.0f) &gt;&gt; 16; r2 = arg * 10;",
    )
    + fn_xml(
        "wrapped",
        "14",
        format="INT16",
        write_function_code="r1 = (int16_t)arg;",
        read_function_code="r1 = r1 - 40000; arg = (float)(int8_t)r1 / 3.0f;",
    )
)
REQUIRES = re.compile(r"^# Requires pymodbus >= (\d+\.\d+\.\d+), < 4\.$", re.M)


def _generate(source: Path, outdir: Path) -> Path:
    outdir.mkdir(parents=True)
    proc = run_mdl("gen", source, "--lang", "python", "-o", outdir)
    assert proc.returncode == 0, proc.stderr
    (driver,) = outdir.glob("*.py")
    return driver


@pytest.fixture(scope="module")
def drivers(tmp_path_factory) -> dict[str, Path]:
    """Module name -> file: the golden drivers and the driver of every test device (the Toolkit's
    reference files too, where they are present), each under a name of its own so that one mypy
    run checks them all."""
    root = tmp_path_factory.mktemp("lint")
    fragments = root / "fragments.xml"
    fragments.write_text(device_xml(FRAGMENTS, name="Fragments"), encoding="ascii")
    sources = [("device", path) for path in [*DEVICES, fragments]]
    sources += [("toolkit", path) for path in sorted(REFERENCE.glob("*.yaml"))]
    out = {}
    for kind, path in [("golden", path) for path in GOLDEN] + sources:
        if kind != "golden":
            path = _generate(path, root / "generated" / f"{kind}_{path.stem}")
        name = f"{kind}_{path.stem}".lower()
        assert name not in out, name
        out[name] = root / "lint" / f"{name}.py"
        out[name].parent.mkdir(exist_ok=True)
        shutil.copyfile(path, out[name])
    return out


def _tool(module: str) -> list[str]:
    """The command running a linter installed for this interpreter (mypy must see its pymodbus)."""
    if importlib.util.find_spec(module) is not None:
        return [sys.executable, "-m", module]
    found = shutil.which(module)
    if found is None:
        skip_or_fail(f"{module} is not installed (pip install '.[test]')")
    return [str(found)]


def _run(cmd: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=600)


def test_the_lint_set_covers_fragments_and_plain_registers(drivers):
    texts = {name: path.read_text() for name, path in drivers.items()}
    assert "device_all_tables" in texts and "device_temco_tstat" in texts
    helpers = re.findall(r"^def (_\w+)\(", texts["device_fragments"], re.M)
    assert {"_idiv", "_imod", "_f2i", "_store", "_shl", "_shr", "_wrap", "_f32", "_i2f32", "_fdiv"} <= set(helpers)
    assert "class FragmentDomainError(DeviceError, ArithmeticError):" in texts["device_fragments"]
    assert any("def _f2i(" in text and "except ArithmeticError" in text for text in texts.values())  # fragments
    assert any("# not implemented" in text for text in texts.values())


@pytest.mark.conformance("modbus-schema-reference")
def test_the_lint_set_covers_expressions(drivers):
    with_expressions = [name for name, path in drivers.items() if "def _x_regs(" in path.read_text()]
    assert len(with_expressions) >= 10, with_expressions


def test_ruff_default_rules_find_nothing(drivers):
    ruff = _tool("ruff")
    files = sorted(drivers.values())
    proc = _run(
        [*ruff, "check", "--isolated", "--no-cache", "--output-format", "concise", *map(str, files)], files[0].parent
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_mypy_strict_finds_nothing(drivers):
    mypy = _tool("mypy")
    files = sorted(drivers.values())
    proc = _run(
        [
            *mypy,
            "--config-file",
            "",
            "--strict",
            "--python-executable",
            sys.executable,
            "--cache-dir",
            str(files[0].parent / ".mypy_cache"),
            *map(str, files),
        ],
        files[0].parent,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f"Success: no issues found in {len(files)} source files" in proc.stdout


def _module_names(tree: ast.Module) -> tuple[list[str], list[str], Counter[str]]:
    """(top-level functions, imported modules, how often each name is read)."""
    functions = [node.name for node in tree.body if isinstance(node, ast.FunctionDef)]
    modules = []
    for node in tree.body:
        if isinstance(node, ast.Import):
            modules += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            modules.append(node.module or "")
    reads = Counter(node.id for node in ast.walk(tree) if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load))
    return functions, modules, reads


def test_every_helper_is_called_and_every_module_imported_once(drivers):
    for name, path in drivers.items():
        tree = ast.parse(path.read_text())
        functions, modules, reads = _module_names(tree)
        assert [f for f in functions if not reads[f]] == [], name
        assert [m for m, n in Counter(modules).items() if n > 1] == [], name
        imports_at_top = [type(node) in (ast.Import, ast.ImportFrom) for node in tree.body[1:]]  # after the docstring
        assert imports_at_top == sorted(imports_at_top, reverse=True), f"{name}: an import below other code"


def test_a_plain_device_carries_no_fragment_or_expression_runtime(write_device, tmp_path):
    path = write_device(fn_xml("count", "10", format="UINT16", access="read"), name="Plain")
    text = _generate(path, tmp_path / "out").read_text()
    assert "def _wrap(" not in text and "def _x_" not in text and "def _not_implemented(" not in text
    assert "import math" not in text and "import struct" not in text and "_write(" not in text
    assert "class PlainValues(TypedDict):\n" in text and "    count: int\n" in text


def test_read_all_is_typed_by_function_name(tmp_path):
    text = _generate(DATA / "all_tables.xml", tmp_path / "out").read_text()
    assert "    def read_all(self) -> AllTablesValues:" in text
    assert "    async def read_all(self) -> AllTablesValues:" in text
    for line in (
        "    voltage: float | None\n",
        "    label: str\n",
        "    pump: bool\n",
        "    mode: int\n",
        "    setpoint: float\n",
    ):
        assert line in text, line


def test_names_that_are_not_identifiers_key_a_functional_typed_dict(write_device, tmp_path):
    path = write_device(
        fn_xml("Room Temp", "10", format="INT16", multiplier="0.1") + fn_xml("class", "11"), name="Odd Names"
    )
    text = _generate(path, tmp_path / "out").read_text()
    assert "OddNamesValues = TypedDict(\"OddNamesValues\", {\n    'Room Temp': float,\n    'class': int,\n})" in text


def test_every_driver_names_its_lowest_pymodbus(drivers):
    versions = {name: REQUIRES.findall(path.read_text()) for name, path in drivers.items()}
    assert all(len(found) == 1 for found in versions.values()), versions
    assert len({found[0] for found in versions.values()}) == 1


@pytest.fixture(scope="session")
def lowest_pymodbus(tmp_path_factory) -> tuple[str, Path]:
    """(version, python): a virtual environment holding only the lowest pymodbus drivers support."""
    (version,) = REQUIRES.findall((ROOT / "tests" / "golden" / "all_tables" / "all_tables.py").read_text())
    venv = tmp_path_factory.mktemp("lowest") / "venv"
    made = subprocess.run([sys.executable, "-m", "venv", str(venv)], capture_output=True, text=True, timeout=300)
    if made.returncode != 0:
        skip_or_fail(f"cannot create a virtual environment: {made.stderr.strip()}")
    python = venv / ("Scripts" if os.name == "nt" else "bin") / "python"
    pip = subprocess.run(
        [
            str(python),
            "-m",
            "pip",
            "install",
            "--disable-pip-version-check",
            "--retries",
            "1",
            "--timeout",
            "30",
            f"pymodbus=={version}",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    if pip.returncode != 0:
        skip_or_fail(f"pip cannot install pymodbus=={version} from the package registry: {pip.stderr.strip()[-500:]}")
    return version, python


RUN_ON_LOWEST = """
import asyncio, json, sys
sys.path.insert(0, sys.argv[1])
import pymodbus
from pymodbus.client import AsyncModbusTcpClient, ModbusTcpClient
from all_tables import AllTables, AsyncAllTables

client = ModbusTcpClient("127.0.0.1", port=int(sys.argv[2]), timeout=5)
assert client.connect()
dev = AllTables(client)
before = dev.read_all()
dev.write_setpoint(19.0)
after = dev.read_setpoint()
client.close()

async def read_async():
    client = AsyncModbusTcpClient("127.0.0.1", port=int(sys.argv[2]), timeout=5)
    await client.connect()
    try:
        return await AsyncAllTables(client).read_all()
    finally:
        client.close()

print(json.dumps({"version": pymodbus.__version__, "before": before, "after": after,
                  "async": asyncio.run(read_async())}))
"""


def test_a_driver_runs_on_the_lowest_pymodbus(lowest_pymodbus, sim_factory, tmp_path):
    version, python = lowest_pymodbus
    driver = _generate(DATA / "all_tables.xml", tmp_path / "out")
    sim = sim_factory(DATA / "all_tables.xml", "--set", "setpoint=21.5", "--set", "label=Hall", "--set", "pump=1")
    proc = subprocess.run(
        [str(python), "-I", "-c", RUN_ON_LOWEST, str(driver.parent), str(sim.port)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["version"] == version
    assert result["before"]["setpoint"] == 21.5 and result["before"]["label"] == "Hall" and result["before"]["pump"]
    assert result["after"] == 19.0 and result["async"]["setpoint"] == 19.0
