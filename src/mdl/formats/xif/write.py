"""A resolved description -> a SmartServer Modbus XIF (`.mod`) file, with the current column names
(SPEC 7; docs/xif.md has the mapping).

A function XIF can express becomes one datapoint row; what a row cannot carry (an enumeration,
"not implemented" values, units, a second marker value...) is a warning, and a function XIF cannot
express at all (a fragment, an expression, registers that are not consecutive, bytes of several
registers, bits of a register or a scale register: SPEC 2.2's `bits`, `scale_exponent`, `scale_by`, for
which seed 004 has no column) is left out with a warning that says why; one warning per kind, naming
every function it concerns (mdl.exchange.notes, as the engines do). Reading the file back (`mdl import`)
gives every exported function the same value.

Text cells (names, descriptions, the Block Name, product line values) never make a row or a cell of
their own: commas and quotes are quoted as Excel does, a Block Name starting with `#` is quoted (else
it reads as a product line), a description's line breaks become spaces, and a name, block label or
identity value holding a line break is refused (MdlError naming each). A text a spreadsheet would run
as a formula is written behind a `'` (OWASP), with a warning; import takes the `'` away.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from pathlib import Path

from mdl.diagnostics import Diagnostic, MdlError
from mdl.exchange.export import Export, Settings
from mdl.exchange.notes import LeftOut, Lost, Notes, bits_detail, factor_detail
from mdl.exchange.text import unwritable
from mdl.formats.xif import columns as C
from mdl.formats.xif.scaling import decimal_text, points
from mdl.model import Function
from mdl.model.layout import Layout
from mdl.resolver import ResolvedDevice, ResolvedFunction


class _Inexpressible(LeftOut):
    """The function cannot be a datapoint."""


@dataclass
class _Datapoint:
    rf: ResolvedFunction
    cells: dict[str, str]
    slot: tuple[str, int, str]  # as the reader keys it: (table, first address, part of the register)
    lost: list[Lost] = field(default_factory=list)  # what the row cannot carry

    @property
    def fn(self) -> Function:
        return self.rf.fn


def export_xif(resolved: ResolvedDevice, settings: Settings) -> Export:
    """The `.mod` text of the description; `settings` (connection, unit, interval) are not part of a `.mod`
    (a warning says so when the command line gives them)."""
    device = resolved.device
    source = device.source
    notes = Notes(resolved, "")

    kept = _datapoints(resolved, notes)
    for point, base in _restore_names(kept):
        notes.note_for(
            point.rf,
            "written with its name in its block (a .mod needs names unique only within a block)",
            f"as '{base}'",
        )
    refused: list[Diagnostic] = []

    def text(rf: ResolvedFunction | None, value: str, what: str, prose: bool = False) -> str:
        cell, said, refusal = _text(value, what, prose)
        for message, detail, severity in said:
            if rf is None:
                (notes.device_warning if severity == "warning" else notes.note)(f"{message} ({detail})")
            else:
                (notes.warn if severity == "warning" else notes.note_for)(rf, message, detail)
        if refusal is not None:
            subject = f"function '{rf.name}': " if rf is not None else ""
            refused.append(Diagnostic(source, rf.fn.line if rf else None, None, subject + refusal))
        return cell

    for point in kept:
        for key, what in (("block", "block label"), ("name", "name"), ("description", "description")):
            if point.cells.get(key):
                point.cells[key] = text(point.rf, point.cells[key], what, prose=key == "description")
        if _product_like(point.cells.get(C.EXPORT_COLUMNS[0], "")):
            notes.note_for(
                point.rf,
                f"its {C.CURRENT[C.EXPORT_COLUMNS[0]]} starts with #: written in quotes, so that "
                "the row is not read as a product line",
            )
    rows = [[point.cells.get(key, "") for key in C.EXPORT_COLUMNS] for point in kept]

    program_id = device.program_id
    if program_id is None:
        program_id = _placeholder_id(device.name)
        notes.device_warning(
            f"the description has no program_id: wrote the placeholder {program_id}; a SmartServer "
            "needs your device type's program ID there"
        )
    if device.tests:
        notes.device_warning(f"{len(device.tests)} test scenario(s) not written: a .mod file has none")
    if device.max_registers is not None:
        notes.device_warning(f"max_registers {device.max_registers} not written: a .mod file has no such setting")
    if settings.connection is not None or settings.unit != 1 or settings.interval_given:
        notes.device_warning(
            "the connection, --unit and --interval are not written: a .mod file describes the device "
            "type, and the SmartServer sets those when a device is provisioned"
        )
    if source is None or Path(source).stem != device.name:
        notes.note(
            f"the device name '{device.name}' is not in the file: a .mod file's name (without .mod) is the XIF's name"
        )

    lines = [_row(["#filetype", C.FILETYPE], datapoint=False)]
    identity = {"program_id": program_id, "description": device.description}
    for line, attr in C.PRODUCT_LINE_NAMES:
        value = identity.get(attr, getattr(device, attr, None))
        if value:
            lines.append(
                _row([f"#{line}", text(None, value, f"#{line}", prose=attr == "description")], datapoint=False)
            )
    if refused:
        raise MdlError(refused)
    lines.append(_row([C.CURRENT[key] for key in C.EXPORT_COLUMNS]))
    lines += (_row(row) for row in rows)
    return Export(text="".join(lines), warnings=notes.found)


def _datapoints(resolved: ResolvedDevice, notes: Notes) -> list[_Datapoint]:
    """A datapoint for each function a row can carry; each other function, and what a row loses, warned."""
    kept: list[_Datapoint] = []
    taken: dict[tuple[str, int, str], str] = {}
    for rf in resolved.functions:
        try:
            point = _datapoint(rf)
        except _Inexpressible as exc:
            notes.warn(rf, f"not exported: {exc.why}", exc.detail)
            continue
        other = taken.get(point.slot)
        if other is not None:
            notes.warn(
                rf,
                "not exported: it starts on the same register as a datapoint before it, and a .mod file "
                "lists each address once",
                f"'{other}'",
            )
            continue
        taken[point.slot] = rf.name
        for why, detail in point.lost:
            notes.warn(rf, why, detail)
        kept.append(point)
    return kept


def _text(value: str, what: str, prose: bool) -> tuple[str, list[tuple[str, str, str]], str | None]:
    """A text as its cell: (the cell, what to say about it, why it cannot be written or None). A line
    break of any kind would start a row for some reader: prose (a description) is put on one line, any
    other text refused; a text a spreadsheet would run as a formula gets a `'` before it."""
    said: list[tuple[str, str, str]] = []  # (message, detail, severity)
    control = unwritable(value)  # NUL, a lone surrogate: what mdl import (and MDL) refuses to read back
    if control is not None:
        return value, said, f"its {what} holds {control}, which a .mod cell cannot carry: change the {what}"
    bad = C.line_break(value)
    if bad is not None:
        if not prose:
            return (
                value,
                said,
                (
                    f"its {what} '{value[:40]}' holds a line break ({bad}), which would start a new row "
                    f"of the .mod file: change the {what} (a .mod cell cannot carry one)"
                ),
            )
        value = _one_line(value)
        said.append((f"its {what} holds line breaks: written on one line, with spaces", bad, "note"))
    elif prose:
        value = value.strip()
    if C.marked(value):
        said.append(
            (
                f"its {what} written behind a {C.TEXT_MARK}, so that a spreadsheet does not run it as a formula "
                f"(CSV injection); mdl import reads it back without the {C.TEXT_MARK}",
                f"'{C.TEXT_MARK}{value[:40]}'",
                "warning",
            )
        )
        value = C.TEXT_MARK + value
    return value, said, None


def _product_like(cell: str) -> bool:
    """Whether a row's first cell would make it read as a product line."""
    return cell.lstrip().startswith("#")


