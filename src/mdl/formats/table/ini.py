"""The device INI file (ORNL's format plus the extensions of SPEC section 4)."""

from __future__ import annotations

import codecs
import configparser
import re
from dataclasses import dataclass, field
from pathlib import Path

from mdl.diagnostics import Diagnostic, MdlError, shown
from mdl.exchange.text import unwritable
from mdl.fileio import read_bytes
from mdl.formats.table.readers.delimited import MAX_CELL_CHARS, decode_table
from mdl.formats.table.vocabulary import (
    CELL_SECTION,
    FUNCTION_SECTION,
    FunctionSection,
    check_cell_value,
    check_function_value,
    quoted_keys,
    split_synonyms,
)

COLUMN_KEYS = (
    "name",
    "description",
    "addresses",
    "length",
    "count",
    "format",
    "block_label",
    "multiplier",
    "divisor",
    "units",
    "read_function_code",
    "write_function_code",
    "register_type",
    "access",
    "minimum",
    "maximum",
    "offset",
    "word_order",
    "bits",
)
# what a [function NAME] section may set (SPEC 4.1)
FUNCTION_KEYS = (
    "format",
    "count",
    "bits",
    "multiplier",
    "divisor",
    "offset",
    "units",
    "register_type",
    "access",
    "byte_order",
    "word_order",
    "minimum",
    "maximum",
    "scale_exponent",
    "role",
    "addresses",
    "row",
    "expression",
)
DEVICE_KEYS = (
    "device_name",
    "device_description",
    "register_type",
    "address_base",
    "byte_order",
    "word_order",
    "count_unit",
    "threshold",
    "default_synonyms",
    "limits",
)
IO_KEYS = (
    "address_map_csv_file",
    "lines_to_skip",
    "output_xml_file",
    "delimiter",
    "decimal_separator",
    "encoding",
    "table",
    "sheet",
    "pages",
)
DELIMITER_WORDS = {"comma": ",", ",": ",", "semicolon": ";", "tab": "\t", "\\t": "\t", "pipe": "|", "|": "|"}
DECIMAL_WORDS = {"point": "point", ".": "point", "dot": "point", "comma": "comma", ",": "comma"}
SECTIONS = {
    "modbus device": "device",
    "input/output": "io",
    "column/field indices": "columns",
    "additional column/field indices": "additional",
    "function name search synonyms": "synonyms",
}
CHOICES = {
    "register_type": ("holding", "input", "coil", "discrete"),
    "address_base": ("0", "1", "modicon", "hex"),
    "byte_order": ("big", "little"),
    "word_order": ("big", "little"),
    "count_unit": ("words", "bytes"),
    "limits": ("scaled", "raw"),
    "default_synonyms": ("yes", "no", "true", "false", "1", "0", "on", "off"),
}


@dataclass
class DeviceIni:
    path: Path | None = None
    device: dict[str, str] = field(default_factory=dict)
    csv_file: Path | None = None
    lines_to_skip: int | None = None
    output_file: Path | None = None
    delimiter: str | None = None  # , ; \t |
    decimal: str | None = None  # point | comma
    encoding: str | None = None  # the table's (a Python codec name); None: UTF-8, else said as a guess
    table: int | None = None  # which table of a .md/.html file (or sheet of a workbook), 1-based
    pages: str | None = None  # which pages of a PDF manual are read (`12-19`, `3,5-7`)
    sheet: str | None = None  # which sheet of an .xlsx workbook, by name
    columns: dict[str, int | str] = field(default_factory=dict)  # key -> index or header text
    blank_columns: set[str] = field(default_factory=set)  # keys the INI lists as absent
    claimed: list[int | str] = field(default_factory=list)  # columns of [Additional ...]
    default_synonyms: bool = False
    synonyms: dict[str, list[str]] = field(default_factory=dict)
    threshold: float | None = None
    warnings: list[Diagnostic] = field(default_factory=list)
    notes: list[Diagnostic] = field(default_factory=list)  # guesses made reading the INI itself
    lines: dict[tuple[str, str], int] = field(default_factory=dict)  # (section kind, key) -> its line
    # [<field> cells]: field -> cell text (trimmed, lower case) -> the text csv2xml reads instead
    cells: dict[str, dict[str, str]] = field(default_factory=dict)
    functions: dict[str, FunctionSection] = field(default_factory=dict)  # [function NAME], by NAME

    def line(self, kind: str, key: str) -> int | None:
        """The line a key is written on (kind: device, io, columns ...; key in lowercase)."""
        return self.lines.get((kind, key))


# a key: up to its first = or :, without the spaces before it (tried only where a run of spaces starts,
# so that a long run not followed by = or : is passed over once, not once for each of its characters)
_KEY = re.compile(r"\s*([^#;=:\s][^=:]*?)(?<!\s)\s*[=:]")


