"""The engine exports of the examples as the golden files under tests/golden/exports hold them
(tests/unit/exports/test_export_golden.py compares them; scripts/regen_golden.py writes them with the drivers').

Regenerate after an intended change, then review the diff:
    python3 scripts/regen_golden.py                    (every golden file: these and the drivers)
    python3 tests/support/export_golden.py --regen     (these only)
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

if __name__ == "__main__":  # run as a script: tests/ holds the support package
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mdl.diagnostics import MdlError, error  # noqa: E402
from support.common import DATA, EXAMPLE, ROOT, TESTS  # noqa: E402
from support.run import run_mdl  # noqa: E402

GOLDEN = TESTS / "golden" / "exports"
CASES = {"temco_tstat": EXAMPLE / "temco_tstat.xml", "all_tables": DATA / "all_tables.xml"}
ARGS = ("--host", "192.0.2.10", "--port", "502", "--unit", "1", "--interval", "60")
# an engine on the serial line itself (ESPHome's UART) gets the line's settings instead of a TCP address
LINE_ARGS = {
    "esphome": ("--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E", "--unit", "1", "--interval", "60")
}
FILES = {
    "homeassistant": "homeassistant.yaml",
    "telegraf": "telegraf.toml",
    "esphome": "esphome.yaml",
    "thingsboard": "thingsboard.json",
    "nodered": "nodered.json",
    "wot": "wot.td.jsonld",
}


def render(path: Path) -> dict[str, str]:
    """Relative file name -> content of every export of `path`, and the warnings each printed."""
    source = path.relative_to(ROOT)  # messages name the file as a user in the repository would
    out: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "volttron"
        for engine in ("volttron", *FILES):
            extra = ("-o", folder) if engine == "volttron" else ()
            proc = run_mdl("export", source, "--to", engine, *LINE_ARGS.get(engine, ARGS), *extra, cwd=ROOT)
            if proc.returncode != 0:  # an error, not a traceback, for python3 scripts/regen_golden.py too
                said = "; ".join(proc.stderr.strip().splitlines())
                raise error(f"mdl export --to {engine} exited {proc.returncode}: {said}", source)
            # what it printed, less the `wrote FILE` lines (a temporary folder's name, new each run)
            said = [line for line in proc.stderr.splitlines(keepends=True) if not line.startswith("wrote ")]
            out[f"{engine}.warnings.txt"] = "".join(said)
            if engine == "volttron":
                for file in sorted(folder.iterdir()):
                    out[f"volttron/{file.name}"] = file.read_text(encoding="utf-8")
            else:
                out[FILES[engine]] = proc.stdout
    return out


def expected_files() -> dict[Path, str]:
    """Every export golden file (its path) -> the content it should have, rendered now."""
    return {GOLDEN / name / relative: text for name, path in CASES.items() for relative, text in render(path).items()}


def stale_files(expected: dict[Path, str]) -> list[Path]:
    """The files under tests/golden/exports that no export writes any more."""
    return sorted(p for p in GOLDEN.rglob("*") if p.is_file() and p not in expected) if GOLDEN.exists() else []


def regenerate() -> None:
    """Only the export golden files; `python3 scripts/regen_golden.py` writes them with the drivers'."""
    sys.path.insert(0, str(ROOT / "scripts"))
    from regen_golden import write_golden

    expected = expected_files()
    write_golden(expected, stale_files(expected))


if __name__ == "__main__":
    if sys.argv[1:] != ["--regen"]:
        sys.exit("usage: python3 tests/support/export_golden.py --regen")
    try:
        regenerate()
    except MdlError as exc:
        sys.exit(str(exc))