def _row(cells: list[str], datapoint: bool = True) -> str:
    """One CSV record as Excel writes it: a cell in quotes where it holds a comma, a quote or a line
    break (a quote inside doubled); a datapoint's first cell also where it starts with `#`."""

    def needs_quotes(i: int, cell: str) -> bool:
        return any(ch in cell for ch in ',"\r\n') or (datapoint and i == 0 and _product_like(cell))

    return ",".join(_quoted(cell) if needs_quotes(i, cell) else cell for i, cell in enumerate(cells)) + "\r\n"


def _quoted(cell: str) -> str:
    return '"' + cell.replace('"', '""') + '"'


_RENAMED = re.compile(r"(.+)_([2-9]|[1-9][0-9]+)")


def _restore_names(points: list[_Datapoint]) -> list[tuple[_Datapoint, str]]:
    """Give back the names import changed: a datapoint name used in two blocks became `NAME_2`, `NAME_3`
    in MDL (names are unique in a device, SPEC 3), while a .mod needs them unique only within a block.
    A name `NAME_N` is written `NAME` where another block has a datapoint `NAME` and this block has
    none. Returns (the datapoint, its datapoint name) of each one renamed, to be said."""

    def block(p: _Datapoint) -> tuple[str, str]:
        return p.cells.get("block", ""), p.cells.get("block_index", "")

    used = {(*block(p), p.cells["name"]) for p in points}
    blocks_of: dict[str, set[tuple[str, str]]] = {}
    for p in points:
        blocks_of.setdefault(p.cells["name"], set()).add(block(p))
    renamed = []
    for p in points:
        m = _RENAMED.fullmatch(p.cells["name"])
        if m is None:
            continue
        base = m.group(1)
        elsewhere = bool(blocks_of.get(base, set()) - {block(p)})
        if elsewhere and (*block(p), base) not in used:
            used.add((*block(p), base))
            renamed.append((p, base))
            p.cells["name"] = base
            if p.cells.get("description") == base:
                p.cells["description"] = ""
    return renamed


