"""The words of a SmartServer Modbus XIF (`.mod`) file, in one place: product lines, column headings
(the current ones of SmartServer 3.2 and later, and the names files written for earlier releases
use), native types, function codes and write enable values. The reader and the writer both take
them from here."""

from __future__ import annotations

from mdl.exchange.text import FORMULA_STARTS
from mdl.records import record

FILETYPE = "Modbus_xif"

# product line key (lowercase, after the '#') -> the Device attribute it fills
PRODUCT_LINES = {
    "program_id": "program_id",
    "version": "product_version",
    "product_name": "product",
    "manufacturer": "manufacturer",
    "description": "description",
}
# the order and spelling export writes them in (after `#filetype,Modbus_xif`)
PRODUCT_LINE_NAMES = (
    ("program_ID", "program_id"),
    ("version", "product_version"),
    ("product_name", "product"),
    ("manufacturer", "manufacturer"),
    ("description", "description"),
)

# column key -> the current heading (what export writes)
CURRENT = {
    "block": "Block Name",
    "block_index": "Block Index",
    "name": "Datapoint Name",
    "modicon": "Modicon",
    "address": "Address",
    "function_code": "Function Code",
    "native": "Native Type",
    "ascii_length": "ASCII Length",
    "word_order": "Word Order",
    "byte_order": "Byte Order",
    "bit_order": "Bit Order",
    "iap_type": "IAP Type",
    "iap_field": "IAP Field",
    "write": "Write Enable",
    "precision": "Precision",
    "native_1": "Native Value 1",
    "native_2": "Native Value 2",
    "scaled_1": "Scaled Value 1",
    "scaled_2": "Scaled Value 2",
    "range_min": "Range Min",
    "range_max": "Range Max",
    "marker": "Marker Value",
    "description": "Description",
}
# column key -> the headings files made for SmartServer releases before 3.2 use
LEGACY = {
    "name": ("Point Name",),
    "native": ("Modbus datatype", "DATATYPE"),
    "iap_type": ("Presentation type",),
    "iap_field": ("SNVT FIELD",),
    "write": ("Direction",),
    "description": ("Description (optional)",),
    "a": ("A'",),
    "b": ("B'",),
    "c": ("C'",),
    "multiplier": ("Multiplier",),
    "offset": ("Offset",),
    "in_feedback": ("inFeedback",),
}
# headings only files of the 3.1 format have (the others above also appear in later files): a file
# with one gives wire addresses, as releases before 3.5 read them, never Modicon numbers
PRE_35_HEADINGS = ("Point Name", "Direction", "A'", "B'", "C'", "inFeedback")
REQUIRED = ("name", "address", "native", "write")  # a datapoint header without one of these is refused
IGNORED = ("iap_type", "iap_field", "in_feedback")  # read and not kept: MDL has no place for them
SCALING_POINTS = ("native_1", "native_2", "scaled_1", "scaled_2")

# the columns export writes, in this order
EXPORT_COLUMNS = (
    "block",
    "block_index",
    "name",
    "modicon",
    "address",
    "function_code",
    "native",
    "ascii_length",
    "word_order",
    "byte_order",
    "iap_type",
    "write",
    "precision",
    *SCALING_POINTS,
    "range_min",
    "range_max",
    "marker",
    "description",
)


def normalize(heading: str) -> str:
    """A heading as compared: case and spacing ignored, typographic apostrophes as `'`."""
    return " ".join(heading.replace("\u2019", "'").replace("\u2032", "'").lower().split())


# normalized heading -> (column key, whether it is a pre-3.2 name)
HEADINGS: dict[str, tuple[str, bool]] = {normalize(text): (key, False) for key, text in CURRENT.items()}
HEADINGS.update({normalize(text): (key, True) for key, texts in LEGACY.items() for text in texts})
PRE_35 = frozenset(normalize(text) for text in PRE_35_HEADINGS)


def heading_names(key: str) -> str:
    """How messages name a column: its current heading, and its pre-3.2 names."""
    names = [CURRENT[key]] if key in CURRENT else []
    names += LEGACY.get(key, ())
    return " / ".join(f"'{n}'" for n in names)


