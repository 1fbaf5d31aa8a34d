"""The user guide's Makefile rule (docs/user-guide.md, "mdl gen"), run as written by make: `mdl gen` runs
once after the description changes and not on every `make` after (issue 37: gen keeps an unchanged
file's date, so a rule on the driver file itself ran gen on every make)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time

from support.common import EXAMPLE, ROOT, skip_or_fail


def _make(folder, path_dir) -> str:
    env = {**os.environ, "PATH": f"{path_dir}{os.pathsep}{os.environ.get('PATH', '')}"}
    proc = subprocess.run(["make", "drivers/temco_tstat.py"], cwd=folder, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def test_the_guides_makefile_rule_runs_gen_once_per_change(tmp_path):
    if shutil.which("make") is None:
        skip_or_fail("make is not installed")
    guide = (ROOT / "docs" / "user-guide.md").read_text(encoding="utf-8")
    (rule,) = re.findall(r"```make\n(.*?)```", guide, re.S)
    (tmp_path / "Makefile").write_text(rule)
    shutil.copy(EXAMPLE / "temco_tstat.xml", tmp_path)
    shim = tmp_path / "bin"
    shim.mkdir()
    (shim / "mdl").write_text(f'#!/bin/sh\nexec "{sys.executable}" -m mdl "$@"\n')
    (shim / "mdl").chmod(0o755)
    assert "mdl gen" in _make(tmp_path, shim)  # the first make generates the driver
    assert (tmp_path / "drivers" / "temco_tstat.py").is_file()
    assert "mdl gen" not in _make(tmp_path, shim)  # and the second has nothing to do
    time.sleep(0.05)  # the edit is newer than the stamp, whatever the file system's clock grain
    xml = tmp_path / "temco_tstat.xml"
    xml.write_text(xml.read_text().replace("</name>", "</name>\n  <!-- a comment -->", 1))  # the driver stays
    assert "mdl gen" in _make(tmp_path, shim)  # a changed description runs gen again
    assert "mdl gen" not in _make(tmp_path, shim)  # once: its unchanged driver kept its date
