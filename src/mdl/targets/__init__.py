"""`mdl gen`: the target registry, and drivers written only when their content changes.

A target is a folder here (python/, cpp/, c/) holding its emitter (`emit.py`, whose `TARGET`
registers it), its Jinja templates (`templates/`) and the runtime files its drivers carry. Adding a
language is adding a folder and one entry to `TARGETS` (docs/architecture.md walks through it).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from mdl.registry import Registry

if TYPE_CHECKING:  # imported where used: the CLI reads the registry's names at every start
    from mdl.diagnostics import Diagnostic
    from mdl.model import Device
    from mdl.resolver import ResolvedDevice
    from mdl.targets.base import Target
    from mdl.targets.profile import Interface


@dataclass(frozen=True)
class TargetEntry:
    """A registered target: its `--lang` name, what it writes, and the module holding its TARGET
    (imported only when the target renders, so that `mdl --help` and `mdl sim` start fast)."""

    name: str
    summary: str
    module: str

    def load(self) -> Target:
        found: Target = importlib.import_module(self.module).TARGET
        return found


# in the order `--lang all` writes them
TARGETS: Registry[TargetEntry] = Registry(
    TargetEntry("python", "<stem>.py, a module over pymodbus with sync and asyncio classes", "mdl.targets.python.emit"),
    TargetEntry("cpp", "<stem>.h/<stem>.cc, C++17 on libmodbus", "mdl.targets.cpp.emit"),
    TargetEntry("c", "<stem>.h/<stem>.c, C99 on libmodbus", "mdl.targets.c.emit"),
)


def names() -> list[str]:
    """The registered targets, in `--lang all` order."""
    return TARGETS.names()


def summaries() -> list[str]:
    """`name: what it writes` for each registered target."""
    return TARGETS.summaries()


def target(name: str) -> Target:
    return TARGETS[name].load()


def render(
    device: ResolvedDevice | Device, source_name: str, lang: str, interface: Interface | None = None
) -> dict[str, str]:
    """File name -> content for the chosen target, or for every target with lang "all". A model
    not yet resolved is resolved here, once for every target. The files carry the stamp of this
    generation (templating.stamp): a C or C++ source compiles only with the header of its run.
    The targets of a large device render at once (mdl.targets.parallel).
    With a profile's `interface` (mdl.targets.profile), each target adds it and its shared files."""
    from mdl.resolver import ResolvedDevice, resolve
    from mdl.targets.parallel import render_all
    from mdl.targets.templating import stamp

    if not isinstance(device, ResolvedDevice):
        device = resolve(device, source_name)
    resolved = device
    chosen = names() if lang == "all" else [lang]
    out: dict[str, str] = {}
    modules = {name: target(name) for name in chosen}  # imported before any fork
    for files in render_all(resolved, chosen, lambda name: modules[name].render(resolved, source_name, interface)):
        for file_name, text in files.items():
            out[file_name] = shared_header(out[file_name], text) if file_name in out else text
    return stamp(out)


def shared_header(cpp: str, c: str) -> str:
    """One `<stem>.h` for the C++ and the C driver (SPEC 5 names both `<stem>.h`): C++ code sees the
    C++ driver's declarations, C code the C driver's (docs/c-api.md)."""
    first = cpp.split("\n", 1)[0]
    return (
        f"{first}\n// With --lang all, this header serves both drivers: C++ code (<stem>.cc) sees the C++17\n"
        f"// class, C code (<stem>.c) the C99 functions.\n#ifdef __cplusplus\n{cpp}#else\n{c}#endif\n"
    )


def notes(device: ResolvedDevice, source: Path) -> list[Diagnostic]:
    """What `mdl gen` tells about the names it chose: a stem shortened (mdl.model.names, rule 3b)."""
    from mdl.diagnostics import Diagnostic
    from mdl.model.names import STEM_LIMIT, stem_shortened
    from mdl.resolver.checks import position

    if not stem_shortened(device.name):
        return []
    line, col = position(device.device, "name")
    return [
        Diagnostic(
            str(source),
            line,
            col,
            f"the device name makes an identifier longer than {STEM_LIMIT} "
            f"characters: the generated files are named {device.stem}.* (and the class "
            f"{device.class_name})",
            "note",
        )
    ]


def generate(
    device: ResolvedDevice, source: Path, lang: str, outdir: Path, check: bool, interface: Interface | None = None
) -> list[Path]:
    from mdl.targets.templating import require_dir, write_outputs

    require_dir(outdir)
    files = render(device, source.name, lang, interface)
    return write_outputs({outdir / name: text for name, text in files.items()}, check)
