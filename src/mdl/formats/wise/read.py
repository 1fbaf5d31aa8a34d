"""WISE-Agent `Modbus.ini` -> the document model (SPEC 7): the guide's form and the shipped agent's.

Read as the agent reads it (its Modbus_Handler.cpp): a section's `numberOfX` says how many entries
`X0`, `X1`... there are; a register line's precision multiplies the value (0 or absent: 1); min and
max are in the scaled unit (crossed ones are swapped, as the agent does); the datatype (0-8) says how
the registers compose; a Lua column that is plain arithmetic on `modbus_val` is applied before the
precision, and any other Lua is kept in the description as a comment, with a warning. Offsets are wire
addresses inside the section's table. The section is the function's block label; a name used again
(in another section, as the agent's samples do) gets SPEC 3's `_2`.

Lines are `[Section]`, `key=value`, blank, or comments starting with `#` or `;` (a whole line: the
agent has no comments after a value). An entry is split at every comma, as the agent's C `strtok`
splits it: quotes are not special (a name holding `"` is that name; a Lua column holding a comma is
cut there for the agent). `strtok` also skips empty fields, moving every later field one column to the
left; a line where that would happen is refused with the empty field's position rather than read
another way than the agent reads it. Every problem is collected: errors (a `numberOfX` that disagrees
with the keys, a datatype outside 0-8, an address used twice in one table, a number that is not
one...) are raised together as one MdlError with each line and column; warnings and notes travel on
`Device.notes`. Diagnostics of one kind (the same message but for its numbers and quoted texts) are
shown SHOWN_PER_KIND times, then summed up in one line with a count and the next lines' numbers.

Limits (docs/wise.md): a file of at most MAX_FILE_BYTES and MAX_ENTRIES entries in all; time and
memory grow linearly with the file.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from mdl.diagnostics import (
    Collector,
    Diagnostic,
    MdlError,
    TextSpan,
    line_order,
    message_kind,
    record_span,
    said,
    shown,
)
from mdl.fileio import is_stdin, read_bytes
from mdl.formats.wise.lua import Affine, affine, kept_in_description
from mdl.formats.wise.sections import (
    DATA_TYPES,
    DEFAULT_DATA_TYPE,
    PLATFORM,
    Section,
    section_named,
)
from mdl.model import Device, Function
from mdl.model.layout import MAX_ADDRESS, address_runs

if TYPE_CHECKING:
    from _typeshed import StrPath

_LINE_BREAK = re.compile(r"\r\n|\r|\n")
_HEADER = re.compile(r"\[(?P<name>[^\]]*)\]\s*")
_INDEX = re.compile(r"(?P<tag>[A-Za-z]+?)(?P<index>[0-9]{1,6})")
# digits, then a point and more digits: one way to match each number, so a long run of digits that is
# no number (`1111...x`) is refused in one pass, not tried at every split of the run (quadratic)
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_DIGITS = re.compile(r"[0-9]{1,9}")
ENCODINGS = ("utf-8-sig", "cp1252", "latin-1")  # latin-1 decodes any byte: the last resort
MAX_FILE_BYTES = 4 * 1024 * 1024  # the agent's samples are a few kB; a full table of entries is some 2 MB
MAX_ENTRIES = 65536  # entries of all sections together: one whole table's worth
SHOWN_PER_KIND = 5  # diagnostics of one kind printed in full before the rest are summed up
COLUMNS = ("offset", "name", "min", "max", "precision", "unit", "datatype", "lua")  # a register line's fields


@dataclass
class _Key:
    key: str
    value: str
    line: int
    col: int  # of the value's first character
    key_col: int = 1


@dataclass
class _Block:
    """One `[section]` of the file and its keys, in order."""

    header: str
    line: int
    section: Section | None
    keys: list[_Key] = field(default_factory=list)


@dataclass
class _Field:
    text: str  # stripped
    col: int
    raw: str = ""  # as written: the agent's token (empty only when nothing is between the commas)

    @property
    def token(self) -> bool:
        """Whether strtok finds a token here (the last field, the rest of the line, may hold commas)."""
        return self.raw.replace(",", "") != ""

    @property
    def blank(self) -> bool:
        return not self.raw.replace(",", "").strip()


@dataclass
class _Claim:
    """An entry's offset in its table (for entries with errors too: a clash is reported either way)."""

    table: str
    offset: int
    label: str
    line: int
    col: int
    width: int = 1  # registers read: 2 for a 32-bit datatype

    @property
    def span(self) -> str:
        return f"registers {self.offset}-{self.offset + 1}" if self.width == 2 else f"register {self.offset}"


