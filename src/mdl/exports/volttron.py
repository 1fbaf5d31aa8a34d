"""`mdl export --to volttron`: VOLTTRON's Modbus-TK driver files (SPEC 11).

Three files for the platform driver's configuration store, named by the device's stem:
- `<stem>_map.csv`, the register map the driver's `Map` reads: Register Name, Address (wire address:
  the config's `addressing` is `offset`), Type, Units, Writable, Default Value, Transform, Table,
  Mixed Endian, Description;
- `<stem>.csv`, the registry: Volttron Point Name (the function's name) -> Register Name (its identifier);
- `<stem>.config`, the device configuration (JSON): `driver_config` (connection, `slave_id`,
  `addressing`, `endian`, `register_map`), `driver_type: "modbus_tk"`, `registry_config`, `interval`.

Types follow the driver's own rules (volttron.driver.interfaces.modbus_tk.utils.maps and helpers):
the named types (`int16` ... `uint64`, `float`, `bool`, `string[N]`) are read with the device's
`endian` (big here) and `Mixed Endian` reverses the registers of one value; any other Type is a
Python struct format with its own byte order, which is how a little-endian word (`<h`), a float64
(`>d`) or one byte of a register (`>xB`: the lower byte) is said. `scale(m)` multiplies and rounds
to the decimal places of m, so it is exact for integers scaled by a decimal multiplier; a float
scaled, a negative or exponent-form multiplier, an offset (no transform adds one) leave the
function out with a warning, as do expressions and fragments. So does a BIT in a holding or input
register (mdl: true when the register is not 0): the driver's `bool` there unpacks one byte from two
and fails the whole poll, and no type or transform tests a register for 0.

Bits and scale registers (SPEC 2.2): no type or transform reads bits of a register (left out, warned). A
`scale_exponent` without multiplier or offset is `scale_reg_pow_10(REG)` (helpers.py: value * 10^REG, rounded
to the decimal places of str(10^REG), the same double as mdl's value / 10^|e| for -4 <= e <= 22), REG the
factor's Register Name; the transform's syntax takes letters, digits and points only
(its pattern's `[a-zA-Z0-9.]*` in maps), so a factor named otherwise gets a Register Name of its letters and
digits (its point keeps its name). `scale_reg(REG)` divides by the register where `scale_by` multiplies,
so a `scale_by` is left out, as is a scaled value with a multiplier or offset (one transform a point).

Writes (utils/client.py `write_all`): one coil is written with function 5 even where the function says
write_multiple (warned); registers with function 16 when the config's `write_multiple_registers` is
true, else one register with function 6 (which writes a struct-format or multi-register value wrong).
It is false where every writable register function is one int16/uint16 register that mdl writes with
function 6; true otherwise, with one warning naming the functions then written with 16 where mdl uses 6.

The CSVs are written by Python's csv module (a cell holding a comma, a quote or a line break is quoted);
a cell of free text (Units, Description, Volttron Point Name) that starts with a formula character
(`=` `+` `-` `@`, tab, carriage return) gets a single quote in front, with a warning (spreadsheet_cell in
mdl.exchange.text).
"""

from __future__ import annotations

import csv
import io
import re
from typing import TYPE_CHECKING

from mdl.diagnostics import error
from mdl.exchange.export import Export
from mdl.exchange.text import json_text, spreadsheet_cell
from mdl.exports.base import (
    Notes,
    bit_in_register,
    bits_detail,
    connection_of,
    decimals,
    factor_detail,
    hex_pattern,
    left_out_unreadable,
    nothing_left,
    patterns_of,
    plain_number,
    scale_factor,
    scale_of,
    write_code,
    written_by_fragment,
)

if TYPE_CHECKING:
    from mdl.exchange.export import Settings
    from mdl.model.layout import Layout
    from mdl.resolver import ResolvedDevice, ResolvedFunction

ENGINE = "VOLTTRON"
MAP_COLUMNS = (
    "Register Name",
    "Address",
    "Type",
    "Units",
    "Writable",
    "Default Value",
    "Transform",
    "Table",
    "Mixed Endian",
    "Description",
)
REGISTRY_COLUMNS = ("Volttron Point Name", "Register Name")
TABLES = {
    "coil": "discrete_output_coils",
    "discrete": "discrete_input_contacts",
    "input": "analog_input_registers",
    "holding": "analog_output_holding_registers",
}
_NAMED = {
    ("int", 16, True): "int16",
    ("int", 16, False): "uint16",
    ("int", 32, True): "int32",
    ("int", 32, False): "uint32",
    ("int", 64, True): "int64",
    ("int", 64, False): "uint64",
    ("float", 32, True): "float",
}
_STRUCT = {
    ("int", 16, True): "h",
    ("int", 16, False): "H",
    ("int", 32, True): "i",
    ("int", 32, False): "I",
    ("int", 64, True): "q",
    ("int", 64, False): "Q",
    ("float", 32, True): "f",
    ("float", 64, True): "d",
}
_PARITY = {"N": "none", "E": "even", "O": "odd"}
_SINGLE_TYPES = ("int16", "uint16")  # what the driver writes right with function 6 (no struct format, one register)


