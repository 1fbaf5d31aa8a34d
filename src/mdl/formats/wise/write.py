"""A resolved device -> WISE-Agent `Modbus.ini` in the shipped agent's form (`mdl export --to wise`, SPEC 7).

`[Platform]` takes the connection from the command line (TCP: Protocol=Modbus_TCP, ClientIP, ClientPort,
UnitID; a serial line: Protocol=Modbus_RTU, SlavePort, Baud, Parity, DataBits, StopBits, SlaveID;
Interval in whole seconds). Each function becomes a line of its table's section: coils and discrete
inputs `offset,name`; registers `offset,name,min,max,precision,unit,datatype[,lua]`, where precision is
the multiplier, and an offset is written as the Lua column `modbus_val*m+o` (precision 1 then). Every
field is written, never left empty: the agent splits a line with strtok, which skips an empty field
and shifts the rest (no unit is written as one space; no minimum/maximum as the range of the raw value,
scaled). What the format cannot express is a warning: a function it cannot read at all is left out
(fragments, expressions, text, bytes, 64-bit values, byte orders datatypes 0-8 do not have, addresses not
next to each other, and SPEC 2.2's `bits` and scale registers: an entry reads whole registers, scaled by a
constant precision); one it reads with a loss is written and the loss named. One warning per kind of
loss, naming every function it concerns (mdl.exchange.notes, as the engines do).

No text can make a line of its own or shift the columns: the agent splits the file at line breaks and a line
at commas (strtok), so a name or unit has its commas, quotes, control characters and line breaks of every
kind (NEL, U+2028, U+2029 too) written as `_`, the Lua column its quotes and line breaks refused, and the
device's name (`[Platform] Name`) its line breaks written as spaces: each change said in a warning. `=`, `[`,
`;` and `#` inside a value are kept: a key ends at the line's first `=`, and only a line's first character
makes a section or a comment. The header comments escape what does not print (mdl.exchange.text.comment_text).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from mdl import __version__
from mdl.diagnostics import Diagnostic
from mdl.exchange.connection import Endpoint
from mdl.exchange.export import Export, Settings
from mdl.exchange.notes import LeftOut, Lost, Notes, bits_detail, factor_detail
from mdl.exchange.text import comment_text
from mdl.formats.wise.lua import KEPT, kept_lua, kept_twice
from mdl.formats.wise.sections import (
    AGENT_SECTIONS,
    DATA_TYPES,
    LUA_VARIABLE,
    DataType,
    agent_section,
    data_type_of,
)
from mdl.model import IDENTITY_FIELDS, READ_ONLY_TABLES, Function
from mdl.model.layout import integer_range

if TYPE_CHECKING:
    from mdl.model.layout import Layout
    from mdl.resolver import ResolvedDevice, ResolvedFunction

FLOAT32_MAX = 3.4028234663852886e38
_RAW_RANGE = {
    "UINT16": integer_range(16, False),
    "UINT32": integer_range(32, False),
    "INT32": integer_range(32, True),
    "FLOAT32": (-FLOAT32_MAX, FLOAT32_MAX),
}
_BREAKS = r"\x00-\x1f\x7f-\x9f\u2028\u2029"  # control characters (C0, DEL, C1 with NEL) and line/paragraph separators
_UNSAFE = re.compile(f'[,"{_BREAKS}]')  # what would split or end an INI line
_UNSAFE_LUA = re.compile(f'["{_BREAKS}]')  # what would end the quoted Lua column or its line
_LINE_BREAKING = re.compile(f"[{_BREAKS}]")
PARITY = {"N": "None", "E": "Even", "O": "Odd"}


class _Warn(Protocol):
    def __call__(self, message: str, severity: str = "warning") -> None: ...


class _Skip(LeftOut):
    """The function cannot be written to a Modbus.ini."""


@dataclass
class _Line:
    rf: ResolvedFunction
    table: str
    offset: int
    name: str
    rest: list[str] = field(default_factory=list)  # the fields after the name
    losses: list[Lost] = field(default_factory=list)
    lua: str | None = None  # a Lua conversion kept in the description and written back

    @property
    def fn(self) -> Function:
        return self.rf.fn


def export_wise(resolved: ResolvedDevice, settings: Settings) -> Export:
    """`mdl export --to wise`: the Modbus.ini text and a warning for each thing it cannot express."""
    text, warnings = wise_ini(resolved, settings.connection, settings.unit, settings.interval)
    return Export(text, warnings=warnings)


def wise_ini(
    resolved: ResolvedDevice, connection: Endpoint | None, unit: int, interval: float
) -> tuple[str, list[Diagnostic]]:
    source = resolved.device.source
    notes = Notes(resolved, "")

    def warn(message: str, severity: str = "warning") -> None:  # about the device
        (notes.device_warning if severity == "warning" else notes.note)(message)

    lines = _lines(resolved, notes)
    _device_losses(resolved, lines, warn)
    out = [
        f"; WISE-Agent Modbus handler configuration for {comment_text(resolved.name)}",
        f"; written by mdl {__version__}" + (f" from {comment_text(Path(source).name)}" if source else ""),
        "",
    ]
    out += _platform(resolved.name, connection, unit, interval, warn)
    for section in AGENT_SECTIONS:
        entries = sorted(lines[section.table], key=lambda e: e.offset)
        if not entries:
            continue
        out += ["", f"[{section.name}]", f"{section.count_key}={len(entries)}"]
        out += [f"{section.tag}{i}=" + ",".join([str(e.offset), e.name, *e.rest]) for i, e in enumerate(entries)]
    out += [
        "",
        ";tag = offset, name, min, max, precision, unit, data type, lua script",
        ";precision multiplies the raw value; the lua script (on modbus_val) runs before it",
        ";data type",
    ]
    out += [f";{d.code}->{d.summary} ({d.letters})" for d in DATA_TYPES]
    return "\n".join(out) + "\n", notes.found


def _lines(resolved: ResolvedDevice, notes: Notes) -> dict[str, list[_Line]]:
    """The line of each function a Modbus.ini can hold, by table; each other function, and each loss, warned."""
    lines: dict[str, list[_Line]] = {s.table: [] for s in AGENT_SECTIONS}
    taken: dict[tuple[str, int], str] = {}
    for rf in resolved.functions:
        try:
            line = _line(rf)
        except _Skip as skip:
            notes.warn(rf, f"not written: {skip.why}", skip.detail)
            continue
        where = (line.table, line.offset)
        if where in taken:
            notes.warn(
                rf,
                "not written: its offset is taken by an entry before it (the agent reads one entry per offset)",
                f"{line.table} {line.offset}: '{taken[where]}'",
            )
            continue
        taken[where] = rf.name
        _unique_name(line, lines[line.table], notes)
        for why, detail in line.losses:
            notes.warn(rf, f"written, losing {why}", detail)
        if line.lua is not None:
            notes.warn(
                rf,
                "written with the Lua conversion its description keeps: the agent applies it, mdl does not",
                f"'{line.lua}'",
            )
        lines[line.table].append(line)
    return lines


def _platform(name: str, connection: Endpoint | None, unit: int, interval: float, warn: _Warn) -> list[str]:
    out = ["[Platform]", f"Name={_value(name, 'the device name', warn)}"]
    if connection is None:
        connection = Endpoint()
        warn(
            f"no --host or --serial: the agent is set to ClientIP={connection.host} ClientPort={connection.port}",
            "note",
        )
    if connection.serial is not None:
        out += [
            "Protocol=Modbus_RTU",
            f"SlavePort={_value(connection.serial, '--serial', warn)}",
            f"Baud={connection.baud}",
            f"Parity={PARITY.get(connection.parity, connection.parity)}",
            f"DataBits={connection.bytesize}",
            f"StopBits={connection.stopbits}",
            f"SlaveID={unit}",
        ]
    else:
        if connection.rtu:
            warn(
                "the agent speaks Modbus TCP or RTU on a serial port, not RTU frames over TCP: "
                "written as Protocol=Modbus_TCP"
            )
        out += [
            "Protocol=Modbus_TCP",
            f"ClientIP={_value(connection.host, '--host', warn)}",
            f"ClientPort={connection.port}",
            f"UnitID={unit}",
        ]
    seconds = max(1, round(interval))
    if seconds != interval:
        warn(f"the agent polls every whole number of seconds: Interval={seconds} for --interval {interval:g}")
    return [*out, f"Interval={seconds}", "Log=0"]


def _line(rf: ResolvedFunction) -> _Line:
    """The function's Modbus.ini line, or _Skip saying why there is none."""
    fn, lay = rf.fn, rf.layout
    if fn.bits is not None:
        raise _Skip("bits of a register (an entry reads whole registers)", bits_detail(fn))
    if fn.factor is not None:
        raise _Skip("scaled by another register (an entry's precision is a constant)", factor_detail(fn))
    if fn.expression is not None:
        raise _Skip("computed by an expression (WISE has none)")
    if fn.read_function_code is not None:
        raise _Skip("read by a C fragment (WISE has none)")
    losses = _losses(fn)
    lua = kept_lua(fn.description)
    if lay.kind == "bool" and lay.unit == "bit":
        if lua is not None:
            losses.append(("the Lua conversion its description keeps (a bit line has no Lua column)", f"'{lua}'"))
        return _Line(rf, lay.table, lay.addresses[0], fn.name, [], losses)
    if lay.kind == "string":
        raise _Skip("text (STRING): WISE reads numbers")
    if lay.unit != "word":
        raise _Skip("a byte of a register: WISE reads whole registers", "lower" if lay.unit == "low" else "upper")
    offset, dtype = _data_type(fn, lay, losses)
    lo, hi = _RAW_RANGE[dtype.format]
    multiplier, add = fn.eff_multiplier, fn.eff_offset
    low = fn.minimum if fn.minimum is not None else min(lo * multiplier + add, hi * multiplier + add)
    high = fn.maximum if fn.maximum is not None else max(lo * multiplier + add, hi * multiplier + add)
    unit = (fn.units or "").strip()
    if _UNSAFE.search(fn.units or ""):
        losses.append(("the commas, quotes and control characters of its unit", repr(fn.units)))
        unit = _UNSAFE.sub("_", fn.units or "").strip()
    if lua is not None and kept_twice(fn.description):
        losses.append(
            (
                f"the Lua conversion its description keeps (it holds '{KEPT}' twice: where the Lua text "
                "starts is not clear)",
                None,
            )
        )
        lua = None
    elif lua is not None and _UNSAFE_LUA.search(lua):
        losses.append(
            (
                "the Lua conversion its description keeps (quotes and control characters cannot be "
                "written in the Lua column)",
                repr(lua),
            )
        )
        lua = None
    elif lua is not None and add != 0 and "--" in lua:
        losses.append(
            (
                "the Lua conversion its description keeps (its `--` comment would hide the offset the Lua column adds)",
                f"'{lua}'",
            )
        )
        lua = None
    rest = [_number(low), _number(high), _number(multiplier if add == 0 else 1.0), unit or " ", str(dtype.code)]
    column = _lua_column(lua, multiplier, add)
    if column is not None:
        rest.append(f'"{column}"')
    return _Line(rf, lay.table, offset, fn.name, rest, losses, lua)