def _line_numbers(text: str) -> dict[tuple[str, str | None], int]:
    """(section, key) -> line, with (section, None) for the header line; each section both as written and
    in lower case (names are case-insensitive, but two spellings of one name are two sections)."""
    out: dict[tuple[str, str | None], int] = {}
    names: tuple[str, ...] = ()
    for no, line in enumerate(text.splitlines(), 1):
        m = re.match(r"\s*\[(.+?)\]", line)
        if m:
            names = (m.group(1).strip(), m.group(1).strip().lower())
            for name in names:
                out.setdefault((name, None), no)
            continue
        m = _KEY.match(line)
        for name in names if m else ():
            out.setdefault((name, m.group(1).strip()), no)  # type: ignore[union-attr]
    return out


def _whole(value: str) -> int | None:
    """ASCII digits -> int (up to 9 of them: no table has more lines or columns); None for anything else."""
    return int(value) if re.fullmatch(r"[0-9]{1,9}", value) else None


class _CaseKeepingParser(configparser.ConfigParser):
    """Keys keep their case: they name functions. A key line is read by the linear twin of
    configparser's own pattern (whose `.*?\\s*` is quadratic in a long run of spaces)."""

    OPTCRE = re.compile(r"(?P<option>[^=:]*?)(?<!\s)\s*(?P<vi>[=:])\s*(?P<value>.*)$")

    def optionxform(self, optionstr: str) -> str:
        return optionstr


def _parse(text: str, path: Path) -> configparser.ConfigParser:
    parser = _CaseKeepingParser(
        interpolation=None,
        inline_comment_prefixes=(";",),
        comment_prefixes=("#", ";"),
        strict=True,
        empty_lines_in_values=False,
    )
    try:
        parser.read_string(text, source=str(path))
    except configparser.Error as exc:
        raise MdlError(Diagnostic(str(path), getattr(exc, "lineno", None), None, _problem(exc))) from None
    return parser


def _problem(exc: configparser.Error) -> str:
    if isinstance(exc, configparser.MissingSectionHeaderError):
        return "a key before any [section]"
    if isinstance(exc, configparser.DuplicateSectionError):
        return f"section [{exc.section}] appears twice"
    if isinstance(exc, configparser.DuplicateOptionError):
        return f"key {shown(exc.option)} appears twice in [{exc.section}]"
    return f"not an INI file: {exc.message.splitlines()[0]}"


def is_ini(path: Path) -> bool:
    """Whether `mdl csv2xml PATH` names a device INI (which names the CSV) rather than the CSV."""
    return path.suffix.lower() in (".ini", ".cfg", ".conf")


def _codec(value: str) -> str | None:
    """A text encoding's name as Python knows it, None for anything else (an unknown name, base64)."""
    try:
        name = codecs.lookup(value).name
        b"a".decode(name)  # a codec of bytes to bytes (base64) or text to text (rot13) says it is no text encoding
    except LookupError:
        return None
    except UnicodeDecodeError:
        pass  # a text encoding in which `a` alone is no text (utf-16)
    return name


def _refuse_long_lines(text: str, path: Path) -> None:
    """A line of the INI longer than a table's longest cell (MAX_CELL_CHARS) is refused with its number:
    no key or value is that long, and every value becomes a cell's match or an element of the MDL."""
    for no, line in enumerate(text.splitlines(), 1):
        if len(line) > MAX_CELL_CHARS:
            raise MdlError(
                Diagnostic(str(path), no, None, f"a line of {len(line):,} characters: the limit is {MAX_CELL_CHARS:,}")
            )


