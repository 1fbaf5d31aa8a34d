"""The engine exports of the examples, pinned byte for byte (and the warnings they print).

Regenerate after an intended change, then review the diff:
    python3 scripts/regen_golden.py                    (every golden file: these and the drivers)
    python3 tests/support/export_golden.py --regen     (these only)
"""

from __future__ import annotations

import pytest

from support.export_golden import CASES, GOLDEN, render


@pytest.mark.parametrize("name", sorted(CASES))
def test_exports_match_the_golden_files(name):
    got = render(CASES[name])
    folder = GOLDEN / name
    on_disk = sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())
    assert on_disk == sorted(got), "regenerate: python3 tests/support/export_golden.py --regen"
    for relative, text in got.items():
        assert (folder / relative).read_text(encoding="utf-8") == text, (
            f"{name}/{relative} changed; if intended: python3 tests/support/export_golden.py --regen"
        )