class _Reader:
    def __init__(self, path: StrPath):
        self.path = str(path)
        self.diagnostics: list[Diagnostic] = []
        self.errors = 0
        self.entries = 0

    def report(self, line: int | None, col: int | None, message: str, severity: str = "error") -> None:
        self.diagnostics.append(Diagnostic(self.path, line, col, message, severity))
        self.errors += severity == "error"

    @property
    def failed(self) -> bool:
        return self.errors > 0


def read_wise(path: StrPath) -> Device:
    """The device a WISE-Agent Modbus.ini describes; MdlError with every error found."""
    reader = _Reader(path)
    text = _decode(read_bytes(path, MAX_FILE_BYTES), reader)
    blocks = _blocks(text, reader)
    name = _platform(blocks, path, reader)
    functions: list[Function] = []
    claims: list[_Claim] = []
    for block in blocks:
        if block.section is not None:
            functions += _section_functions(block, block.section, reader, claims)
    _check_addresses(claims, reader)
    _unique_names(functions, reader)
    if reader.failed:
        raise MdlError(summed_up(d for d in reader.diagnostics if d.severity == "error"))
    source = "<stdin>" if is_stdin(path) else Path(path).name
    device = Device(name, f"Imported from WISE-Agent {source}", functions, source=str(path))
    if device.extensions():
        device.version = "1.0"
    device.notes = summed_up(reader.diagnostics)
    return device


def summed_up(diagnostics: Iterable[Diagnostic]) -> list[Diagnostic]:
    """The diagnostics in line order, those of one kind and severity past the first SHOWN_PER_KIND folded
    into the next one: its message ends with how many more there are and the lines of the first few."""
    collector = Collector(shown_each=SHOWN_PER_KIND, shown_lines=SHOWN_PER_KIND, fold=True, kind_of=message_kind)
    for d in sorted(diagnostics, key=line_order):
        collector.add(d)
    return collector.diagnostics()


def _decode(data: bytes, reader: _Reader) -> str:
    for encoding in ENCODINGS:
        try:
            text = data.decode(encoding)
        except UnicodeDecodeError:
            continue
        if encoding != ENCODINGS[0]:
            reader.report(None, None, f"not UTF-8: read as {encoding}", "note")
        return text
    raise AssertionError("latin-1 decodes every byte")  # pragma: no cover


def _blocks(text: str, reader: _Reader) -> list[_Block]:
    """The file's sections with their keys; unknown sections are kept (section None) to be reported once."""
    blocks: list[_Block] = []
    seen: dict[str, int] = {}
    current: _Block | None = None
    for number, raw in enumerate(_LINE_BREAK.split(text), start=1):
        stripped = raw.strip()
        if not stripped or stripped[0] in "#;":
            continue
        indent = len(raw) - len(raw.lstrip())
        header = _HEADER.fullmatch(stripped)
        if header is not None:
            name = " ".join(header.group("name").split())
            section = section_named(name)
            canonical = section.name if section else name
            key = canonical.lower()
            if key in seen:
                reader.report(number, indent + 1, f"section [{canonical}] appears twice (first on line {seen[key]})")
                current = _Block(canonical, number, None)  # its keys are not read a second time
                continue
            seen[key] = number
            if section is None and key != PLATFORM.lower():
                reader.report(number, indent + 1, f"unknown section [{name}]: its keys are not read", "warning")
            current = _Block(canonical, number, section)
            blocks.append(current)
            continue
        if "=" not in stripped:
            reader.report(number, indent + 1, "not a [section], a key=value line or a comment (# or ;)")
            continue
        key, _, value = raw.lstrip().partition("=")
        value_col = indent + len(key) + 2 + (len(value) - len(value.lstrip()))
        if current is None:
            reader.report(number, indent + 1, f"{shown(key.strip())} is outside any section: not read", "warning")
            continue
        current.keys.append(_Key(key.strip(), value.strip(), number, value_col, indent + 1))
    return blocks


