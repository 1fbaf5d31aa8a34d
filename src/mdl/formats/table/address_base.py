"""How a table numbers its registers, when the INI does not say (`address_base`): wire addresses,
or Modicon register numbers (`40001`: holding register 0, the first digit naming the table).

The guess looks at the whole column and is always said. It reads Modicon numbers when at least
three quarters of the plain numbers are Modicon-shaped (5 digits starting 0, 1, 3 or 4, or 6 digits),
some start a table (a 6-digit number, or one below X1000 as Modicon tables do), no 5-digit number
is impossible as one (`30000`, `20001`) and no register-type column contradicts their first digit.
Coil numbers may drop their leading 0 (`1` for 00001 on a row whose register type is coil, as
VOLTTRON's register maps write them).
A plain number that is not Modicon-shaped is then reported on its row (rows.parse_row), never a
reason to read every other row another way. Inverter tables whose wire addresses happen to be
5-digit numbers (`33000`, `43000`) stay wire addresses.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mdl.formats.table.cells import WORDED_TABLES, CellError, bit_of, is_modicon_number, parse_table, unlisted
from mdl.formats.table.readers.delimited import Row
from mdl.model.addressing import MODICON_TABLE

SHARE = 0.75
_PLAIN = re.compile(r"^[\d\s,;/&\-–—]+$|^\d+\s*(?:to|\.\.)\s*\d+$", re.IGNORECASE)
_WORDED = re.compile(r"^([A-Za-z]+)\s+(\d+)$")  # `hreg 6`: cells.WORDED_TABLES
OVERRIDE = "set address_base in [Modbus Device] to 0, 1 or modicon to say how the table counts"


@dataclass(frozen=True)
class BaseGuess:
    base: str  # 0 | modicon | hex
    note: str | None  # what was decided and why


def guess_address_base(rows: list[Row], index: int, header: str, type_index: int | None) -> BaseGuess:
    if "hex" in header.lower():
        return BaseGuess(
            "hex",
            f"addresses read as hexadecimal: the header '{header.strip()}' says so; "
            "set address_base = 0 in [Modbus Device] to read them as decimal",
        )
    plain: list[tuple[Row, list[str]]] = []
    for r in rows:
        text = r.cell(index)
        if text.isascii() and text.isdigit():  # most cells: one plain number, its own only token
            plain.append((r, [text]))
            continue
        text = unlisted(text)
        worded = _WORDED.match(text.strip()) if text else None
        bit = bit_of(text) if text else None
        if worded and worded.group(1).lower() in WORDED_TABLES:
            plain.append((r, [worded.group(2)]))
        elif bit is not None and bit.group(1).isdigit():  # `40001.3`: the register's number counts
            plain.append((r, [bit.group(1)]))
        elif text and _PLAIN.match(text):
            plain.append((r, re.findall(r"\d+", text)))
    if not plain:
        return BaseGuess("0", None)  # hex, named or Modicon-x forms only: nothing to guess
    # (tokens hold no spaces: is_modicon_number needs 5 or 6 characters, looked at first)
    shaped = [
        (r, tokens)
        for r, tokens in plain
        if tokens
        and (
            all(len(t) in (5, 6) and is_modicon_number(t) for t in tokens)
            or (type_index is not None and _coil_numbers(r, tokens, type_index))
        )
    ]
    if not shaped:
        return BaseGuess(
            "0",
            "plain addresses read as wire addresses (0-based, as sent on the bus); "
            "set address_base = 1 in [Modbus Device] if the table counts from 1",
        )
    impossible = next((t for _, tokens in plain for t in tokens if len(t) == 5 and not is_modicon_number(t)), None)
    six = any(len(t) == 6 for _, tokens in shaped for t in tokens)
    low = any(len(t) == 5 and int(t[1:]) < 1000 for _, tokens in shaped for t in tokens)
    against = _disagreement(shaped, type_index)
    why_not = None
    if len(shaped) < SHARE * len(plain):
        why_not = f"only {len(shaped)} of {len(plain)} are"
    elif impossible:
        why_not = f"'{impossible}' cannot be one"
    elif against:
        why_not = against
    elif not (six or low):
        why_not = "none starts a table (X0001 to X0999), as Modicon numbering does"
    if why_not is None:
        stray = len(plain) - len(shaped)
        strays = f"; the {stray} that are not are reported on their lines" if stray else ""
        return BaseGuess(
            "modicon",
            f"addresses read as Modicon register numbers (40001 is holding register 0, "
            f"30001 input register 0){strays}; set address_base = 0 in [Modbus Device] "
            "if they are wire addresses",
        )
    return BaseGuess(
        "0",
        f"addresses read as wire addresses (0-based), though {len(shaped)} of {len(plain)} look "
        f"like Modicon register numbers (40001 ...): {why_not}; set address_base = modicon in "
        "[Modbus Device] to read them as Modicon numbers",
    )


def _coil_numbers(row: Row, tokens: list[str], type_index: int | None) -> bool:
    """Coil numbers written without their leading 0 (`1` for 00001, as VOLTTRON's maps do), on a row
    whose register type is coil."""
    if type_index is None or not all(len(t) <= 4 and int(t) >= 1 for t in tokens):
        return False
    try:
        return parse_table(row.cell(type_index)) == "coil"
    except CellError:
        return False


def _disagreement(shaped: list[tuple[Row, list[str]]], type_index: int | None) -> str | None:
    """Why a register-type column says the first digits are not tables, or None."""
    if type_index is None:
        return None
    agree = disagree = 0
    for r, tokens in shaped:
        try:
            table = parse_table(r.cell(type_index)) if r.cell(type_index) else None
        except CellError:
            continue
        if table is not None and len(tokens[0]) >= 5:
            if MODICON_TABLE[tokens[0][0]] == table:
                agree += 1
            else:
                disagree += 1
    if disagree > agree:
        return f"the register type column contradicts their first digit on {disagree} rows"
    return None
