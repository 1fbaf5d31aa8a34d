"""The typed model of an MDL document.

Fields hold exactly what the document says (None where an element is absent); the properties
apply the defaults of SPEC section 2, so writing a loaded model back never adds defaults.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias

if TYPE_CHECKING:
    from mdl.diagnostics import Diagnostic

LENGTHS = ("Lower byte", "Upper byte", "Full word")
FORMATS_09 = ("INT8", "UINT8", "INT16", "UINT16", "INT32", "UINT32")
FORMATS = FORMATS_09 + ("INT64", "UINT64", "FLOAT32", "FLOAT64", "STRING", "BIT")
REGISTER_TYPES = ("holding", "input", "coil", "discrete")
ORDERS = ("big", "little")
ACCESS = ("read", "write", "read_write")
BIT_TABLES = ("coil", "discrete")
READ_ONLY_TABLES = ("input", "discrete")

Scalar: TypeAlias = bool | int | float | str  # a value the codec decodes or encodes
Value: TypeAlias = Scalar | list[str] | None  # a function's value as read (a bitset: its labels; None: no value)


class CompiledExpression(Protocol):
    """A function's expression as the resolve step compiles it (mdl.dsl.expr.fields.Compiled, kept on
    mdl.resolver.ResolvedFunction, never on the model): the model names only what its layout reads,
    so it does not depend on the expression language."""

    @property
    def lowered(self) -> Any: ...  # mdl.dsl.expr.lower.Lowered

    @property
    def deps(self) -> list[str]: ...  # the functions it names, in parameter order

    @property
    def type(self) -> str: ...  # its value's type: long, double, string, bool or list


# a pattern's text, compiled where it is used (re.compile keeps it): no compiling at import (issue 40)
_BITS = r"\s*([0-9]{1,2})\s*(?:-\s*([0-9]{1,2})\s*)?"


def parse_bits(text: str) -> tuple[int, int] | None:
    """`N` or `N-M` (either order) -> (lowest, highest) bit; None if the text is neither."""
    m = re.compile(_BITS).fullmatch(text)
    if m is None:
        return None
    a = int(m.group(1))
    b = int(m.group(2)) if m.group(2) is not None else a
    return min(a, b), max(a, b)


# element name -> attribute, in schema order; used by the loader and writer alike
EXTENSION_FIELDS = (
    "register_type",
    "byte_order",
    "word_order",
    "offset",
    "access",
    "minimum",
    "maximum",
    "not_implemented",
    "values",
    "expression",
    "immutable",
    "system",
    "fetch_group",
    "marker",
    "precision",
    "write_multiple",
    "bits",
    "scale_exponent",
    "scale_by",
    "role",
    "initial",
)

# the device's identity elements (SPEC 2.2), in schema order, after its description
IDENTITY_FIELDS = ("manufacturer", "product", "product_version", "program_id")


@dataclass
class Function:
    name: str
    description: str
    addresses: list[int]
    length: str | None = None
    count: int | None = None
    format: str | None = None
    block_labels: list[str] = field(default_factory=list)
    multiplier: float | None = None
    units: str | None = None
    read_function_code: str | None = None
    write_function_code: str | None = None
    register_type: str | None = None
    byte_order: str | None = None
    word_order: str | None = None
    offset: float | None = None
    access: str | None = None
    minimum: float | None = None
    maximum: float | None = None
    not_implemented: list[str] | None = None
    values: dict[int, str] | None = None
    expression: str | None = None
    immutable: bool | None = None
    system: bool | None = None
    fetch_group: str | None = None
    marker: list[int] | None = None  # raw values it reads on a device of this kind (mdl discover)
    precision: int | None = None  # decimal places to show; display only
    write_multiple: bool | None = None  # FC16/FC15 even for one register or coil
    bits: str | None = None  # "N" or "N-M": one bit (a boolean) or a range (an unsigned integer) of the value
    scale_exponent: str | None = None  # the function whose integer e scales this one by 10^e
    scale_by: str | None = None  # the function whose value multiplies this one
    role: str | None = None  # a profile's name for what the value is (SPEC 13); kept, not used here
    initial: list[int] | None = None  # raw register (or bit) values `mdl sim` starts with
    line: int | None = field(default=None, compare=False, repr=False)
    expression_line: int | None = field(default=None, compare=False, repr=False)

    @property
    def eff_length(self) -> str:
        return self.length or "Full word"

    @property
    def eff_count(self) -> int:
        return self.count if self.count is not None else 1

    @property
    def eff_format(self) -> str:
        return self.format or "INT8"

    @property
    def eff_multiplier(self) -> float:
        return 1.0 if self.multiplier is None else self.multiplier

    @property
    def eff_offset(self) -> float:
        return 0.0 if self.offset is None else self.offset

    @property
    def scales(self) -> bool:
        """Whether a multiplier or an offset applies (SPEC 2.3: then the value is a float)."""
        # eff_multiplier and eff_offset spelled out: asked several times of every function
        return (self.multiplier is not None and self.multiplier != 1.0) or (
            self.offset is not None and self.offset != 0.0
        )

    @property
    def bit_range(self) -> tuple[int, int] | None:
        """(lowest, highest) bit of `bits`, either order accepted; None without `bits` or where the
        text is not `N` or `N-M` (mdl.resolver says so)."""
        return parse_bits(self.bits) if self.bits is not None else None

    @property
    def mask_write(self) -> bool:
        """Written with function 22 (Mask Write Register): `write_function_code` 22 on a function with bits."""
        return self.write_function_code is not None and self.write_function_code.strip() == "22"

    @property
    def factor(self) -> str | None:
        """The function whose value scales this one (scale_exponent or scale_by), if any."""
        return self.scale_exponent if self.scale_exponent is not None else self.scale_by

    @property
    def table(self) -> str:
        return self.register_type or "holding"

    @property
    def eff_byte_order(self) -> str:
        return self.byte_order or "big"

    @property
    def eff_word_order(self) -> str:
        return self.word_order or "big"

    @property
    def eff_access(self) -> str:
        if self.access:
            return self.access
        if self.expression is not None:
            return "read"
        return "read" if self.table in READ_ONLY_TABLES else "read_write"

    @property
    def block(self) -> str:
        return self.block_labels[0] if self.block_labels else ""

    @property
    def field_id(self) -> str:
        """The name expressions of its block use: the function name without a "<block>." prefix."""
        prefix = self.block + "."
        return self.name[len(prefix) :] if self.block and self.name.startswith(prefix) else self.name

    @property
    def readable(self) -> bool:
        # eff_access, spelled out (asked of every function by every consumer): its default is
        # read or read_write, both readable
        return not self.access or self.access in ("read", "read_write")

    @property
    def writable(self) -> bool:
        # eff_access, spelled out as `readable`: without an expression or a read-only table its
        # default is read_write
        if self.expression is not None or self.table in READ_ONLY_TABLES:
            return False
        return not self.access or self.access in ("write", "read_write")

    def extensions(self) -> list[str]:
        used = [name for name in EXTENSION_FIELDS if getattr(self, name) is not None]
        if self.format and self.format not in FORMATS_09:
            used.insert(0, f"format {self.format}")
        return used


@dataclass
class ScenarioInput:
    table: str
    address: int
    values: list[str]  # 4-hex-digit words, "----" no value, "xxxx" read error; 0/1 for bits


@dataclass
class Scenario:
    """A test: raw values in, the value each named function must then read (None: null)."""

    id: str
    description: str | None = None
    inputs: list[ScenarioInput] = field(default_factory=list)
    expected: dict[str, list[str] | None] = field(default_factory=dict)
    line: int | None = field(default=None, compare=False, repr=False)


@dataclass
class Device:
    name: str
    description: str
    functions: list[Function] = field(default_factory=list)
    version: str | None = None
    max_registers: int | None = None  # per request (the Toolkit's maxRegistersPerModbusRequest)
    tests: list[Scenario] = field(default_factory=list)
    source: str | None = field(default=None, compare=False, repr=False)
    manufacturer: str | None = None
    product: str | None = None
    product_version: str | None = None
    program_id: str | None = None
    # what the source said while reading it (a column it could not map, text it kept as a comment):
    # warnings the resolve step reports with its own
    notes: list[Diagnostic] = field(default_factory=list, compare=False, repr=False)

    def select(self, names: Iterable[str], write: bool = False) -> list[Function]:
        """The functions `names` names, in that order (every readable one when none are named and not
        `write`); MdlError for a name the device lacks, a read-only function to write, a write-only one
        to read (`mdl read`, `mdl write` and mdl.Session take their functions so)."""
        from mdl.diagnostics import error

        names = list(names)
        if not names and not write:
            return [fn for fn in self.functions if fn.readable]
        by_name = {fn.name: fn for fn in self.functions}
        out = []
        for name in names:
            fn = by_name.get(name)
            if fn is None:
                import difflib

                close = difflib.get_close_matches(name, list(by_name), n=3, cutoff=0.6)
                hint = f": did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
                raise error(f"the device has no function '{name}'{hint}")
            if write and not fn.writable:
                raise error(f"function '{name}' is read-only")
            if not write and not fn.readable:
                raise error(f"function '{name}' is write-only")
            out.append(fn)
        return out

    def extensions(self) -> list[str]:
        used: list[str] = [name for name in IDENTITY_FIELDS if getattr(self, name) is not None]
        if self.max_registers is not None:
            used.append("max_registers")
        if self.tests:
            used.append("tests")
        for fn in self.functions:
            for ext in fn.extensions():
                if ext not in used:
                    used.append(ext)
        return used

    @property
    def schema_version(self) -> str:
        return "1.0" if self.version or self.extensions() else "0.9b"