def _lua_column(lua: str | None, multiplier: float, add: float) -> str | None:
    """The Lua column: the kept conversion (the agent multiplies its result by the precision, the multiplier);
    with an offset, the conversion or modbus_val times the multiplier plus the offset, and precision 1."""
    if add == 0:
        return lua
    value = LUA_VARIABLE if lua is None else f"({lua})"
    scaled = value if multiplier == 1 else f"{value}*{_number(multiplier)}"
    return f"{scaled}{'+' if add > 0 else '-'}{_number(abs(add))}"


def _data_type(fn: Function, lay: Layout, losses: list[Lost]) -> tuple[int, DataType]:
    """The first address and datatype of a value in registers (losses appended), or _Skip."""
    fmt = fn.eff_format
    if lay.kind == "bool":
        losses.append(("true/false (the agent reads the register's number)", None))
        return lay.addresses[0], DATA_TYPES[0]
    if len(lay.addresses) == 1:
        if lay.byte_order == "little":
            raise _Skip("its bytes are swapped: WISE reads a 16-bit register as it comes")
        if lay.bits == 8:
            losses.append(("an 8-bit format (the agent reads the whole 16-bit register, unsigned)", fmt))
        elif lay.signed:
            losses.append(
                ("a signed format (the agent reads the register unsigned: a negative value reads 65536 higher)", fmt)
            )
        return lay.addresses[0], DATA_TYPES[0]
    if len(lay.addresses) != 2:
        raise _Skip("a value of neither 16 nor 32 bits: WISE reads 16 or 32 bits", f"{lay.bits} bits")
    first, second = lay.addresses
    word_order = lay.word_order
    if second == first - 1:  # listed high address first: the same as word order reversed
        first, word_order = second, "little" if word_order == "big" else "big"
    elif second != first + 1:
        raise _Skip("registers not next to each other", f"registers {first} and {second}")
    kind = "FLOAT32" if lay.kind == "float" else "INT32" if lay.signed else "UINT32"
    dtype = data_type_of(kind, lay.byte_order, word_order)
    if dtype is None:
        raise _Skip(
            "no WISE datatype reads its byte and word order",
            f"{kind} with byte order {lay.byte_order} and word order {word_order}",
        )
    return first, dtype