def _platform(blocks: list[_Block], path: StrPath, reader: _Reader) -> str:
    """The device name: [Platform] Name, else the file's name (said in a note)."""
    platform = next((b for b in blocks if b.header.lower() == PLATFORM.lower()), None)
    keys = platform.keys if platform else []
    name = next((k for k in keys if k.key.lower() == "name" and k.value), None)
    others = [k for k in keys if k is not name]
    if others:
        settings = ", ".join(said(f"{k.key}={k.value}") for k in others)
        reader.report(
            others[0].line,
            None,
            f"[Platform] {settings}: connection settings are not part of MDL "
            "(give them to mdl read or mdl export as options)",
            "note",
        )
    if name is not None:
        return name.value
    guess = "WISE device" if is_stdin(path) else Path(path).stem
    reader.report(
        platform.line if platform else None, None, f"no [Platform] Name: the device is named '{guess}'", "note"
    )
    return guess


def _section_functions(block: _Block, section: Section, reader: _Reader, claims: list[_Claim]) -> list[Function]:
    """The functions of one section's entries, after checking them against its numberOfX."""
    count_key: _Key | None = None
    entries: dict[int, _Key] = {}
    for key in block.keys:
        if key.key.lower() == section.count_key.lower():
            if count_key is not None:
                reader.report(
                    key.line, key.key_col, f"{section.count_key} appears twice (first on line {count_key.line})"
                )
                continue
            count_key = key
            continue
        m = _INDEX.fullmatch(key.key)
        if m is None or m.group("tag").lower() != section.tag.lower():
            reader.report(
                key.line,
                key.key_col,
                f"[{section.name}] has no key {shown(key.key)} (entries are "
                f"{section.tag}0, {section.tag}1, ... and {section.count_key}): not read",
                "warning",
            )
            continue
        index = int(m.group("index"))
        if index in entries:
            reader.report(
                key.line, key.key_col, f"{section.tag}{index} appears twice (first on line {entries[index].line})"
            )
            continue
        entries[index] = key
    count = _count(count_key, section, reader)
    _check_count(block, section, count_key, count, entries, reader)
    out = []
    for index in sorted(entries):
        if count is not None and index >= count:
            continue
        fn = _entry(section, f"{section.tag}{index}", entries[index], reader, claims)
        if fn is not None:
            out.append(fn)
    return out


def _count(key: _Key | None, section: Section, reader: _Reader) -> int | None:
    if key is None:
        return None
    if _DIGITS.fullmatch(key.value) is None:
        reader.report(key.line, key.col, f"{section.count_key} must be a whole number, not {shown(key.value)}")
        return None
    return int(key.value)


def _check_count(
    block: _Block,
    section: Section,
    count_key: _Key | None,
    count: int | None,
    entries: dict[int, _Key],
    reader: _Reader,
) -> None:
    tag, name = section.tag, section.count_key
    if count_key is None:
        if entries:
            first = entries[min(entries)]
            reader.report(
                first.line,
                first.key_col,
                f"[{section.name}] has no {name}: the agent reads none of its "
                f"{len(entries)} entries (add {name}={len(entries)})",
            )
        return
    if count is None:
        return
    for index in sorted(entries):
        if index >= count:
            key = entries[index]
            reader.report(
                key.line,
                key.key_col,
                f"{tag}{index} is beyond {name}={count} (line {count_key.line}): "
                f"the agent reads {_span(tag, 0, count)} only",
            )
    missing = _runs([i for i in range(count) if i not in entries]) if count <= len(entries) + 1000 else None
    if missing is None:
        reader.report(count_key.line, count_key.col, f"{name}={count} but [{section.name}] has {len(entries)} entries")
    elif missing:
        listed = ", ".join(_span(tag, lo, hi) for lo, hi in missing)
        reader.report(count_key.line, count_key.col, f"{name}={count} but [{section.name}] has no {listed}")