@record
class Native:
    """A native type: the MDL format it reads as and the registers one value takes (strings: from
    ASCII Length, `chars` characters in each register)."""

    name: str
    format: str
    registers: int
    chars: int = 0  # characters per register (strings)


NATIVE_TYPES = {
    n.name: n
    for n in (
        Native("BIT", "BIT", 1),
        Native("UINT8", "UINT8", 1),
        Native("SINT8", "INT8", 1),
        Native("UINT16", "UINT16", 1),
        Native("SINT16", "INT16", 1),
        Native("UINT32", "UINT32", 2),
        Native("SINT32", "INT32", 2),
        Native("UINT64", "UINT64", 4),
        Native("SINT64", "INT64", 4),
        Native("FLOAT32", "FLOAT32", 2),
        Native("FLOAT64", "FLOAT64", 4),
        Native("CHAR8", "STRING", 0, 1),  # one 8-bit character in each register (its low byte)
        Native("CHAR8_2", "STRING", 0, 2),  # two 8-bit characters in each register, high byte first
        Native("CHAR16", "STRING", 0, 1),  # one 16-bit character in each register
    )
}
NATIVE_ALIASES = {"FLOAT": "FLOAT32"}  # what real files write besides the vendor's names
STRING_TYPES = ("CHAR8", "CHAR8_2", "CHAR16")

# read function code -> MDL table, and back
FUNCTION_TABLES = {1: "coil", 2: "discrete", 3: "holding", 4: "input"}
TABLE_CODES = {table: f"FC{code:02d}" for code, table in FUNCTION_TABLES.items()}
WRITE_CODES = (5, 6, 15, 16)

# write enable (and the pre-3.2 Direction) -> (writable, always a multiple write)
WRITE_ENABLE = {
    "-": (False, False),
    "+": (True, False),
    "++": (True, True),
    "r": (False, False),
    "rw": (True, False),
    "r/w": (True, False),
}
ORDERS = ("big", "little")

# the IAP type export writes for a value of each kind (a SmartServer needs one; edit to taste)
IAP_COUNT, IAP_SIGNED, IAP_FLOAT, IAP_TEXT = "SNVT_count", "SNVT_count_inc", "SNVT_count_f", "SNVT_str_asc"


# Text cells (names, descriptions, block names, product line values) and a spreadsheet. A cell starting
# with one of FORMULA_STARTS (OWASP's CSV injection list, as every export has it) is a formula to Excel or
# LibreOffice: export writes such a text behind a `'` (as a spreadsheet marks text), and import takes that
# `'` away again. A text already starting with `'` and one of these or another `'` gets one too, so every
# text comes back.
TEXT_MARK = "'"
# what ends a line to someone: `str.splitlines` splits at each (a cell holding one would start a row)
LINE_BREAKS = "\n\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"


def marked(text: str) -> bool:
    """Whether export writes `text` behind a `'`."""
    return text[:1] in FORMULA_STARTS or (text[:1] == TEXT_MARK and text[1:2] in (*FORMULA_STARTS, TEXT_MARK))


def unmarked(text: str) -> str | None:
    """`text` without the `'` export put before it; None if it has none."""
    if text[:1] == TEXT_MARK and text[1:2] in (*FORMULA_STARTS, TEXT_MARK):
        return text[1:]
    return None


def line_break(text: str) -> str | None:
    """The first line break of `text`, as `U+000A`; None if it has none."""
    for ch in text:
        if ch in LINE_BREAKS:
            return f"U+{ord(ch):04X}"
    return None


def register_part(native: Native, byte_order: str | None) -> str:
    """Which part of its first register a datapoint's value takes: `low` or `high` byte (8-bit
    numbers and CHAR8/CHAR16 characters: the high one with Byte Order little), else the `word`. Two
    datapoints of a file may not start on the same part of the same register."""
    if native.format in ("UINT8", "INT8") or native.chars == 1:
        return "high" if byte_order == "little" else "low"
    return "word"
