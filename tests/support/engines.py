"""The polling engines' own code, each in a virtual environment of its own, for the export proofs (SPEC 11).

An engine's pins never touch mdl's: each engine is installed from PyPI with pip into a venv under
$MDL_ENGINE_CACHE (default ~/.cache/mdl-engines/), named by the engine, its pinned versions and the Python
version, so a later run (or a later machine given the same cache) reuses it. A venv is built in a
folder that carries a marker file only once pip and an import check succeeded: a venv without it
(an interrupted install) is made again, never used.
Several test processes asking at once wait for one another (a file lock).

`python3 tests/support/engines.py [NAME...]` creates them ahead of a test run (the install takes minutes).
Versions (checked with `pip index versions`, Python 3.11):
- VOLTTRON: volttron-lib-modbustk-driver 0.1.2rc0 (the newest release; PyPI has only pre-releases) with
  volttron-lib-base-driver 0.2.1rc2, volttron 10.0.5rc4 and modbus-tk 1.1.5 as pip resolves them, and six
  (its client imports six without declaring it).
- Home Assistant: homeassistant 2024.3.3, the newest release that installs on Python 3.11 (2024.4 needs 3.12),
  with pymodbus 3.6.6, the version its modbus integration's manifest requires (Home Assistant installs an
  integration's requirements when it loads it, not with the core package).
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
import venv
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Engine:
    name: str
    requirements: tuple[str, ...]  # pip requirement specifiers, every one pinned
    pre: bool = False  # allow pre-releases (VOLTTRON's modular drivers are published only as such)
    probe: str = ""  # Python run in the venv to check the install

    @property
    def key(self) -> str:
        pins = "\n".join((*self.requirements, f"pre={self.pre}", sys.version.split()[0]))
        digest = hashlib.sha256(pins.encode()).hexdigest()[:12]
        return f"{self.name}-py{sys.version_info[0]}.{sys.version_info[1]}-{digest}"


VOLTTRON = Engine(
    "volttron-modbustk",
    # six: the driver's client imports it without declaring it; the rest pinned as pip resolved them
    (
        "volttron-lib-modbustk-driver==0.1.2rc0",
        "volttron-lib-base-driver==0.2.1rc2",
        "volttron==10.0.5rc4",
        "modbus-tk==1.1.5",
        "six==1.17.0",
    ),
    pre=True,
    probe="import volttron.driver.interfaces.modbus_tk.modbus_tk",
)
HOMEASSISTANT = Engine(
    "homeassistant",
    ("homeassistant==2024.3.3", "pymodbus==3.6.6"),  # an integration's requirements (its manifest's) come apart
    probe="import homeassistant.components.modbus",
)
ENGINES = {engine.name: engine for engine in (VOLTTRON, HOMEASSISTANT)}


def cache_root() -> Path:
    configured = os.environ.get("MDL_ENGINE_CACHE")
    return Path(configured) if configured else Path.home() / ".cache" / "mdl-engines"


class EngineUnavailable(Exception):
    """The engine could not be installed here (no registry, no matching release): the reason."""


def python_of(venv_dir: Path) -> Path:
    return venv_dir / "bin" / "python"


def engine_python(engine: Engine, *, timeout: float = 1800) -> Path:
    """The Python of the engine's venv, created and installed if it is not cached yet."""
    root = cache_root()
    root.mkdir(parents=True, exist_ok=True)
    final = root / engine.key
    with open(root / f"{engine.key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if (final / "mdl-engine-ok").is_file():
            return python_of(final)
        shutil.rmtree(final, ignore_errors=True)
        venv.EnvBuilder(with_pip=True, clear=True).create(final)
        python = python_of(final)
        command = [
            str(python),
            "-m",
            "pip",
            "install",
            "--no-input",
            "--disable-pip-version-check",
            *(["--pre"] if engine.pre else []),
            *engine.requirements,
        ]
        try:
            proc = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise EngineUnavailable(f"pip install {' '.join(engine.requirements)} took over {timeout:.0f} s") from None
        if proc.returncode != 0:
            tail = "\n".join((proc.stdout + proc.stderr).strip().splitlines()[-15:])
            raise EngineUnavailable(f"pip install {' '.join(engine.requirements)} failed:\n{tail}")
        if engine.probe:
            check = subprocess.run([str(python), "-c", engine.probe], capture_output=True, text=True)
            if check.returncode != 0:
                raise EngineUnavailable(f"{engine.name} installed but does not import: {check.stderr.strip()[-800:]}")
        frozen = subprocess.run([str(python), "-m", "pip", "freeze"], capture_output=True, text=True)
        (final / "mdl-engine-freeze.txt").write_text(frozen.stdout)
        (final / "mdl-engine-ok").write_text("\n".join(engine.requirements) + "\n")
        return python_of(final)


def installed_version(python: Path, distribution: str) -> str:
    out = subprocess.run(
        [str(python), "-c", f"import importlib.metadata as m; print(m.version({distribution!r}))"],
        capture_output=True,
        text=True,
        check=True,
    )
    return out.stdout.strip()


def require(engine: Engine) -> Path:
    """The engine's Python for a test; skipped with the reason when it cannot be installed (a failure in CI)."""
    return installed(engine.name, lambda: engine_python(engine))


def installed(name: str, install: Callable[[], Path]) -> Path:
    """What `install` gives (an engine's Python or folder) for a test of the engines tier; the test skipped
    with the reason when the engine cannot be installed (a failure in CI)."""
    from support.common import skip_or_fail
    from support.tiers import require_tier

    require_tier("engines", f"the {name} installation")
    try:
        return install()
    except EngineUnavailable as exc:
        skip_or_fail(f"{name} is not available: {exc}")
        raise AssertionError("unreachable") from None


if __name__ == "__main__":
    for name in sys.argv[1:] or list(ENGINES):
        python = engine_python(ENGINES[name])
        print(f"{name}: {python}")
