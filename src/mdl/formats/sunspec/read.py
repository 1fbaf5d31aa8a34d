"""`mdl import --from sunspec MODEL... [--base] [--repeat]` (SPEC 12): model ids or JSON paths -> the
document model of their chain, model 1 (common) first when the list lacks it.

`import_chain` is what the command calls; `read_sunspec` is the format's reader of one model JSON file
(mdl.formats.FORMATS), the chain of model 1 and that model at the default base.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from mdl.diagnostics import Diagnostic, error
from mdl.formats.sunspec.build import BASES, build_chain
from mdl.formats.sunspec.models import ModelDef, load_model

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.model import Device

DEFAULT_REPEAT = 1
COMMON = 1


def import_chain(models: Sequence[str], base: int | None = None, repeat: int | None = None) -> Device:
    """The device of the chain of `models` (ids or JSON paths, in that order) at `base` (default 40000),
    each repeating group unrolled `repeat` times (default 1); model 1 first when absent (a note says so,
    as it says the base and repeat count it took)."""
    if not models:
        raise error("give at least one SunSpec model id or model JSON file")
    loaded: list[tuple[ModelDef, int]] = []
    for spec in models:
        loaded.append((load_model(spec), DEFAULT_REPEAT if repeat is None else repeat))
    notes: list[Diagnostic] = []
    if all(int(m["id"]) != COMMON for m, _ in loaded):
        loaded.insert(0, (load_model(str(COMMON)), 0))
        notes.append(
            Diagnostic(None, None, None, "model 1 (common) added first: every SunSpec chain starts with it", "note")
        )
    at = BASES[0] if base is None else base
    if base is None:
        notes.append(Diagnostic(None, None, None, f"the chain starts at {at} (give --base for 0 or 50000)", "note"))
    elif base not in BASES:
        where = ", ".join(map(str, sorted(BASES)))
        notes.append(
            Diagnostic(
                None,
                None,
                None,
                f"the chain starts at {base}: SunSpec clients look for its marker at {where} only, so they will "
                "not find this device without being told where",
                "warning",
            )
        )
    device = build_chain(loaded, at)
    if repeat is None and any(_repeats(m["group"]) for m, _ in loaded):
        notes.append(
            Diagnostic(None, None, None, f"repeating groups unrolled {DEFAULT_REPEAT} time (give --repeat N)", "note")
        )
    device.notes[:0] = notes
    return device


def chain_device(chain: Sequence[tuple[int | str, int]], base: int = BASES[0]) -> Device:
    """The device of a chain given as (model id or JSON path, repeat count) pairs at `base`, as found
    (mdl discover --sunspec): no model added, nothing guessed."""
    return build_chain([(load_model(str(model)), repeat) for model, repeat in chain], base)


def _repeats(group: dict[str, object]) -> bool:
    groups = group.get("groups", [])
    return isinstance(groups, list) and any("count" in g or _repeats(g) for g in groups)


def read_sunspec(path: StrPath) -> Device:
    """The format's reader: the chain of model 1 and the model in the JSON file `path`."""
    return import_chain([str(path)])