NO_TYPE = "no VOLTTRON type holds its value"


def _shape(lay: Layout) -> str:
    return f"a {lay.bits}-bit {lay.kind} in {len(lay.addresses)} registers"


def volttron_type(lay: Layout) -> tuple[str, bool] | str:
    """(Type, Mixed Endian) that reads the layout as mdl does, or why there is none (NO_TYPE: `_shape` says
    what the value is)."""
    n = len(lay.addresses)
    if lay.kind == "bool":
        return "bool", False
    pad = "x"  # a struct pad byte: the other byte of the register
    if lay.unit in ("low", "high"):
        code = "b" if lay.signed else "B"
        return (f">{pad}{code}" if lay.unit == "low" else f">{code}{pad}"), False
    if lay.kind == "string":
        if lay.byte_order != "big":
            return "its text has its bytes swapped in each register (byte_order little), which string[N] cannot read"
        return f"string[{2 * n}]", False
    if n == 1 and lay.bits == 8:  # an 8-bit format in a full word: its lower byte, after the byte order
        code = "b" if lay.signed else "B"
        return (f">{pad}{code}" if lay.byte_order == "big" else f">{code}{pad}"), False
    key = (lay.kind, lay.bits, lay.signed)
    if key not in _STRUCT or lay.bits != 16 * n:
        return NO_TYPE
    if lay.byte_order == "big":  # >: ABCD; mixed: CDAB
        return _NAMED.get(key, ">" + _STRUCT[key]), n > 1 and lay.word_order == "little"
    return "<" + _STRUCT[key], n > 1 and lay.word_order == "big"  # <: DCBA; mixed: BADC


_TRANSFORM_ARG = re.compile(r"[a-zA-Z0-9.]+")  # what the driver's Transform syntax takes between parentheses
POW_10 = "scale_reg_pow_10"


def _factor_transform(f: ResolvedFunction, notes: Notes) -> str | None:
    """`scale_reg_pow_10(<factor>)` for a scale_exponent the driver computes as mdl does (the factor's
    Register Name filled in by `_name_factors`), or None (warned)."""
    step = scale_factor(f)
    assert step is not None
    if not step.exponent:
        notes.warn(
            f,
            "scale_reg(REG) divides the value by the register, where scale_by multiplies: left out",
            factor_detail(f.fn),
        )
        return None
    if step.multiplier != 1 or step.offset != 0:
        notes.warn(
            f,
            f"{POW_10}() is the point's one transform, so no multiplier or offset goes with it: left out",
            factor_detail(f.fn),
        )
        return None
    notes.warn(
        f,
        f"{POW_10}() rounds to the decimal places of str(10**e): an exponent below -4 rounds the value "
        "to a whole number, and a factor mdl reads as null (its not_implemented, or beyond +-22) gives a "
        "number",
        factor_detail(f.fn),
    )
    return f"{POW_10}({f.fn.factor})"


def _transform(f: ResolvedFunction, notes: Notes) -> str | None:
    """The Transform cell ("" for none), or None when the scaling cannot be said (warned)."""
    if f.fn.factor is not None:
        return _factor_transform(f, notes)
    step = scale_of(f)
    if step is None:
        return ""
    if step.offset != 0:
        notes.warn(f, "no transform adds an offset: left out", f"offset {plain_number(step.offset)}")
        return None
    m = step.multiplier
    if f.layout.kind == "float":
        notes.warn(
            f,
            "scale(m) rounds to the decimal places of m, which would cut a float: left out",
            f"scale({plain_number(m)}): {decimals(m)} places",
        )
        return None
    if m < 0 or "e" in str(m):
        notes.warn(
            f,
            "scale() cannot take the multiplier (its CSV syntax has no sign and it rounds by the digits "
            "of str(m)): left out",
            f"multiplier {plain_number(m)}",
        )
        return None
    return f"scale({plain_number(m)})"


