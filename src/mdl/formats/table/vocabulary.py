"""What an INI says a table's words mean (SPEC 4.1): `[<field> cells]` maps (a vendor's cell -> the text
csv2xml reads instead), `[function NAME]` sections (one function's fields, winning over its row's cells)
and synonyms holding a comma in double quotes. The INI reader (ini.py) checks the values with these;
rows.py reads mapped cells, convert.py applies the function sections; every use is said in a note."""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field

from mdl.diagnostics import Diagnostic, MdlError, error, shown
from mdl.formats.table.cells import (
    CellError,
    parse_access,
    parse_bit_cell,
    parse_length,
    parse_table,
    parse_word_order,
    read_address_cell,
    read_mapped_format,
)
from mdl.formats.table.numbers import parse_int, parse_number
from mdl.formats.table.report import Report
from mdl.model import Function
from mdl.model.layout import Layout, LayoutError, layout
from mdl.resolver.checks import bound_problems
from mdl.resolver.packing import packing_problems

CELL_SECTION = re.compile(r"(?i)^(\w+)\s+cells$")
FUNCTION_SECTION = re.compile(r"(?i)^function\s+(\S.*)$")
# the indent is spaces and tabs only: a run of blank lines before it is not tried from each of its lines
_QUOTED_KEY = re.compile(r'^([^\S\n]*)"([^"\n]*)"(?=\s*[=:])', re.MULTILINE)
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
ORDERS = ("big", "little")


@dataclass
class FunctionSection:
    name: str
    line: int | None
    values: dict[str, str] = field(default_factory=dict)  # key -> value as written (checked)
    lines: dict[str, int] = field(default_factory=dict)  # key -> its line in the INI


def quoted_keys(text: str) -> tuple[str, dict[str, str]]:
    """Keys written in double quotes (`"R/W: yes" = read_write`) replaced by placeholders configparser
    reads whole (it splits a key at its first `=` or `:`); placeholder -> the quoted text."""
    found: dict[str, str] = {}

    def hide(m: re.Match[str]) -> str:
        key = f"mdlquotedkey{len(found)}"
        found[key] = m.group(2)
        return m.group(1) + key

    return _QUOTED_KEY.sub(hide, text), found


def split_synonyms(value: str) -> list[str]:
    """`a, b, "Harmonic, THD,U L1-N"` (also over indented lines) -> the phrases; ValueError for an
    unclosed quote."""
    words: list[str] = []
    for line in value.splitlines():
        if line.count('"') % 2:
            raise ValueError(f"a '\"' is not closed in {shown(line.strip())}")
        for cell in next(csv.reader([line], skipinitialspace=True)):
            if cell.strip():
                words.append(cell.strip())
    return words


def number_of(value: str, what: str, scale: bool = False) -> float:
    try:
        n = parse_number(value, "point", what, scale=scale)
    except CellError as exc:
        raise ValueError(str(exc)) from None
    if n is None:
        raise ValueError(f"{what} must be a number")
    return n.value


def _read(key: str, value: str) -> None:
    """ValueError unless `value` reads as a cell of field `key`."""
    readers = {
        "format": read_mapped_format,
        "register_type": parse_table,
        "access": parse_access,
        "length": parse_length,
        "word_order": parse_word_order,
        "bits": parse_bit_cell,
        "addresses": read_address_cell,
    }
    try:
        if key in readers:
            readers[key](value)
        elif key == "count" and parse_int(value) < 1:
            raise CellError("a count is 1 or more")
    except CellError as exc:
        raise ValueError(str(exc)) from None
    if key in ("multiplier", "divisor", "minimum", "maximum", "offset"):
        number_of(value, key, scale=key in ("multiplier", "divisor"))


def check_cell_value(key: str, value: str) -> str:
    """A `[<key> cells]` value: empty (the cell says nothing) or a cell csv2xml reads as that field."""
    if value:
        _read(key, value)
    return value


def check_function_value(key: str, value: str) -> str:
    """A `[function NAME]` value, checked; ValueError saying what it should be."""
    if not value:
        raise ValueError("no value")
    if key in ("byte_order", "word_order"):
        if value.lower() not in ORDERS:
            raise ValueError("must be big or little")
        return value.lower()
    if key == "row":
        if re.fullmatch(r"(?i)p[0-9]{1,5}:r[0-9]{1,6}", value):
            return value.lower()  # a PDF table's row, as messages name it
        if not (value.isascii() and value.isdigit()) or int(value) < 1:
            raise ValueError("must be a line number of the table (1 or more), or a PDF's row as p14:r7")
        return value
    if key == "scale_exponent" and not _IDENTIFIER.match(value):
        raise ValueError("must name a function (letters, digits, _)")
    if key in ("divisor", "multiplier") and number_of(value, key, scale=True) == 0:
        raise ValueError(f"a {key} of 0 loses every value")
    if key not in ("units", "role", "scale_exponent"):
        _read(key, value)
    return value


def mapped(cells: dict[str, dict[str, str]], key: str, text: str) -> str | None:
    """What `[<key> cells]` says the cell means, or None when it does not map it."""
    found = cells.get(key)
    return found.get(" ".join(text.split()).lower()) if found else None


def multiplier_of(fs: FunctionSection) -> float | None:
    if "divisor" in fs.values:
        return 1.0 / number_of(fs.values["divisor"], "divisor", scale=True)
    if "multiplier" in fs.values:
        return number_of(fs.values["multiplier"], "multiplier", scale=True)
    return None


