"""What a count column counts, when the INI does not say (`count_unit`): bytes or words."""

from __future__ import annotations

from mdl.formats.table.cells import CellError, read_type
from mdl.formats.table.columns import Columns
from mdl.formats.table.numbers import parse_int
from mdl.formats.table.readers.delimited import Row
from mdl.model.layout import FORMAT_BITS


def count_unit(cols: Columns, data: list[Row], given: str | None) -> tuple[str, str | None]:
    """(words | bytes, the note that says how it was decided, or None when nothing was guessed).

    The header decides when it says "byte" (ORNL's "Bytes") or "word"/"register"; otherwise the rows
    with a fixed-width format do: a FLOAT32 counted 4 counts bytes, counted 2 words (bytes only on
    clear evidence: two rows or more, and more than twice the rows that fit words). A format without a
    width (INT) is no evidence."""
    if given or "count" not in cols.index:
        return given or "words", None
    col = cols.describe(cols.index["count"])
    header = cols.header_of("count").lower()
    override = "set count_unit = {} in [Modbus Device] to override"
    if "byte" in header:
        return "bytes", f"counts in {col} read as bytes: its header says so; {override.format('words')}"
    if "word" in header or "reg" in header:
        return "words", f"counts in {col} read as registers: its header says so; {override.format('bytes')}"
    words = octets = 0
    for r in data:
        n_text, f_text = r.cell(cols.index["count"]), r.cell(cols.index.get("format"))
        if not n_text or not f_text:
            continue
        try:
            n, typed = parse_int(n_text), read_type(f_text)
        except (CellError, ValueError):
            continue
        size = FORMAT_BITS[typed.format] // 16
        if typed.widthless or typed.format in ("STRING", "BIT") or size == 0:
            continue  # INT counted 2: two registers of 32 bits, or two bytes of 16?
        words += n == size
        octets += n == 2 * size
    if octets >= 2 and octets > 2 * words:
        return "bytes", (
            f"counts in {col} read as bytes: {octets} of the rows with a format are counted in bytes "
            f"(a 32-bit value counted 4); {override.format('words')}"
        )
    why = f"{words} of the rows with a format are counted in registers" if words else "the usual unit"
    return "words", f"counts in {col} read as registers (words): {why}; {override.format('bytes')}"