def _row(f: ResolvedFunction, notes: Notes) -> dict[str, str] | None:
    if f.fn.readable and left_out_unreadable(f, notes):
        return None
    if f.fn.bits is not None:
        notes.warn(
            f,
            "no VOLTTRON type or transform reads bits of a register (a struct format reads whole bytes): left out",
            bits_detail(f.fn),
        )
        return None
    if bit_in_register(f):
        notes.warn(
            f,
            f"a BIT in the {f.layout.table} registers (true when the register is not 0): the driver's bool "
            "type there unpacks one byte and fails the whole poll, and no type or transform tests a "
            "register for 0: left out",
        )
        return None
    found = volttron_type(f.layout)
    if isinstance(found, str):
        notes.warn(f, f"{found}: left out", _shape(f.layout) if found == NO_TYPE else None)
        return None
    vtype, mixed = found
    transform = _transform(f, notes)
    if transform is None:
        return None
    writable = f.fn.writable
    if writable and written_by_fragment(f):
        notes.warn(f, "a write fragment encodes it, which VOLTTRON cannot: exported read-only")
        writable = False
    if not f.fn.readable:
        if not writable:
            notes.warn(f, "neither readable nor writable here: left out")
            return None
        notes.warn(f, "write-only, but VOLTTRON polls every point it knows: it will read this one too")
    if writable and transform.startswith(POW_10):
        notes.warn(
            f,
            f"writes through {POW_10}() take integers only (the driver packs value / 10^e, a float, into "
            "the integer register and fails) and cut the raw value where mdl rounds it",
        )
    elif writable and transform:
        notes.warn(
            f,
            "writes through scale() take integers only (the driver packs value / m, a float, into the "
            "integer register and fails) and cut the raw value where mdl rounds it",
        )
    if writable and f.layout.table == "coil" and write_code(f) == 15:
        notes.warn(f, "write_multiple: the driver writes one coil with function 5, never 15")
    if writable and (f.fn.minimum is not None or f.fn.maximum is not None):
        notes.warn(f, "writes outside minimum/maximum are not refused")
    patterns = patterns_of(f)
    if patterns:
        notes.warn(
            f,
            "no 'not implemented' value: the values that mean it read as numbers",
            ", ".join(map(hex_pattern, patterns)),
        )
    if f.fn.values:
        notes.warn(f, "no enumeration: the number is reported, not its label")
    if f.layout.kind == "string":
        notes.warn(f, "the text keeps the NUL padding that mdl strips")
    return {
        "Register Name": f.ident,
        "Address": str(f.layout.addresses[0]),
        "Type": vtype,
        "Units": _cell(f, "Units", f.fn.units or "", notes),
        "Writable": "TRUE" if writable else "FALSE",
        "Default Value": "",
        "Transform": transform,
        "Table": TABLES[f.layout.table],
        "Mixed Endian": "TRUE" if mixed else "FALSE",
        "Description": _cell(f, "Description", " ".join(f.fn.description.split()), notes),
    }


def _cell(f: ResolvedFunction, column: str, text: str, notes: Notes) -> str:
    """A cell of free text that a spreadsheet opening the CSV shows as text, never runs as a formula."""
    cell = spreadsheet_cell(text)
    if cell != text:
        notes.warn(
            f,
            f"its {column} cell starts with {text[0]!r}, which a spreadsheet runs as a formula: written "
            "with a single quote in front"
            + (" (the point's name in VOLTTRON too)" if column == "Volttron Point Name" else ""),
            f"{cell[:20]!r}" + ("..." if len(cell) > 20 else ""),
        )
    return cell


def _csv(columns: tuple[str, ...], rows: list[dict[str, str]]) -> str:
    """The CSV text: cells quoted where needed, and every cell of a row holding a carriage return (which
    Python's csv writer leaves unquoted when the lines end in \\n, and every reader takes for a line end)."""
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=columns, lineterminator="\n")
    quoted = csv.DictWriter(out, fieldnames=columns, lineterminator="\n", quoting=csv.QUOTE_ALL)
    writer.writeheader()
    for row in rows:
        (quoted if any("\r" in cell for cell in row.values()) else writer).writerow(row)
    return out.getvalue()


