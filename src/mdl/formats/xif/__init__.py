"""SmartServer Modbus XIF (`.mod`): `read.read_xif` (import) and `write.export_xif` (export).
`columns` holds the format's words (column headings current and pre-3.2, native types, function
codes, write enable values), `records` its CSV records with positions, `rows` a datapoint row read
into a function, `scaling` the two-point and A'/B'/C' scaling both ways. docs/xif.md has the mapping.
`guess` is how mdl.formats tells an XIF file from its first line."""

from __future__ import annotations


def guess(head: str) -> bool:
    """Whether the start of a file is XIF: a first line `#filetype,Modbus_xif` (any case, spaces ignored)."""
    first = head.lstrip().split("\n", 1)[0].strip().lower().replace(" ", "")
    if not first.startswith("#"):
        return False  # before the import: commands that read no XIF start without the format's words
    from mdl.formats.xif.columns import FILETYPE

    return first.startswith(f"#filetype,{FILETYPE.lower()}")