def _losses(fn: Function) -> list[Lost]:
    """What the line cannot say about the function, apart from its value's layout."""
    out: list[Lost] = []
    if fn.values:
        out.append(("its enumeration (the agent shows the number)", None))
    if fn.not_implemented:
        out.append(("its not_implemented values (the agent shows the number)", " ".join(fn.not_implemented)))
    if fn.write_function_code is not None:
        out.append(("its write fragment", None))
    if fn.table not in READ_ONLY_TABLES and fn.eff_access != "read_write":
        out.append(("its access (the agent reads and writes the table)", f"{fn.eff_access}, {fn.table}"))
    lost = [
        name
        for name in ("precision", "marker", "write_multiple", "immutable", "system", "fetch_group")
        if getattr(fn, name) is not None
    ]
    if lost:
        out.append(("fields a Modbus.ini line has not", ", ".join(lost)))
    return out


def _unique_name(line: _Line, section: list[_Line], notes: Notes) -> None:
    """A name the line can hold, unique in its section (the agent finds an entry by section and name)."""
    name = _UNSAFE.sub("_", line.name).strip() or "unnamed"
    used = {e.name for e in section}
    base, n = name, 1
    while name in used:
        n += 1
        name = f"{base}_{n}"
    if name != line.name:
        notes.warn(
            line.rf,
            "written under another name (a name in a Modbus.ini has no commas, quotes, control "
            "characters or line breaks and is unique in its section)",
            f"as '{name}'",
        )
    line.name = name