def function_problems(fn: Function, functions: Mapping[str, Function], lay: Layout | None = None) -> list[str]:
    """What makes `fn` impossible (its layout, bounds, bits, scale factor, role), the first first. A
    function with an expression is checked where every expression is, by the resolve step. `lay`:
    the function's layout, where the caller has it."""
    if fn.expression is not None:
        return []
    if lay is None:
        try:
            lay = layout(fn)
        except LayoutError as exc:
            return [str(exc)]
    problems = bound_problems(fn, lay) + [
        m for m, severity, _ in packing_problems(fn, lay, functions) if severity == "error"
    ]
    if fn.multiplier is not None and not math.isfinite(fn.multiplier):
        problems.append("the scale is not a finite number")
    return problems


# what a field left out means (MDL's defaults), as the notes of [function NAME] name it
_DEFAULT_SHOWN = {"register_type": "holding", "access": "read_write", "byte_order": "big", "word_order": "big"}


def _shown(attr: str, value: object) -> str:
    """A field's value as a note names it: a number as written, a field left out by what it means."""
    if value is None or value == "":
        return _DEFAULT_SHOWN.get(attr, "no value")
    if isinstance(value, list):  # addresses: as MDL writes them
        return " ".join(map(str, value))
    return f"{value:g}" if isinstance(value, float) else str(value)


_BESIDE_EXPRESSION = ("format", "count", "bits", "multiplier", "divisor", "offset", "byte_order", "word_order")


def apply_function(fs: FunctionSection, fn: Function) -> list[tuple[int | None, str]]:
    """Set the section's fields on `fn`; one note (INI line, text) per field that changed (whether the
    function is still possible is function_problems')."""
    said: list[tuple[int | None, str]] = []
    v = fs.values

    def change(key: str, attr: str, new: object) -> None:
        old = getattr(fn, attr)
        setattr(fn, attr, new)
        text = f"{fs.name}: {attr} {_shown(attr, new)} from [function {fs.name}]"
        if old != new:
            text += (
                f" instead of the table's '{_shown(attr, old)}'"
                if old not in (None, "")
                else (f" instead of {_shown(attr, old)}")
            )
        said.append((fs.lines.get(key), text))  # every override is said, the table's value kept or not

    replaced = [
        k for k in ("format", "count", "bits", "multiplier", "divisor", "offset", "byte_order", "word_order") if k in v
    ]
    if "expression" in v and replaced:
        raise ValueError(
            f"expression gives the whole value: {', '.join(replaced)} cannot stand beside it (write it in)"
        )
    if "register_type" in v:
        table = parse_table(v["register_type"])
        change("register_type", "register_type", None if table == "holding" else table)
    if "addresses" in v:
        cell = read_address_cell(v["addresses"])
        change("addresses", "addresses", cell.addresses)
        if cell.bits:
            change("addresses", "bits", cell.bits)
    if "format" in v:
        fmt = read_mapped_format(v["format"])
        change("format", "format", fmt.typed.format)
        if fmt.count or fmt.typed.strlen:
            change("format", "count", fmt.count or -(-(fmt.typed.strlen or 0) // 2))
        if fmt.bits or fmt.typed.bits:
            change("format", "bits", fmt.bits or fmt.typed.bits)
    if "count" in v:
        change("count", "count", parse_int(v["count"]))
    if "bits" in v:
        change("bits", "bits", parse_bit_cell(v["bits"]))
    if len(fn.addresses) > 1:  # a list of addresses is its own count
        fn.count = len(fn.addresses)
    if fn.count == 1:
        fn.count = None
    for key in ("byte_order", "word_order"):
        if key in v:
            change(key, key, None if v[key] == "big" else v[key])
    scale = multiplier_of(fs)
    if scale is not None:
        change("divisor" if "divisor" in v else "multiplier", "multiplier", None if scale == 1 else scale)
    for key in ("offset", "minimum", "maximum"):
        if key in v:
            change(key, key, number_of(v[key], key))
    if "access" in v:
        access = parse_access(v["access"])
        change("access", "access", None if access == "read_write" else access)
    for key in ("units", "scale_exponent", "role"):
        if key in v:
            change(key, key, v[key])
    if "expression" in v:  # the value is the expression's (SPEC 2.2): what the table's cells said of it goes
        change("expression", "expression", v["expression"])
        fn.format = fn.count = fn.multiplier = fn.offset = fn.bits = fn.length = None
        fn.byte_order = fn.word_order = None
    return said


def apply_sections(
    sections: dict[str, FunctionSection], where: str, out: list[Function], report: Report, said: Collection[str] = ()
) -> None:
    """Each [function NAME] section's fields onto its function, each change a note at the INI's line
    (`where`: the INI); a warning for a section whose function matched no row (but not for those in
    `said`, whose best row was skipped: a warning said why already); an error at the section for a
    function they leave impossible."""
    by_name = {fn.name: fn for fn in out}
    applied = []
    for name, fs in sections.items():
        fn = by_name.get(name)
        if fn is None and name in said:
            continue
        if fn is None:
            report.warn(
                f"[function {name}]: no row matched {name}, so its fields are not used; give it synonyms "
                "or row = N (the table's line)",
                fs.line,
                file=where,
            )
            continue
        try:
            for line, message in apply_function(fs, fn):
                report.note(message, line, file=where)
        except (ValueError, CellError) as exc:
            raise error(str(exc), where, fs.line) from None
        applied.append((fs, fn))
    errors = [
        Diagnostic(where, fs.line, None, f"[function {fs.name}] leaves {fs.name} impossible: {problems[0]}")
        for fs, fn in applied
        if (problems := function_problems(fn, by_name))
    ]
    if errors:
        raise MdlError(errors)