def _span(tag: str, lo: int, hi: int) -> str:
    """`IR0..IR2` for the entries lo..hi-1 (`IR0` for one, `no entry` for none)."""
    if hi <= lo:
        return "no entry"
    return f"{tag}{lo}" if hi - lo == 1 else f"{tag}{lo}..{tag}{hi - 1}"


def _runs(indices: list[int]) -> list[tuple[int, int]]:
    """(first, end) of each run of indices that follow each other by one."""
    return [(start, start + count) for start, count in address_runs(indices)]


def _fields(key: _Key) -> list[_Field]:
    """The value split at every comma, as the agent's `strtok(str, ",")` splits it (quotes are not special),
    each field stripped, with its column; after the columns the agent reads, the rest of the line is one
    more field, commas and all."""
    out: list[_Field] = []
    start = 0
    for raw in key.value.split(",", len(COLUMNS)):
        lead = len(raw) - len(raw.lstrip())
        out.append(_Field(raw.strip(), key.col + start + lead, raw))
        start += len(raw) + 1
    return out


def _shifted(section: Section, label: str, key: _Key, fields: list[_Field], reader: _Reader) -> bool:
    """Whether a field the agent reads is empty with a field after it that is not: `strtok` skips the empty one
    and the agent reads every later field one column to the left, so the line is refused (reported)."""
    read = 2 if section.bits else len(COLUMNS)
    for i, fld in enumerate(fields[:read]):
        if fld.raw == "" and any(later.token for later in fields[i + 1 :]):
            reader.report(
                key.line,
                fld.col,
                f"{label}: the {COLUMNS[i]} field is empty: the agent (C strtok) skips "
                "an empty field and reads every later one a column to the left; "
                f"write the {COLUMNS[i]} (a unit may be one space)",
            )
            return True
    return False


def _entry(section: Section, label: str, key: _Key, reader: _Reader, claims: list[_Claim]) -> Function | None:
    """One entry line -> a function (None, with the line's errors reported, where it has any)."""
    fields = _fields(key)
    errors_before = reader.errors
    reader.entries += 1
    if reader.entries == MAX_ENTRIES + 1:
        reader.report(
            key.line,
            key.key_col,
            f"{label}: more than {MAX_ENTRIES:,} entries in the file, the most "
            "the reader takes (each table has 65,536 addresses)",
        )
    if reader.entries > MAX_ENTRIES or _shifted(section, label, key, fields, reader):
        return None
    offset = _offset(fields[0], label, key, reader)
    if offset is not None:
        claims.append(_claim(section, offset, label, key, fields, reader))
    if len(fields) < 2 or not fields[1].text:
        reader.report(
            key.line,
            key.col,
            f"{label}: no name (the line is offset,name{'' if section.bits else ',min,max,precision,unit,datatype'})",
        )
        return None
    name = fields[1].text
    fn = Function(
        name, name, [offset if offset is not None else 0], block_labels=[section.name], register_type=section.table
    )
    if section.bits:
        fn.format = "BIT"
        if len(fields) > 2 and not all(f.blank for f in fields[2:]):
            reader.report(
                key.line, fields[2].col, f"{label}: a bit line is offset,name; the rest is not read", "warning"
            )
    else:
        _register_fields(fn, fields, label, key, reader)
    if section.table == "holding":
        fn.register_type = None  # the default table: the model keeps only what differs
    if reader.errors > errors_before:
        return None
    fn.line = key.line
    record_span(fn, "", TextSpan(key.line, key.key_col))
    return fn


