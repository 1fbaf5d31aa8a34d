"""The vocabulary of a WISE-Agent `Modbus.ini` (SPEC 7, seed 003 and the shipped agent): its sections in
both forms, their key tags, and the data types 0-8. The reader and the writer both take them from here.

The guide's form names a section for what the values mean (`[Analog Input]`, keys `numberOfAI`,
`AI0`...); the shipped agent's form names the Modbus table (`[Input Registers]`, `numberOfIR`, `IR0`...).
Both mean the same table. A register line is `offset,name,min,max,precision,unit,datatype,lua`; a bit
line is `offset,name`.
"""

from __future__ import annotations

from typing import Literal

from mdl.model import BIT_TABLES
from mdl.records import record

PLATFORM = "Platform"


@record
class Section:
    name: str  # as the files write it: "Input Registers"
    table: str  # MDL register_type
    tag: str  # the key prefix: IR for IR0, IR1, ... and numberOfIR
    form: Literal["guide", "agent"]  # the guide's (seed 003) or the shipped agent's

    @property
    def count_key(self) -> str:
        return "numberOf" + self.tag

    @property
    def bits(self) -> bool:
        return self.table in BIT_TABLES


SECTIONS = (
    Section("Digital Input", "discrete", "DI", "guide"),
    Section("Digital Output", "coil", "DO", "guide"),
    Section("Analog Input", "input", "AI", "guide"),
    Section("Analog Output", "holding", "AO", "guide"),
    Section("Discrete Inputs", "discrete", "IB", "agent"),
    Section("Coils", "coil", "B", "agent"),
    Section("Input Registers", "input", "IR", "agent"),
    Section("Holding Registers", "holding", "R", "agent"),
)
# the shipped agent's section of each table, in the order its samples write them: what export writes
AGENT_SECTIONS = tuple(s for s in SECTIONS if s.form == "agent")


def section_named(header: str) -> Section | None:
    """The section a `[header]` names (case and runs of spaces do not matter), or None."""
    key = " ".join(header.split()).lower()
    return next((s for s in SECTIONS if s.name.lower() == key), None)


def agent_section(table: str) -> Section:
    return next(s for s in AGENT_SECTIONS if s.table == table)


@record
class DataType:
    """A register line's datatype column: how the agent composes the value from its registers."""

    code: int
    format: str  # the MDL format
    byte_order: str  # MDL byte_order: bytes inside each register
    word_order: str  # MDL word_order: registers inside the value
    letters: str  # the byte order in letters, A the most significant byte, first register first
    summary: str  # as the agent's sample files describe it


DATA_TYPES = (
    DataType(0, "UINT16", "big", "big", "AB", "16-bit operation (unsigned)"),
    DataType(1, "FLOAT32", "big", "big", "ABCD", "32-bit float no swap"),
    DataType(2, "FLOAT32", "little", "little", "DCBA", "32-bit float byte and word swap"),
    DataType(3, "FLOAT32", "little", "big", "BADC", "32-bit float byte swap"),
    DataType(4, "FLOAT32", "big", "little", "CDAB", "32-bit float word swap"),
    DataType(5, "UINT32", "big", "big", "ABCD", "32-bit unsigned int no swap"),
    DataType(6, "UINT32", "big", "little", "CDAB", "32-bit unsigned int word swap"),
    DataType(7, "INT32", "big", "big", "ABCD", "32-bit signed int no swap"),
    DataType(8, "INT32", "big", "little", "CDAB", "32-bit signed int word swap"),
)
DEFAULT_DATA_TYPE = DATA_TYPES[0]  # an empty or absent datatype column, as the agent reads it


def data_type_of(fmt: str, byte_order: str, word_order: str) -> DataType | None:
    """The datatype that reads a value of MDL format `fmt` in these orders, or None if there is none."""
    return next(
        (d for d in DATA_TYPES if (d.format, d.byte_order, d.word_order) == (fmt, byte_order, word_order)), None
    )


LUA_VARIABLE = "modbus_val"  # the raw value's name in the Lua column
