"""What the tests of generated drivers share: the generated Python driver's device class, and (for the compiled
drivers) the values served and the comparisons with mdl read."""

from __future__ import annotations

from pathlib import Path

from mdl.model.names import stem
from mdl.targets import render
from support.common import import_generated


def python_device(device, workdir: Path):
    name = f"{stem(device.name)}.py"
    (workdir / name).write_text(render(device, "ref.xml", "python")[name])
    module = import_generated(workdir / name, f"tk_{stem(device.name)}")
    return next(
        getattr(module, n)
        for n in module.__all__
        if not n.startswith("Async") and n[0].isupper() and not n.endswith("Error")
    )