def _write_multiple_registers(resolved: ResolvedDevice, rows: dict[str, dict[str, str]], notes: Notes) -> bool:
    """The config's write_multiple_registers: false (function 6 for each register, as mdl writes one register)
    where every writable register is a named 16-bit type mdl writes with 6; else true (function 16 for
    every register write), with a warning naming the functions mdl would write with 6."""
    written = [
        (row["Type"], f)
        for f in resolved.functions
        if (row := rows.get(f.ident)) is not None and row["Writable"] == "TRUE" and row["Table"] == TABLES["holding"]
    ]
    needs = [(vtype, f) for vtype, f in written if write_code(f) == 16 or vtype not in _SINGLE_TYPES]
    if not needs:
        return not written  # nothing to write: the driver's default
    single = [f.name for _, f in written if write_code(f) == 6]
    if single:
        vtype, f = needs[0]
        why = (
            "mdl writes it with function 16"
            if write_code(f) == 16
            else f"the driver writes its type {vtype} right with function 16 only"
        )
        notes.device_warning(
            f"write_multiple_registers is one setting for the device: true, as '{f.name}' needs "
            f"({why}), so function 16 writes what mdl writes with function 6: "
            f"{', '.join(single)}"
        )
    return True


def _config(resolved: ResolvedDevice, settings: Settings, notes: Notes, multiple: bool) -> str:
    conn = connection_of(settings, notes)
    stem = resolved.stem
    driver: dict[str, object] = {"name": resolved.name}
    if conn.serial is not None:
        driver.update(
            device_address=conn.serial,
            baudrate=conn.baud,
            bytesize=conn.bytesize,
            parity=_PARITY[conn.parity],
            stopbits=conn.stopbits,
            xonxoff=0,
        )
    else:
        if conn.rtu:
            raise error(
                "VOLTTRON's Modbus-TK driver speaks Modbus TCP or RTU on a serial line, not RTU framing "
                "over TCP (--framer rtu)",
                resolved.device.source,
            )
        driver.update(device_address=conn.host, port=conn.port)
    driver.update(
        slave_id=settings.unit,
        addressing="offset",
        endian="big",
        write_multiple_registers=multiple,
        register_map=f"config://{stem}_map.csv",
    )
    interval: float | int = int(settings.interval) if settings.interval == int(settings.interval) else settings.interval
    config = {
        "driver_config": driver,
        "driver_type": "modbus_tk",
        "registry_config": f"config://{stem}.csv",
        "interval": interval,
    }
    return json_text(config, indent=4)


def _name_factors(resolved: ResolvedDevice, rows: dict[str, dict[str, str]], notes: Notes) -> None:
    """Each scale_reg_pow_10 row's Transform given its factor's Register Name (one the Transform syntax takes,
    renamed where needed); a row whose factor is not exported is dropped, with a warning."""
    by_name = {f.name: f for f in resolved.functions}
    taken = set(rows)
    renamed: dict[str, str] = {}
    for f in resolved.functions:
        row = rows.get(f.ident)
        if row is None or not row["Transform"].startswith(POW_10):
            continue
        factor = by_name[f.fn.factor or ""]
        if factor.ident not in rows:
            notes.warn(
                f,
                "its factor is not exported, and the transform reads the factor's register: left out",
                factor_detail(f.fn),
            )
            del rows[f.ident]
            continue
        name = renamed.get(factor.ident, factor.ident)
        if not _TRANSFORM_ARG.fullmatch(name):
            base = re.sub(r"[^a-zA-Z0-9]", "", name) or "factor"
            name = next(c for c in (base, *(f"{base}{i}" for i in range(2, len(taken) + 3))) if c not in taken)
            taken.add(name)
            renamed[factor.ident] = name
            notes.note_for(
                factor,
                "Register Name written without the characters the driver's Transform syntax "
                "does not take (its point keeps its name)",
                name,
            )
        row["Transform"] = f"{POW_10}({name})"
    for ident, name in renamed.items():
        rows[ident]["Register Name"] = name


def export_volttron(resolved: ResolvedDevice, settings: Settings) -> Export:
    notes = Notes(resolved, ENGINE)
    by_ident = {f.ident: row for f in resolved.functions if (row := _row(f, notes)) is not None}
    _name_factors(resolved, by_ident, notes)
    rows = list(by_ident.values())
    if not rows:
        raise nothing_left(resolved, ENGINE, notes)
    registry = [
        {
            "Volttron Point Name": _cell(f, "Volttron Point Name", f.name, notes),
            "Register Name": by_ident[f.ident]["Register Name"],
        }
        for f in resolved.functions
        if f.ident in by_ident
    ]
    stem = resolved.stem
    files = {
        f"{stem}_map.csv": _csv(MAP_COLUMNS, rows),
        f"{stem}.csv": _csv(REGISTRY_COLUMNS, registry),
        f"{stem}.config": _config(resolved, settings, notes, _write_multiple_registers(resolved, by_ident, notes)),
    }
    return Export(files=files, warnings=notes.found)