def _datapoint(rf: ResolvedFunction) -> _Datapoint:
    fn, lay = rf.fn, rf.layout
    if fn.bits is not None:
        raise _Inexpressible(
            "a datapoint reads whole registers, and a .mod file has no column for bits of one", bits_detail(fn)
        )
    if fn.factor is not None:
        raise _Inexpressible(
            "a datapoint's scaling is two constant points, and a .mod file cannot name a scale register",
            factor_detail(fn),
        )
    if fn.expression is not None:
        raise _Inexpressible("it is computed by an expression, which XIF cannot express")
    if fn.read_function_code is not None:
        raise _Inexpressible("its value comes from a read fragment, which XIF cannot express")
    first = lay.addresses[0]
    if lay.addresses != tuple(range(first, first + len(lay.addresses))):
        raise _Inexpressible(
            "its registers do not follow each other, and a datapoint reads consecutive registers",
            f"registers {' '.join(map(str, lay.addresses))}",
        )
    native, length, byte_order = _native(lay)
    cells = {
        "name": fn.name,
        "modicon": "N",
        "address": str(first),
        "function_code": C.TABLE_CODES[lay.table],
        "native": native.name,
        "description": "" if fn.description == fn.name else fn.description,
    }
    point = _Datapoint(rf, cells, (lay.table, first, C.register_part(native, byte_order)))
    if length is not None:
        cells["ascii_length"] = str(length)
    if native.name != "BIT":
        cells["byte_order"] = byte_order
        cells["word_order"] = lay.word_order if native.chars != 1 else ""
    cells["iap_type"] = _iap_type(fn, lay)
    _blocks(fn, cells, point.lost)
    _access(fn, cells, point.lost)
    if fn.scales and lay.kind in ("int", "float"):
        cells.update(zip(C.SCALING_POINTS, points(fn.eff_multiplier, fn.eff_offset), strict=True))
    for key, value in (("range_min", fn.minimum), ("range_max", fn.maximum)):
        if value is not None:
            cells[key] = decimal_text(value)
    if fn.precision is not None:
        cells["precision"] = str(fn.precision)
    if fn.marker:
        cells["marker"] = str(fn.marker[0])
        if len(fn.marker) > 1:
            point.lost.append(
                (
                    "marker values after the first not written: a datapoint holds one marker value",
                    f"marker {' '.join(map(str, fn.marker[1:]))}",
                )
            )
    if fn.values:
        point.lost.append(("its enumeration (values) is not written: the datapoint reads the number", None))
    if fn.not_implemented:
        point.lost.append(
            ("not_implemented not written: the datapoint reads those values as numbers", " ".join(fn.not_implemented))
        )
    if fn.units:
        point.lost.append(
            (
                "units not written: a .mod file has no units column (a SmartServer takes them from the IAP type)",
                f"'{fn.units}'",
            )
        )
    kept = [attr for attr in ("immutable", "system", "fetch_group") if getattr(fn, attr) is not None]
    if kept:
        point.lost.append(("not written: a .mod file has no such column", ", ".join(kept)))
    return point


