#!/usr/bin/env python3
"""Regenerate every golden file: the drivers (tests/golden/all_tables, examples/temco_tstat) and the
engine exports (tests/golden/exports, rendered by tests/unit/exports/test_export_golden.py).

    python3 scripts/regen_golden.py

Only files whose content changes are written, all of them or none; an export golden file no export
writes any more is removed. Review the diff before committing it: every changed line is a change users
will see. Run it in mdl's virtual environment with the test dependencies (scripts/test installs them):
the exports are rendered by running `mdl export` as the tests do.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from mdl.diagnostics import MdlError  # noqa: E402  (after the sys.path line: runs from a checkout without an install)
from mdl.formats.mdl import load_device  # noqa: E402
from mdl.targets import render  # noqa: E402

# MDL source -> directory its generated files are pinned in
GOLDEN = {
    ROOT / "tests" / "data" / "all_tables.xml": ROOT / "tests" / "golden" / "all_tables",
    ROOT / "examples" / "temco_tstat" / "temco_tstat.xml": ROOT / "examples" / "temco_tstat",
}
LANGS = ("all",)  # every target; the C and C++ drivers share <stem>.h (mdl.targets.shared_header)


def expected_files() -> dict[Path, str]:
    """Every driver golden file (its path) -> the content `mdl gen` gives it now (tests/unit/targets/test_gen.py)."""
    out = {}
    for source, directory in GOLDEN.items():
        device = load_device(source)
        for lang in LANGS:
            for name, text in render(device, source.name, lang).items():
                out[directory / name] = text
    return out


def write_golden(expected: dict[Path, str], stale: list[Path]) -> None:
    """Write the files whose content changed, all or none (mdl.fileio), then remove the stale ones."""
    from mdl.fileio import all_or_none, would_change, write_atomic

    changed = [path for path, text in expected.items() if would_change(path, text)]
    with all_or_none():
        for path in changed:
            write_atomic(path, expected[path])
    for path in changed:
        print(f"wrote {path.relative_to(ROOT)}")
    for path in stale:
        path.unlink()
        print(f"removed {path.relative_to(ROOT)}")


def main() -> int:
    sys.path.insert(0, str(ROOT / "tests"))
    from support import export_golden  # the export golden files, rendered as their test renders them

    try:
        exports = export_golden.expected_files()
        write_golden({**expected_files(), **exports}, export_golden.stale_files(exports))
    except MdlError as exc:
        print(exc, file=sys.stderr)
        return exc.exit_code
    return 0


if __name__ == "__main__":
    sys.exit(main())
