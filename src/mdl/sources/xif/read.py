"""SmartServer Modbus XIF (`.mod`) -> the document model (SPEC 7; docs/xif.md has the mapping).

The file: a `#filetype,Modbus_xif` line, product lines (`#program_ID,…`, `#version`, `#product_name`,
`#manufacturer`, `#description`), then the datapoint list: a heading row and a row per datapoint.
Columns are found by their heading, in any order, under their current names or those of files made
for releases before 3.2. Every bad cell of every row is reported (file, line, column) before the
reader gives up; what it reads differently from a SmartServer, or cannot keep, is a warning on
`Device.notes`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

from mdl.diagnostics import Diagnostic, MdlError
from mdl.fileio import decode_text, is_stdin, read_bytes
from mdl.model import Device
from mdl.sources.xif import columns as C
from mdl.sources.xif.records import Cell, Record, RecordError, records
from mdl.sources.xif.rows import Columns, Point, RowReader

if TYPE_CHECKING:
    from _typeshed import StrPath

_PROGRAM_ID = re.compile(r"[0-9A-Fa-f]{16}")


class _Reader:
    def __init__(self, path: str):
        self.path = path
        self.diagnostics: list[Diagnostic] = []
        self.product: dict[str, str] = {}
        self.filetype_seen = False
        self.cols: Columns | None = None
        self.points: list[Point] = []
        self.modicon_guessed: list[int] = []  # lines whose address was read as a Modicon number

    # -- reporting ---------------------------------------------------------------------------------
    def report(self, line: int | None, col: int | None, message: str, severity: str = "error") -> None:
        self.diagnostics.append(Diagnostic(self.path, line, col, message, severity))

    def at(self, cell: Cell, message: str, severity: str = "error") -> None:
        self.report(cell.line, cell.col, message, severity)

    @property
    def failed(self) -> bool:
        return any(d.severity == "error" for d in self.diagnostics)

    # -- the file ----------------------------------------------------------------------------------
    def read(self, text: str) -> None:
        last_line = 1
        heading_refused = False
        try:
            for record in records(text):
                last_line = record.line
                if record.blank:
                    continue
                if record.cells[0].value.startswith("#"):
                    self.product_line(record)
                elif heading_refused:
                    continue
                elif self.cols is None:
                    self.cols = self.heading(record)
                    heading_refused = self.cols is None
                else:
                    self.datapoint(record)
        except RecordError as exc:
            self.report(exc.line, exc.col, str(exc))
        if not self.filetype_seen:
            self.report(1, None, f"not a Modbus XIF file: no '#filetype,{C.FILETYPE}' line")
        if self.cols is None:
            if not heading_refused:
                self.report(last_line, None, "no datapoint list: no heading row (Datapoint Name, Address, Native "
                                             "Type, Write Enable, ...) after the product lines")
            return
        if not self.points and not self.failed:
            self.report(last_line, None, "the datapoint list is empty", "warning")
        self.check_addresses()
        self.name_points()

    def product_line(self, record: Record) -> None:
        cells = record.filled()
        key_cell = cells[0]
        key = "_".join(key_cell.value[1:].lower().split())
        value = ",".join(c.text for c in cells[1:]).strip()
        if not key:
            return
        if key == "filetype":
            if value.lower() != C.FILETYPE.lower():
                self.at(key_cell, f"file type '{value}' is not {C.FILETYPE}")
            self.filetype_seen = True
        elif key in C.PRODUCT_LINES:
            attr = C.PRODUCT_LINES[key]
            if attr in self.product:
                self.at(key_cell, f"a second '#{key_cell.value[1:].strip()}' line; the first is kept", "warning")
            elif value:
                self.product[attr] = value
                if attr == "program_id" and not _PROGRAM_ID.fullmatch(re.sub(r"[:\-]", "", value)):
                    self.at(cells[1], f"program ID '{value}' is not 16 hexadecimal digits; kept as written",
                            "warning")
        else:
            self.at(key_cell, f"'{key_cell.value}' is not a product line of a Modbus XIF file; ignored", "warning")

    def heading(self, record: Record) -> Columns | None:
        found = [(position, cell, C.HEADINGS.get(C.normalize(cell.value)))
                 for position, cell in enumerate(record.cells) if cell.value]
        known = {f[0] for _, _, f in found if f is not None}
        if not known & {"name", "address"}:
            self.report(record.line, None, "no datapoint list: this line should name the columns (Datapoint Name, "
                                           "Address, Native Type, Write Enable, ...), and names neither a datapoint "
                                           "name nor an address column")
            return None
        cols = Columns(width=len(record.filled()))
        bad = False
        for position, cell, key_legacy in found:
            if key_legacy is None:
                self.at(cell, f"column '{cell.value}' is not a Modbus XIF column; ignored", "warning")
                continue
            key, legacy = key_legacy
            cols.wire_only = cols.wire_only or C.normalize(cell.value) in C.PRE_35
            if key in cols.index:
                other = record.cells[cols.index[key]]
                if C.normalize(other.value) == C.normalize(cell.value):
                    self.at(cell, f"column '{cell.value}' appears twice (also column {other.col})")
                    bad = True
                    continue
                older, newer = (cell, other) if legacy else (other, cell)
                self.at(older, f"column '{older.value}' ignored: '{newer.value}' gives the same", "warning")
                if legacy:
                    continue
            cols.index[key] = position
        for key in C.REQUIRED:
            if key not in cols.index:
                self.report(record.line, None, f"the datapoint heading has no {C.heading_names(key)} column")
                bad = True
        return None if bad else cols

    # -- a datapoint row ---------------------------------------------------------------------------
    def datapoint(self, record: Record) -> None:
        assert self.cols is not None
        for cell in record.filled()[self.cols.width:]:
            if cell.value:
                self.at(cell, f"cell '{cell.value[:40]}' is beyond the heading's columns; ignored", "warning")
        row = RowReader(self.cols, record, self.at, self.modicon_guessed)
        point = row.point()
        if point is not None and not row.failed:
            self.points.append(point)

    # -- checks across rows ------------------------------------------------------------------------
    def check_addresses(self) -> None:
        first: dict[tuple[str, int, str], Point] = {}
        for p in self.points:
            other = first.setdefault(p.slot, p)
            if other is not p:
                table, address, _ = p.slot
                self.at(p.address_cell, f"datapoint '{p.name_cell.value}': address {address} of the {table} "
                                        f"table is also datapoint '{other.name_cell.value}' (line {other.row.line})")
        if self.modicon_guessed:
            lines = ", ".join(str(n) for n in self.modicon_guessed[:10])
            more = f" and {len(self.modicon_guessed) - 10} more" if len(self.modicon_guessed) > 10 else ""
            self.report(self.modicon_guessed[0], None,
                        f"addresses on line{'s' * (len(self.modicon_guessed) > 1)} {lines}{more} read as Modicon "
                        "register numbers (40001 = holding register 0), as SmartServer 3.5 and later do: the "
                        "Function Code names the same table; give a Modicon column with N for wire addresses",
                        "warning")

    def name_points(self) -> None:
        """Names are unique within a block; one used again in another block gets `_2`, `_3`... (SPEC 3),
        said in a note; within one block it is a warning (SmartServer refuses such a file)."""
        literal = {p.fn.name for p in self.points}
        used: dict[str, Point] = {}
        suffix: dict[str, int] = {}  # the next number to try for a name
        for p in self.points:
            original = p.fn.name
            other = used.get(original)
            if other is None:
                used[original] = p
                continue
            n = suffix.get(original, 2)
            while f"{original}_{n}" in used or f"{original}_{n}" in literal:
                n += 1
            suffix[original] = n + 1
            p.fn.name = f"{original}_{n}"
            used[p.fn.name] = p
            same = other.block == p.block
            where = "in the same block" if same else f"in block '{_block_text(other.block)}'"
            self.at(p.name_cell, f"datapoint name '{original}' is also on line {other.row.line} {where}: "
                                 f"this one is named '{p.fn.name}'", "warning" if same else "note")

    def device(self, path: Path) -> Device:
        name = self.product.get("product", "Modbus XIF device") if is_stdin(path) else path.stem
        description = self.product.get("description") or f"Imported from {path.name}"
        device = Device(name, description, [p.fn for p in self.points], source=str(path),
                        manufacturer=self.product.get("manufacturer"), product=self.product.get("product"),
                        product_version=self.product.get("product_version"),
                        program_id=self.product.get("program_id"))
        if device.extensions():
            device.version = "1.0"
        device.notes = [d for d in _in_file_order(self.diagnostics)]
        return device


def _block_text(block: tuple[str, int]) -> str:
    name, index = block
    return f"{name}[{index}]" if index else name


def _in_file_order(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    return sorted(diagnostics, key=lambda d: (d.line or 0, d.col or 0))


def read_xif(path: StrPath) -> Device:
    """The model of a `.mod` file (`<stdin>`: standard input); MdlError with every error found."""
    p = Path(path)
    text = decode_text(read_bytes(p), p, ("utf-8-sig", "cp1252")).lstrip("\ufeff")
    reader = _Reader(str(p))
    reader.read(text)
    if reader.failed:
        raise MdlError(_in_file_order(reader.diagnostics))
    return reader.device(p)
