"""The engine exports of the examples, pinned byte for byte (and the warnings they print).

Regenerate after an intended change, then review the diff:
    python3 tests/test_export_golden.py --regen
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import DATA, EXAMPLE, ROOT, run_mdl  # noqa: E402

GOLDEN = Path(__file__).resolve().parent / "golden" / "exports"
CASES = {"temco_tstat": EXAMPLE / "temco_tstat.xml", "all_tables": DATA / "all_tables.xml"}
ARGS = ("--host", "192.0.2.10", "--port", "502", "--unit", "1", "--interval", "60")


def render(path: Path) -> dict[str, str]:
    """Relative file name -> content of every export of `path`, and the warnings each printed."""
    source = path.relative_to(ROOT)  # messages name the file as a user in the repository would
    out: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "volttron"
        for engine in ("volttron", "homeassistant", "telegraf"):
            extra = ("-o", folder) if engine == "volttron" else ()
            proc = run_mdl("export", source, "--to", engine, *ARGS, *extra, cwd=ROOT)
            assert proc.returncode == 0, proc.stderr
            out[f"{engine}.warnings.txt"] = proc.stderr
            if engine == "volttron":
                for file in sorted(folder.iterdir()):
                    out[f"volttron/{file.name}"] = file.read_text(encoding="utf-8")
            else:
                out[{"homeassistant": "homeassistant.yaml", "telegraf": "telegraf.toml"}[engine]] = proc.stdout
    return out


@pytest.mark.parametrize("name", sorted(CASES))
def test_exports_match_the_golden_files(name):
    got = render(CASES[name])
    folder = GOLDEN / name
    on_disk = sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())
    assert on_disk == sorted(got), "regenerate: python3 tests/test_export_golden.py --regen"
    for relative, text in got.items():
        assert (folder / relative).read_text(encoding="utf-8") == text, (
            f"{name}/{relative} changed; if intended: python3 tests/test_export_golden.py --regen")


def regenerate() -> None:
    for name, path in CASES.items():
        folder = GOLDEN / name
        for old in sorted(folder.rglob("*"), reverse=True) if folder.exists() else ():
            old.unlink() if old.is_file() else old.rmdir()
        for relative, text in render(path).items():
            target = folder / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(text, encoding="utf-8")
        print(f"wrote {folder.relative_to(ROOT)}")


if __name__ == "__main__":
    if sys.argv[1:] != ["--regen"]:
        sys.exit("usage: python3 tests/test_export_golden.py --regen")
    regenerate()