def read_ini(path: Path) -> DeviceIni:
    text, guess = decode_table(read_bytes(path), path)
    _refuse_long_lines(text, path)
    text, quoted = quoted_keys(text)
    lines = _line_numbers(text)
    parser = _parse(text, path)
    ini = DeviceIni(path=path)
    if guess:  # the INI's own encoding (its `encoding` key is the table's): saving it as UTF-8 says it
        ini.notes.append(
            Diagnostic(str(path), None, None, f"{guess.why}; save the INI as UTF-8 to be sure of its text", "note")
        )
    errors: list[Diagnostic] = []

    def where(section: str, key: str | None = None) -> int | None:
        exact = section.strip()
        return (
            lines.get((exact, key))
            or lines.get((section.lower(), key))
            or lines.get((exact, None))
            or lines.get((section.lower(), None))
        )

    def warn(section: str, key: str | None, message: str) -> None:
        ini.warnings.append(Diagnostic(str(path), where(section, key), None, message, "warning"))

    def err(section: str, key: str | None, message: str) -> None:
        errors.append(Diagnostic(str(path), where(section, key), None, message))

    base = path.parent
    for section in parser.sections():
        kind = SECTIONS.get(section.strip().lower())
        cell_field = CELL_SECTION.match(section.strip()) if kind is None else None
        function = FUNCTION_SECTION.match(section.strip()) if kind is None else None
        if cell_field and cell_field.group(1).lower() in COLUMN_KEYS:
            name = cell_field.group(1).lower()
            section_line = where(section)
            if section_line:
                ini.lines[("cells", name)] = section_line
            for key, raw in parser.items(section):
                cell = " ".join(quoted.get(key, key).split()).lower()
                try:
                    value = check_cell_value(name, (raw or "").strip())
                except ValueError as exc:
                    err(section, key, f"[{section}] {shown(quoted.get(key, key))}: {exc}")
                    continue
                ini.cells.setdefault(name, {})[cell] = value
            continue
        if cell_field:
            err(section, None, f"[{section}]: no field {shown(cell_field.group(1))} (fields: {', '.join(COLUMN_KEYS)})")
            continue
        if function:
            fs = FunctionSection(function.group(1).strip(), where(section))
            for key, raw in parser.items(section):
                lkey, value = key.strip().lower(), (raw or "").strip()
                if lkey not in FUNCTION_KEYS:
                    err(section, key, f"[{section}] cannot set {shown(key)} (it sets {', '.join(FUNCTION_KEYS)})")
                    continue
                try:
                    fs.values[lkey] = check_function_value(lkey, value)
                except ValueError as exc:
                    err(section, key, f"[{section}] {lkey} = {value}: {exc}")
                fs.lines[lkey] = where(section, key) or 0
            twin = next((n for n in ini.functions if n.lower() == fs.name.lower()), None)
            if twin is not None:  # section names are case-insensitive (SPEC 4.1)
                err(section, None, f"function {shown(fs.name)} has two [function] sections ([function {twin}] too)")
            ini.functions[fs.name] = fs
            continue
        if kind is None:
            warn(section, None, f"unknown section [{section}] is ignored")
            continue
        for key, raw in parser.items(section):
            value = (raw or "").strip()
            lkey = key.strip().lower()
            line = where(section, key)
            if line is not None:
                ini.lines[(kind, lkey)] = line
            if "\n" in value and kind != "synonyms":  # only synonym lists may go on over indented lines
                err(
                    section,
                    key,
                    f"the value of {shown(key)} goes on over the next line: an indented line continues the one "
                    "before it",
                )
            elif kind == "synonyms":
                try:
                    words = split_synonyms(value)
                except ValueError as exc:
                    err(section, key, f"synonyms of {shown(key)}: {exc}")
                    continue
                if not words:
                    err(section, key, f"function {shown(key)} has no synonyms")
                ini.synonyms[key.strip()] = words
            elif kind == "additional":
                if value:  # user-defined columns (e.g. operation_info): informational, never guessed
                    index = _whole(value)
                    ini.claimed.append(value if index is None else index)
            elif kind == "columns":
                if lkey not in COLUMN_KEYS:
                    warn(section, key, f"unknown column key {shown(key)} is ignored")
                elif value:
                    index = _whole(value)
                    ini.columns[lkey] = value if index is None else index
                else:
                    ini.blank_columns.add(lkey)
            elif kind == "device":
                if lkey not in DEVICE_KEYS:
                    warn(section, key, f"unknown key {shown(key)} in [{section}] is ignored")
                elif lkey == "threshold":
                    try:
                        ini.threshold = float(value)
                        if not 0 <= ini.threshold <= 1:
                            raise ValueError
                    except ValueError:
                        err(section, key, f"threshold must be a number from 0 to 1, not {shown(value)}")
                elif lkey in CHOICES and value and value.lower() not in CHOICES[lkey]:
                    err(section, key, f"{lkey} must be one of {', '.join(CHOICES[lkey])}, not {shown(value)}")
                elif unwritable(value):
                    err(section, key, f"{lkey} holds the character {unwritable(value)}, which MDL (XML) cannot carry")
                elif value:
                    ini.device[lkey] = value.lower() if lkey in CHOICES else value
            elif kind == "io":
                if lkey not in IO_KEYS:
                    warn(section, key, f"unknown key {shown(key)} in [{section}] is ignored")
                elif lkey == "lines_to_skip" and value:
                    ini.lines_to_skip = _whole(value)
                    if ini.lines_to_skip is None:
                        err(section, key, f"lines_to_skip must be a whole number, not {shown(value)}")
                elif lkey == "table" and value:
                    ini.table = _whole(value)
                    if not ini.table:
                        err(section, key, f"table must be a table's number, 1 or more, not {shown(value)}")
                elif lkey == "sheet" and value:
                    ini.sheet = value
                elif lkey == "pages" and value:
                    ini.pages = value
                elif lkey == "address_map_csv_file" and value:
                    ini.csv_file = base / value
                elif lkey == "output_xml_file" and value:
                    ini.output_file = base / value
                elif lkey == "delimiter" and value:
                    ini.delimiter = DELIMITER_WORDS.get(value.lower())
                    if ini.delimiter is None:
                        err(section, key, f"delimiter must be one of comma, semicolon, tab, pipe, not {shown(value)}")
                elif lkey == "encoding" and value:
                    ini.encoding = _codec(value)
                    if ini.encoding is None:
                        err(
                            section,
                            key,
                            f"encoding must name a text encoding (utf-8, cp1252, latin-1, utf-16 ...), "
                            f"not {shown(value)}",
                        )
                elif lkey == "decimal_separator" and value:
                    ini.decimal = DECIMAL_WORDS.get(value.lower())
                    if ini.decimal is None:
                        err(section, key, f"decimal_separator must be point or comma, not {shown(value)}")
    ini.default_synonyms = ini.device.pop("default_synonyms", "no") in ("yes", "true", "1", "on")
    if errors:
        raise MdlError(errors)
    return ini
