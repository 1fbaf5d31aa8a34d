"""SmartServer Modbus XIF (`.mod`) -> the document model (SPEC 7; docs/xif.md has the mapping).

The file: a `#filetype,Modbus_xif` line, product lines (`#program_ID,…`, `#version`, `#product_name`,
`#manufacturer`, `#description`), then the datapoint list: a heading row and a row per datapoint.
Columns are found by their heading, in any order, under their current names or those of files made
for releases before 3.2. Bad cells are reported (file, line, column) before the reader gives up;
what it reads differently from a SmartServer, or cannot keep, is a warning on `Device.notes`, one of
each kind (`mdl.diagnostics.Collector`). Time and memory are linear in the file, which may hold at most
MAX_BYTES, MAX_DATAPOINTS datapoint rows and MAX_OTHER_ROWS other rows (blank ones are not counted).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from mdl.diagnostics import Collector, Diagnostic, MdlError, error
from mdl.fileio import decode_text, is_stdin, read_bytes
from mdl.formats.xif import columns as C
from mdl.formats.xif.records import Cell, Record, RecordError, records
from mdl.formats.xif.rows import Columns, Point, RowReader, text_cell
from mdl.model import Device

if TYPE_CHECKING:
    from _typeshed import StrPath

_PROGRAM_ID = re.compile(r"[0-9A-Fa-f]{16}")
MAX_BYTES = 16 * 1024 * 1024  # a .mod of 65,536 datapoints of 256 bytes each
MAX_DATAPOINTS = 65_536  # datapoint rows (a SmartServer device type has hundreds)
MAX_OTHER_ROWS = 4_096  # other rows that hold something: product lines, the heading, lines ignored
MAX_ERRORS = 100  # errors shown one by one (each at its cell); the rest are counted in one last error


class _Reader:
    def __init__(self, path: str):
        self.path = path
        self.report = Collector(path, max_errors=MAX_ERRORS)
        self.product: dict[str, str] = {}
        self.filetype_seen = False
        self.cols: Columns | None = None
        self.rows = 0  # datapoint rows read
        self.points: list[Point] = []
        self.modicon_guessed: list[int] = []  # lines whose address was read as a Modicon number

    # -- reporting ---------------------------------------------------------------------------------
    def error(self, cell: Cell, message: str) -> None:
        self.report.error(line=cell.line, col=cell.col, message=message)

    def warn(self, cell: Cell, message: str, kind: str, severity: str = "warning") -> None:
        self.report.add(Diagnostic(self.path, cell.line, cell.col, message, severity), kind=kind)

    @property
    def failed(self) -> bool:
        return self.report.failed

    # -- the file ----------------------------------------------------------------------------------
    def read(self, text: str) -> None:
        last_line = 1
        heading_refused = False
        others = 0  # rows that are not datapoints
        try:
            for record in records(text):
                last_line = record.line
                if record.blank:
                    continue
                first = record.cells[0]
                datapoint = self.cols is not None and not (first.value.startswith("#") and not first.quoted)
                others += not datapoint
                if others > MAX_OTHER_ROWS:
                    self.report.error(
                        line=first.line,
                        col=first.col,
                        message=f"more than {MAX_OTHER_ROWS:,} rows that are not "
                        "datapoints (product lines, lines ignored): mdl reads at most that many; the "
                        "rest is not read",
                        always=True,
                    )
                    heading_refused = True  # said why it stopped: not that there is no heading
                    break
                if first.value.startswith("#") and (self.cols is None or not first.quoted):
                    self.product_line(record)  # a quoted `#...` after the heading is a datapoint's Block Name
                elif heading_refused:
                    continue
                elif self.cols is None:
                    self.cols = self.heading(record)
                    heading_refused = self.cols is None
                elif self.rows == MAX_DATAPOINTS:
                    self.report.error(
                        line=first.line,
                        col=first.col,
                        message=f"more than {MAX_DATAPOINTS:,} datapoints: mdl reads at "
                        "most that many from a .mod file (a SmartServer device type has far fewer); the "
                        "rest is not read",
                        always=True,
                    )
                    break
                else:
                    self.rows += 1
                    self.datapoint(record)
        except RecordError as exc:
            self.report.error(line=exc.line, col=exc.col, message=str(exc), always=True)
            heading_refused = heading_refused or self.cols is None  # said why: no second error for the heading
        if not self.filetype_seen:
            self.report.error(line=1, col=None, message=f"not a Modbus XIF file: no '#filetype,{C.FILETYPE}' line")
        if self.cols is None:
            if not heading_refused:
                self.report.error(
                    line=last_line,
                    col=None,
                    message="no datapoint list: no heading row (Datapoint Name, Address, "
                    "Native Type, Write Enable, ...) after the product lines",
                )
            return
        if not self.points and not self.failed:
            self.report.warn("the datapoint list is empty", last_line)
        self.check_addresses()
        self.name_points()

    def product_line(self, record: Record) -> None:
        cells = record.filled()
        key_cell = cells[0]
        key = "_".join(key_cell.value[1:].lower().split())
        value = ",".join(c.text for c in cells[1:]).strip()
        if key in C.PRODUCT_LINES and value:
            value = text_cell(cells[1], value, self.report) or ""
        if key == "filetype":
            if value.lower() != C.FILETYPE.lower():
                self.error(key_cell, f"file type '{value[:40]}' is not {C.FILETYPE}")
            self.filetype_seen = True
        elif key in C.PRODUCT_LINES:
            attr = C.PRODUCT_LINES[key]
            if attr in self.product:
                self.warn(
                    key_cell,
                    f"a second '#{key_cell.value[1:].strip()}' line; the first is kept",
                    "product lines given again (the first of each kept)",
                )
            elif value:
                self.product[attr] = value
                if attr == "program_id" and not _PROGRAM_ID.fullmatch(re.sub(r"[:\-]", "", value)):
                    self.warn(
                        cells[1],
                        f"program ID '{value[:40]}' is not 16 hexadecimal digits; kept as written",
                        "program ID not 16 hexadecimal digits",
                    )
        else:
            self.warn(
                key_cell,
                f"'{key_cell.value[:40]}' is not a product line of a Modbus XIF file; the line is "
                "ignored (a datapoint whose Block Name starts with # needs it in quotes)",
                "lines starting with # that are not product lines of a Modbus XIF file, ignored,",
            )

    def heading(self, record: Record) -> Columns | None:
        found = [
            (position, cell, C.HEADINGS.get(C.normalize(cell.value)))
            for position, cell in enumerate(record.cells)
            if cell.value
        ]
        known = {f[0] for _, _, f in found if f is not None}
        if not known & {"name", "address"}:
            self.report.error(
                line=record.line,
                col=None,
                message="no datapoint list: this line should name the columns (Datapoint "
                "Name, Address, Native Type, Write Enable, ...), and names neither a "
                "datapoint name nor an address column",
            )
            return None
        cols = Columns(width=len(record.filled()))
        bad = False
        unknown = [cell for _, cell, key_legacy in found if key_legacy is None]
        if unknown:
            names = ", ".join(f"'{cell.value[:40]}'" for cell in unknown[:3])
            more = f" and {len(unknown) - 3:,} more" if len(unknown) > 3 else ""
            verb = "are not Modbus XIF columns" if len(unknown) > 1 else "is not a Modbus XIF column"
            self.warn(unknown[0], f"column{'s' * (len(unknown) > 1)} {names}{more} {verb}; ignored", "unknown columns")
        for position, cell, key_legacy in found:
            if key_legacy is None:
                continue
            key, legacy = key_legacy
            cols.wire_only = cols.wire_only or C.normalize(cell.value) in C.PRE_35
            if key in cols.index:
                other = record.cells[cols.index[key]]
                if C.normalize(other.value) == C.normalize(cell.value):
                    self.error(cell, f"column '{cell.value}' appears twice (also column {other.col})")
                    bad = True
                    continue
                older, newer = (cell, other) if legacy else (other, cell)
                self.warn(
                    older,
                    f"column '{older.value}' ignored: '{newer.value}' gives the same",
                    f"column '{older.value}' ignored: '{newer.value}' gives the same",
                )
                if legacy:
                    continue
            cols.index[key] = position
        for key in C.REQUIRED:
            if key not in cols.index:
                self.report.error(
                    line=record.line, col=None, message=f"the datapoint heading has no {C.heading_names(key)} column"
                )
                bad = True
        return None if bad else cols

    # -- a datapoint row ---------------------------------------------------------------------------
    def datapoint(self, record: Record) -> None:
        assert self.cols is not None
        extra = [cell for cell in record.filled()[self.cols.width :] if cell.value]
        if extra:
            width = self.cols.width
            first = f"'{extra[0].value[:40]}'"
            self.warn(
                extra[0],
                f"cell {first} is beyond the heading's {width} columns; ignored"
                if len(extra) == 1
                else f"{len(extra):,} cells beyond the heading's {width} columns (the first {first}); ignored",
                f"cells beyond the heading's {width} columns, ignored,",
            )
        row = RowReader(self.cols, record, self.report, self.modicon_guessed)
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
                self.error(
                    p.address_cell,
                    f"datapoint '{p.name_cell.value[:80]}': address {address} of the {table} "
                    f"table is also datapoint '{other.name_cell.value[:80]}' "
                    f"(line {other.row.line})",
                )
        if self.modicon_guessed:
            lines = ", ".join(str(n) for n in self.modicon_guessed[:10])
            more = f" and {len(self.modicon_guessed) - 10:,} more" if len(self.modicon_guessed) > 10 else ""
            self.report.warn(
                line=self.modicon_guessed[0],
                kind="addresses read as Modicon register numbers",
                message=f"addresses on line{'s' * (len(self.modicon_guessed) > 1)} {lines}{more} read as Modicon "
                "register numbers (40001 = holding register 0), as SmartServer 3.5 and later do: the "
                "Function Code names the same table; give a Modicon column with N for wire addresses",
            )

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
            where = "in the same block" if same else f"in block '{_block_text(other.block)[:80]}'"
            kind = (
                "datapoint names used twice in one block, the second renamed NAME_2, NAME_3, ..."
                if same
                else "datapoint names used again in another block, renamed NAME_2, NAME_3, ... (SPEC 3)"
            )
            self.warn(
                p.name_cell,
                f"datapoint name '{original[:80]}' is also on line {other.row.line} {where}: "
                f"this one is named '{p.fn.name[:80]}'",
                kind,
                "warning" if same else "note",
            )

    def device(self, path: Path) -> Device:
        name = self.product.get("product", "Modbus XIF device") if is_stdin(path) else path.stem
        description = self.product.get("description") or f"Imported from {path.name}"
        device = Device(
            name,
            description,
            [p.fn for p in self.points],
            source=str(path),
            manufacturer=self.product.get("manufacturer"),
            product=self.product.get("product"),
            product_version=self.product.get("product_version"),
            program_id=self.product.get("program_id"),
        )
        if device.extensions():
            device.version = "1.0"
        device.notes = self.report.diagnostics()
        return device


def _block_text(block: tuple[str, int]) -> str:
    name, index = block
    return f"{name}[{index}]" if index else name


def _read_bytes(path: Path) -> bytes:
    """The file's bytes; an error, without reading the rest, when it holds more than MAX_BYTES."""
    try:
        if is_stdin(path):
            data = sys.stdin.buffer.read(MAX_BYTES + 1)
        else:
            with open(path, "rb") as f:
                data = f.read(MAX_BYTES + 1)
    except OSError:
        data = read_bytes(path)  # no such file, a folder...: it says which
    if len(data) > MAX_BYTES:
        raise error(
            f"larger than {MAX_BYTES // (1024 * 1024)} MiB: mdl reads .mod files up to that size (a "
            f"SmartServer device type of {MAX_DATAPOINTS:,} datapoints fits)",
            path,
        )
    return data


def read_xif(path: StrPath) -> Device:
    """The model of a `.mod` file (`<stdin>`: standard input); MdlError with every error found."""
    p = Path(path)
    text = decode_text(_read_bytes(p), p, ("utf-8-sig", "cp1252")).lstrip("\ufeff")
    reader = _Reader(str(p))
    reader.read(text)
    if reader.failed:
        raise MdlError(reader.report.diagnostics())
    return reader.device(p)