def _claim(section: Section, offset: int, label: str, key: _Key, fields: list[_Field], reader: _Reader) -> _Claim:
    """The registers (or bits) an entry reads: two for a 32-bit datatype (a datatype outside 0-8 is reported
    where the line's fields are read, and claims one)."""
    claim = _Claim(section.table, offset, label, key.line, fields[0].col)
    dtype = fields[6].text if not section.bits and len(fields) > 6 else ""
    if _DIGITS.fullmatch(dtype) is not None and 0 < int(dtype) < len(DATA_TYPES):
        claim.width = 2
        if offset + 1 > MAX_ADDRESS:
            reader.report(
                key.line,
                fields[0].col,
                f"{label}: datatype {dtype} reads two registers, and offset "
                f"{offset} is the table's last ({MAX_ADDRESS})",
            )
    return claim


def _offset(fld: _Field, label: str, key: _Key, reader: _Reader) -> int | None:
    if _DIGITS.fullmatch(fld.text) is None or int(fld.text) > MAX_ADDRESS:
        what = shown(fld.text) if fld.text else "nothing"
        reader.report(key.line, fld.col, f"{label}: the offset must be a wire address 0..{MAX_ADDRESS}, not {what}")
        return None
    return int(fld.text)


def _number(fld: _Field | None, what: str, label: str, key: _Key, reader: _Reader) -> float | None:
    if fld is None or not fld.text:
        return None
    if _NUMBER.fullmatch(fld.text) is None:
        reader.report(key.line, fld.col, f"{label}: {what} must be a number, not {shown(fld.text)}")
        return None
    value = float(fld.text)
    if value in (float("inf"), float("-inf")):
        reader.report(key.line, fld.col, f"{label}: {what} {said(fld.text)} is too large")
        return None
    return value


def _register_fields(fn: Function, fields: list[_Field], label: str, key: _Key, reader: _Reader) -> None:
    """min, max, precision, unit, datatype and Lua of a register line, into `fn`."""

    def at(i: int) -> _Field | None:
        return fields[i] if len(fields) > i else None

    low = _number(at(2), "min", label, key, reader)
    high = _number(at(3), "max", label, key, reader)
    precision = _number(at(4), "precision", label, key, reader)
    unit = at(5)
    dtype = DEFAULT_DATA_TYPE
    type_field = at(6)
    if type_field is not None and type_field.text:
        if _DIGITS.fullmatch(type_field.text) is None or int(type_field.text) >= len(DATA_TYPES):
            reader.report(key.line, type_field.col, f"{label}: datatype {shown(type_field.text)} is outside 0-8")
        else:
            dtype = DATA_TYPES[int(type_field.text)]
    lua = _lua_column(fields, label, key, reader) if len(fields) > 7 else None
    scale = 1.0 if not precision else precision  # the agent: precision 0 or absent means 1
    offset = 0.0
    if lua is not None:
        text, plain = lua
        if plain is None:
            fn.description = kept_in_description(fn.name, text)
            cut = "; the agent reads the column only up to its first comma" if len(fields) > 8 else ""
            reader.report(
                key.line,
                fields[7].col,
                f"{label} {shown(fn.name)}: the Lua column {shown(text)} is not plain "
                "arithmetic on modbus_val: kept in the description (export "
                f"writes it back), not applied{cut}",
                "warning",
            )
        else:  # the agent runs the Lua on the raw value, then multiplies by the precision
            offset = plain[1] * scale + 0.0
            scale = plain[0] * scale
    fn.format = dtype.format
    fn.byte_order = "little" if dtype.byte_order == "little" else None
    fn.word_order = "little" if dtype.word_order == "little" else None
    fn.multiplier = None if scale == 1 else scale
    fn.offset = offset or None
    fn.units = unit.text if unit is not None and unit.text else None
    low_col = fields[2].col if len(fields) > 2 else None
    if (low is None) != (high is None):  # the agent reads an absent one as 0
        absent = "max" if high is None else "min"
        reader.report(key.line, low_col, f"{label} {shown(fn.name)}: no {absent}: read as 0, as the agent does", "note")
        low, high = low or 0.0, high or 0.0
    if low is not None and high is not None:
        if low == high == 0:
            reader.report(
                key.line, low_col, f"{label} {shown(fn.name)}: min and max are both 0: read as no range", "note"
            )
            return
        if low > high:
            reader.report(
                key.line,
                low_col,
                f"{label} {shown(fn.name)}: min {low:g} is above max {high:g}: swapped, as the agent does",
                "warning",
            )
            low, high = high, low
    fn.minimum, fn.maximum = low, high