def _native(lay: Layout) -> tuple[C.Native, int | None, str]:
    """The native type of a layout, its ASCII Length (strings) and Byte Order."""
    n = len(lay.addresses)
    types = C.NATIVE_TYPES
    if lay.kind == "bool":
        return types["BIT"], None, ""
    if lay.unit in ("low", "high"):
        byte_order = "little" if lay.unit == "high" else "big"
        if lay.kind == "string":
            return types["CHAR8"], n, byte_order
        if lay.kind == "int" and n == 1:
            return types["SINT8" if lay.signed else "UINT8"], None, byte_order
        raise _Inexpressible(
            "its value is made of bytes of several registers, which no native type reads",
            f"{'upper' if lay.unit == 'high' else 'lower'} bytes of {n} registers",
        )
    if lay.kind == "string":
        return types["CHAR8_2"], 2 * n, lay.byte_order
    if lay.kind == "float" and lay.bits == 16 * n:
        return types[f"FLOAT{lay.bits}"], None, lay.byte_order
    if lay.kind == "int" and (lay.bits == 16 * n and n in (1, 2, 4) or (n == 1 and lay.bits == 8)):
        return types[f"{'S' if lay.signed else 'U'}INT{lay.bits}"], None, lay.byte_order
    raise _Inexpressible("no native type reads its value", f"a {lay.bits}-bit {lay.kind} over {n} registers")


def _iap_type(fn: Function, lay: Layout) -> str:
    if lay.kind == "string":
        return C.IAP_TEXT
    if lay.kind == "float" or (lay.kind == "int" and (fn.scales or lay.bits > 16)):
        return C.IAP_FLOAT
    return C.IAP_SIGNED if lay.kind == "int" and lay.signed else C.IAP_COUNT


def _blocks(fn: Function, cells: dict[str, str], lost: list[Lost]) -> None:
    """Block Name from the first block label; Block Index from a second one written `Name[N]`, as import
    writes it."""
    labels = list(fn.block_labels)
    if not labels:
        return
    cells["block"] = labels[0]
    rest = labels[1:]
    if rest and rest[0].startswith(labels[0] + "[") and rest[0].endswith("]"):
        index = rest[0][len(labels[0]) + 1 : -1]
        if index.isascii() and index.isdigit():
            cells["block_index"] = str(int(index))
            rest = rest[1:]
    if rest:
        lost.append(
            ("block labels after the first not written: a datapoint is in one block", ", ".join(repr(r) for r in rest))
        )


def _access(fn: Function, cells: dict[str, str], lost: list[Lost]) -> None:
    if fn.write_function_code is not None:
        cells["write"] = "-"
        lost.append(("its write fragment is not expressible: exported read-only (-)", None))
        return
    if fn.writable:
        cells["write"] = "++" if fn.write_multiple else "+"
        if not fn.readable:
            lost.append(("it is write-only, and XIF has no write-only datapoint: exported read-write (+)", None))
        return
    cells["write"] = "-"


def _one_line(text: str) -> str:
    """A description on one line (a SmartServer reads one line per datapoint)."""
    return " ".join(text.splitlines()).strip()


def _placeholder_id(name: str) -> str:
    """A program ID made from the device name: 9FFFFF (a Modbus device of no registered manufacturer)
    and 10 hex digits of the name's SHA-256, the same every run."""
    return "9FFFFF" + hashlib.sha256(name.encode("utf-8")).hexdigest()[:10].upper()
