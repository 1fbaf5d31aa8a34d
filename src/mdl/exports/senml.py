"""`mdl export --to senml`: the WISE guide's capability document of a description, without a device
(the SenML shape itself lives with `mdl read --format senml`, in mdl.device.output)."""

from __future__ import annotations

from mdl.device.output import capability
from mdl.diagnostics import Diagnostic
from mdl.exchange.export import Export, Settings
from mdl.exchange.text import json_text
from mdl.resolver import ResolvedDevice


def export_capability(resolved: ResolvedDevice, settings: Settings) -> Export:
    """The capability document of every function: the same objects as `mdl read --format senml`, each
    entry n, u, min, max, asm and no value."""
    warnings: list[Diagnostic] = []
    if settings.connection is not None or settings.interval_given:
        warnings.append(
            Diagnostic(
                None,
                None,
                None,
                "the capability document describes the functions: the "
                "connection options and --interval are not part of it",
                "note",
            )
        )
    doc = capability([f.fn for f in resolved.functions], resolved.name)
    return Export(json_text(doc, indent=2), warnings=warnings)