def _lua_column(fields: list[_Field], label: str, key: _Key, reader: _Reader) -> tuple[str, Affine | None] | None:
    """The Lua column as kept (everything after the datatype, a quoted column the text between its first two
    quotes) and the scaling applied (None: not plain arithmetic, not applied); None where there is no column.
    The agent runs the column up to its first comma, from after its first quote (and any quotes following
    it) to the next one; where that plain arithmetic is other text than the column as kept, or where the
    agent would get no number at all (it then reports -1 or 0), the line is refused (reported, None)."""
    column = fields[7]
    whole = ",".join(f.raw for f in fields[7:]).rstrip(", \t").strip()  # less Excel's trailing commas
    if whole.startswith('"'):
        whole = whole[1:].split('"', 1)[0].strip()
    agent: str | None = column.raw or None  # nothing between the commas: no token, no conversion
    if '"' in column.raw:
        after = column.raw[column.raw.index('"') + 1 :].lstrip('"')
        agent = None if len(column.raw) <= 2 else after.split('"', 1)[0]  # the agent skips a column of 2
        if agent == "":
            reader.report(
                key.line,
                column.col,
                f"{label}: the Lua column {shown(column.text)} has nothing between quotes "
                "for the agent, which then reports -1 for the value",
            )
            return None
    if agent is not None and not agent.strip():
        reader.report(
            key.line,
            column.col,
            f"{label}: the Lua column is only spaces: the agent's conversion "
            "then returns nothing and it reports 0 for the value",
        )
        return None
    agent = agent.strip() if agent is not None else None
    plain = affine(agent) if agent else None
    if plain is not None and agent is not None and agent != whole:
        reader.report(
            key.line,
            column.col,
            f"{label}: the agent runs {shown(agent)} as this line's Lua conversion (the "
            "column up to its first comma, between its first quotes), not "
            f"{shown(whole)}: write the column as one quoted expression without commas",
        )
        return None
    text = whole or agent
    if not text:
        return None
    return text, plain if text == agent else None


def _check_addresses(claims: list[_Claim], reader: _Reader) -> None:
    """A register (or bit) read by two entries of one table (in one section, or in both forms of it) is an
    error: every register of a 32-bit datatype counts, not only its offset."""
    first: dict[tuple[str, int], _Claim] = {}
    for claim in claims:
        clash: tuple[int, _Claim] | None = None
        for register in range(claim.offset, claim.offset + claim.width):
            other = first.setdefault((claim.table, register), claim)
            if other is not claim and clash is None:
                clash = register, other
        if clash is None:
            continue
        register, other = clash
        if claim.offset == other.offset and claim.width == other.width == 1:
            message = f"offset {claim.offset} of the {claim.table} table is already {other.label}'s (line {other.line})"
        else:
            message = (
                f"reads {claim.span} of the {claim.table} table; register {register} is already read by "
                f"{other.label} (line {other.line}: {other.span})"
            )
        reader.report(claim.line, claim.col, f"{claim.label}: {message}")


def _unique_names(functions: list[Function], reader: _Reader) -> None:
    """SPEC 3's rule for names: a name used again gets `_2`, `_3`...; said in a note (another section, as the
    agent's samples do) or a warning (the same section: the agent cannot tell the two apart)."""
    used: dict[str, Function] = {}
    tried: dict[str, int] = {}  # name -> the last suffix tried for it: each is tried once (linear time)
    for fn in functions:
        original = fn.name
        if original not in used:
            used[original] = fn
            continue
        other = used[original]
        n = tried.get(original, 1) + 1
        while f"{original}_{n}" in used:
            n += 1
        tried[original] = n
        fn.name = f"{original}_{n}"
        used[fn.name] = fn
        same = other.block == fn.block
        reader.report(
            fn.line,
            None,
            f"{shown(original)} is also the name of line {other.line}"
            f"{' in the same section' if same else f' ([{other.block}])'}: "
            f"this one is named {shown(fn.name)}",
            "warning" if same else "note",
        )
