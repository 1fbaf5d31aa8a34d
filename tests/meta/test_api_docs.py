"""docs/api.md's Python examples run, in order, in one namespace, in a scratch folder holding a copy of
examples/, with the thermostat its ```sh block serves started on a free port (its 5020 is that port)."""

from __future__ import annotations

import os
import re
import shutil

from support.common import ROOT
from support.devices import Sim

API_DOC = ROOT / "docs" / "api.md"
_BLOCK = re.compile(r"^```python\n(.*?)^```$", re.S | re.M)


def python_blocks() -> list[str]:
    return _BLOCK.findall(API_DOC.read_text())


def test_the_api_doc_has_an_example_of_every_call():
    import mdl

    code = "\n".join(python_blocks())
    for name in mdl.__all__:
        assert f"mdl.{name}" in code, f"docs/api.md shows no example of mdl.{name}"


def test_the_api_doc_examples_run(tmp_path, capsys):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    sim = Sim(tmp_path / "examples" / "temco_tstat" / "temco_tstat.xml")
    before = os.getcwd()
    namespace: dict[str, object] = {"__name__": "api_doc"}
    try:
        os.chdir(tmp_path)
        for number, block in enumerate(python_blocks(), 1):
            code = compile(block.replace("5020", str(sim.port)), f"docs/api.md python block {number}", "exec")
            exec(code, namespace)  # noqa: S102 - the documentation's own examples
    finally:
        os.chdir(before)
        assert sim.stop() == 0
    out = capsys.readouterr().out
    assert "temco_tstat.py" in out and "'occupied_setpoint': 22.5" in out
