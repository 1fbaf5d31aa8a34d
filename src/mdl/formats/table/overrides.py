"""A row that could not be read, read after all with its function's `[function NAME]` section (SPEC 4.1: the
section's fields win over the table's cells).

A row is skipped when one of its essential cells (addresses, register type, format, count) cannot be read,
or when they disagree (an address range of 10 registers and a format of one). Where the function whose
best row it is has a section that sets an essential field, the row is read again with the section's
values in those cells, and a note says so; the section is then applied as for any row
(mdl.formats.table.vocabulary.apply_sections), its notes included.
"""

from __future__ import annotations

from dataclasses import replace

from mdl.diagnostics import shown
from mdl.formats.table.cells import CellError
from mdl.formats.table.columns import Columns
from mdl.formats.table.ini import DeviceIni
from mdl.formats.table.readers.delimited import Row
from mdl.formats.table.report import Report
from mdl.formats.table.rows import ParsedRow, RowSettings, parse_row

ESSENTIAL = ("addresses", "register_type", "format", "count")


def read_with_sections(
    lost: dict[str, int],
    skipped: list[tuple[Row, str | None]],
    ini: DeviceIni,
    cols: Columns,
    st: RowSettings,
    report: Report,
) -> dict[str, ParsedRow]:
    """`lost`: function name -> the skipped row that is its best (an index into `skipped`, each row with the
    field whose cell could not be read). The functions whose section sets that field, and their rows read
    with every essential field the section sets in its cell (its addresses as wire addresses, as the
    section's are); where that still cannot be read, a warning says why."""
    out: dict[str, ParsedRow] = {}
    for name, i in lost.items():
        row, key = skipped[i]
        fs = ini.functions.get(name)
        given = [f for f in ESSENTIAL if f in fs.values] if fs is not None else []
        if fs is None or key is None or not given or cols.index.get(key) is None:
            continue
        cells = list(row.cells)
        was = row.cell(cols.index[key])
        maps = dict(st.cells)
        for field in ESSENTIAL:
            column = cols.index.get(field)
            if field in fs.values and column is not None:
                cells += [""] * max(0, column + 1 - len(cells))
                if field == "format":  # read as [format cells] reads its values: STRING 10, UINT16 bit 3 too
                    maps["format"] = {
                        **maps.get("format", {}),
                        " ".join(fs.values[field].split()).lower(): fs.values[field],
                    }
                cells[column] = fs.values[field]
        wire = replace(st, address_base="0") if "addresses" in fs.values else st
        wire = replace(wire, cells=maps)
        try:
            parsed = parse_row(Row(row.line, cells), cols, wire)
        except CellError as exc:
            report.warn(
                f"{name}: {report.row_name(row.line)} cannot be read with [function {name}]'s fields either: {exc}",
                fs.line,
                file=str(ini.path),
            )
            continue
        if parsed is None:
            continue
        out[name] = parsed
        if key in given:
            message = (
                f"{name}: {report.row_name(row.line)} read with {key} {fs.values[key]} from [function {name}], "
                f"which wins over the cell {shown(was)} that could not be read"
            )
        else:  # the cells disagreed (a range of 10 registers, a type of one): the section's fields settle it
            fields = ", ".join(f"{f} {fs.values[f]}" for f in given)
            message = (
                f"{name}: {report.row_name(row.line)} read with {fields} from [function {name}], which wins "
                f"over the cells of the row (its {key} cell {shown(was)} could not be read as it stood)"
            )
        report.note(message, fs.lines.get(key if key in given else given[0]), file=str(ini.path))
    return out
