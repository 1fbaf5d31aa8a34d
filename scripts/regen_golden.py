#!/usr/bin/env python3
"""Regenerate the golden files that pin generated output: tests/golden/ and the examples' drivers.

    python3 scripts/regen_golden.py

Review the diff before committing it: every changed line is a change users will see.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from mdl.sources.mdlxml import load_device  # noqa: E402
from mdl.targets import render  # noqa: E402  (after the sys.path line: runs from a checkout without an install)

# MDL source -> directory its generated files are pinned in
GOLDEN = {
    ROOT / "tests" / "data" / "all_tables.xml": ROOT / "tests" / "golden" / "all_tables",
    ROOT / "examples" / "temco_tstat" / "temco_tstat.xml": ROOT / "examples" / "temco_tstat",
}
LANGS = ("all",)  # every target; the C and C++ drivers share <stem>.h (mdl.targets.shared_header)


def expected_files() -> dict[Path, str]:
    out = {}
    for source, directory in GOLDEN.items():
        device = load_device(source)
        for lang in LANGS:
            for name, text in render(device, source.name, lang).items():
                out[directory / name] = text
    return out


def main() -> int:
    for path, text in expected_files().items():
        path.parent.mkdir(parents=True, exist_ok=True)
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
            print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
