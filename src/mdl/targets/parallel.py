"""Several targets of one large device rendered at once: `mdl gen --lang all` forks a child per target
after the first, which renders while this process renders the first (docs/performance.md), through
mdl.forks: the output is the same bytes as rendering one target after another, an error included.
Used where mdl.forks is possible and the device is large enough (PARALLEL_MIN functions) for the fork
to pay. The children inherit the resolved device, warmed first so that none works it out again.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TYPE_CHECKING

from mdl.forks import cpus, each, single_threaded

if TYPE_CHECKING:
    from mdl.resolver import ResolvedDevice

Render = Callable[[str], dict[str, str]]  # target name -> file name -> text

# below this many functions a target renders in well under 0.1 s: a fork would cost more than it saves
PARALLEL_MIN = 1000


def worth_it(device: ResolvedDevice, names: list[str]) -> bool:
    if len(names) < 2 or len(device.functions) < PARALLEL_MIN or not hasattr(os, "fork"):
        return False
    return cpus() > 1 and single_threaded()


def warm(device: ResolvedDevice) -> None:
    """Work out once, before the fork, what every target asks of the device (read plan, buffer slots,
    IR shapes, decode order), so that no child works it out again."""
    device.plan  # noqa: B018 (cached properties: reading them is the work)
    device.readable  # noqa: B018
    for f in device.functions:
        f.decode_shape  # noqa: B018
        f.encode_shape  # noqa: B018
        f.deps  # noqa: B018
        f.runs  # noqa: B018 (every target asks each function's runs)
        if f.fn.readable:
            device.slots_of(f)
        if f.deps:
            device.closure([f.name])


def render_all(device: ResolvedDevice, names: list[str], render: Render) -> list[dict[str, str]]:
    """Each named target's files, in the order of `names`."""
    if not worth_it(device, names):
        return [render(name) for name in names]
    warm(device)
    return each(names, render)