def _device_losses(resolved: ResolvedDevice, lines: dict[str, list[_Line]], warn: _Warn) -> None:
    device = resolved.device
    lost = [name for name in IDENTITY_FIELDS if getattr(device, name) is not None]
    if device.max_registers is not None:
        lost.append("max_registers")
    if device.tests:
        lost.append(f"its {len(device.tests)} test scenario{'s' * (len(device.tests) != 1)}")
    if lost:
        warn("written without the device's " + ", ".join(lost) + " (a Modbus.ini has none)")
    relabelled = sorted(
        {
            line.fn.block
            for entries in lines.values()
            for line in entries
            if line.fn.block and line.fn.block != agent_section(line.table).name
        }
    )
    if relabelled:
        warn(
            "block labels " + ", ".join(f"'{b}'" for b in relabelled) + " are not kept: the agent's sections "
            "are its tables ([Coils], [Holding Registers]...)"
        )


def _number(value: float) -> str:
    """A number as the file writes it: whole numbers without a point, others in Python's shortest form."""
    if math.isfinite(value) and value.is_integer() and abs(value) < 1e16:
        return str(int(value))
    return repr(float(value))


def _value(text: str, what: str, warn: _Warn) -> str:
    """Text as the value of a `key=value` line: control characters and line breaks as spaces, without the
    spaces at its ends (the agent strips them); a warning where that changes it."""
    value = _LINE_BREAKING.sub(" ", text).strip()
    if value != text:
        warn(f"{what} is written as {value!r} (a Modbus.ini value is one line, without spaces at its ends)")
    return value
