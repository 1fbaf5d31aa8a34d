"""WISE-Agent `Modbus.ini` (SPEC 7): read into the document model (`read`) and written back in the shipped
agent's form (`write`); `sections` holds the format's vocabulary, `lua` the arithmetic its Lua column may carry.
`guess` is how mdl.formats tells a WISE-Agent file from its sections."""

from __future__ import annotations


def guess(head: str) -> bool:
    """Whether the start of a file is a WISE-Agent Modbus.ini: an INI with a `[Platform]` section."""
    if "[" not in head:
        return False  # before the import: commands that read no INI start without the format's words
    from mdl.formats.wise.sections import PLATFORM

    section = f"[{PLATFORM.lower()}]"
    return any(line.strip().lower() == section for line in head.splitlines())
