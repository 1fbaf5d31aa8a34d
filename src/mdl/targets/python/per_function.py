"""The parts of a Python driver printed once per function (templates/device.py.j2 puts them in
place): its read_ and write_ methods, its rows in _SLOTS and _NAMES, its key in the values TypedDict
and its lines in _values. Printed here with f-strings and one join each rather than by template
loops, which cost twice as much at 10,000 functions; the text is the same those loops printed. Its
decoder and encoder, _decode_<ident> and _encode_<ident>, are templates/ops.j2's, def line and body."""

from __future__ import annotations

import re
from functools import cache
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mdl.targets.python.emit import FunctionCode

# Each function's methods are printed once for both classes, as triples of a text, a marker and a
# text: the markers AWAIT and DEF stand for what the sync and the async class put there, nothing and
# `def`, or `await ` and `async def`.
AWAIT = "\x00AW\x00"
DEF = "\x00DEFN\x00"
CLASSES = (("", "def"), ("await ", "async def"))  # (AWAIT, DEF) of the sync and the async class


def methods(functions: list[FunctionCode], infos: dict[str, FunctionCode]) -> dict[str, str]:
    """Every function's read_<ident> (where it reads) and write_<ident> (where it writes), by what
    the class puts before a call it awaits: "" (the sync class) or "await " (the async class).
    Replaced device.py.j2's per_function macro."""
    out: list[str] = []  # triples: a text, a marker, a text
    add = out.extend
    for f in functions:
        ident, doc, runs = f.ident, f.doc, f.runs
        if f.decode_body:
            add(("\n    ", DEF, f" read_{ident}(self) -> {f.type}:\n        {doc}\n"))
            for name in f.closure:  # the values its expression names, dependencies first
                d = infos[name]
                add((f"        v_{d.ident} = _decode_{d.ident}(", AWAIT, f"self._read_runs({d.runs}){d.args})\n"))
            add((f"        return _decode_{ident}(", AWAIT, f"self._read_runs({runs}){f.args})\n"))
        if f.encode_body:
            add(("\n    ", DEF, f" write_{ident}(self, value: {f.write_type}) -> None:\n        {doc}\n"))
            if f.merge or f.factor:
                _write_lines(f, infos, out)
            else:
                multiple = ", multiple=True" if f.fn.write_multiple else ""
                add(("        ", AWAIT, f"self._write_runs({runs}, _encode_{ident}(value){multiple})\n"))
    markers = out[1::3]
    texts: dict[str, str] = {}
    for aw, defn in CLASSES:
        out[1::3] = [aw if marker is AWAIT else defn for marker in markers]
        texts[aw] = "".join(out)
    return texts


def _write_lines(f: FunctionCode, infos: dict[str, FunctionCode], out: list[str]) -> None:
    """The body of write_<ident> for a function scaled by another one (whose value it reads now) or
    with bits of registers (merged with the others' bits: with function 22, or read before the
    write), onto `out` (in triples, as `methods`)."""
    ident, runs, merge, factor = f.ident, f.runs, f.merge, f.factor
    multiple = ", multiple=True" if f.fn.write_multiple else ""
    encode = ""  # where the encoding is a line of its own, before the writing
    if factor:
        d = infos[factor]
        out += (
            f"        factor = _decode_{d.ident}(",
            AWAIT,
            f"self._read_runs({d.runs}))  # read now: never a stale one\n"
            f"        regs = _encode_{ident}(value, factor)\n",
        )
    elif merge:
        encode = f"        regs = _encode_{ident}(value)\n"
    if merge and merge.mask_write:
        out += (
            f"{encode}        for address, mask, bits in zip("
            f"{list(f.codec.addresses)!r}, {list(merge.masks)!r}, regs, strict=True):\n"
            "            if mask:  # function 22: the device changes only these bits\n"
            "                ",
            AWAIT,
            "self._mask_write(address, ~mask & 0xFFFF, bits)\n",
        )
    elif merge:
        out += (
            f"{encode}        current = ",
            AWAIT,
            f"self._read_runs({runs})  # only this function's bits change\n"
            f"        masks = {list(merge.masks)!r}\n"
            "        regs = [(c & ~m) | (n & m) for c, n, m in zip(current, regs, masks, strict=True)]\n"
            "        ",
            "",
            AWAIT,
            f"self._write_runs({runs}, regs{multiple})\n",
        )
    else:
        out += ("        ", AWAIT, f"self._write_runs({runs}, regs{multiple})\n")


def slot_rows(plain: list[FunctionCode]) -> str:
    """_SLOTS' rows, one a line: each function's name and its slots in the buffer (its loop in
    device.py.j2)."""
    return "\n".join([f"    ({ascii(f.name)}, {f.slots!r})," for f in plain])


def name_rows(readable: list[FunctionCode]) -> str:
    """_NAMES' rows, one a line: each function's name (its loop in device.py.j2)."""
    return "\n".join([f"    {ascii(f.name)}," for f in readable])


def value_fields(readable: list[FunctionCode], form: str) -> str:
    """The values TypedDict's keys and their types, one a line: as class attributes (`form` "class")
    or as the items of the dict a TypedDict call takes ("call"): the loops of either form in
    device.py.j2."""
    if form == "class":
        return "\n".join([f"    {f.name}: {f.type}" for f in readable])
    return "\n".join([f"    {ascii(f.name)}: {f.type}," for f in readable])


# a register of a decoder's body (ops.j2 names them r[0], r[1], ...)
_REGISTER = re.compile(r"\br\[(\d+)\]")
RESULT = "\x00RESULT\x00"  # where an inlined body's value is assigned


@cache  # once per distinct body: functions of one IR share theirs
def inlined(body: str) -> tuple[tuple[str, ...], tuple[int, ...]] | None:
    """A decoder's body (ops.j2's decode_body) as lines of its caller: its text around each register
    it reads (r[i] -> i), its `return X` at the end as `RESULT X`, and `x: float =` as `x =` (the caller
    declares x once); None where it returns early (not implemented, a scale factor without a value) or
    reads its registers otherwise than one at a time."""
    lines = body.split("\n")
    last = lines[-1]
    if not last.startswith("    return ") or any("return" in line for line in lines[:-1]):
        return None
    text = "\n".join([*lines[:-1], "    " + RESULT + last[len("    return ") :]]).replace("x: float = ", "x = ")
    parts = _REGISTER.split(text)
    texts = tuple(parts[0::2])
    if any(re.search(r"\br\b", t) for t in texts):
        return None
    return texts, tuple(int(i) for i in parts[1::2])


def inline_lines(body: str, buffer: str, slots: tuple[int, ...], result: str) -> str | None:
    """The lines computing a function's value from `buffer` into `result`, its decoder's body inlined
    (its registers at `slots` in the buffer); None where it cannot be (`inlined`)."""
    found = inlined(body)
    if found is None:
        return None
    texts, registers = found
    out = [texts[0]]
    for i, text in zip(registers, texts[1:], strict=True):
        out += (f"{buffer}[{slots[i]}]", text)
    return "".join(out).replace(RESULT, f"{result} = ")


def decode_lines(readable: list[FunctionCode]) -> str:
    """_values' decoding of each function from the buffer (`raw` for an expression, which reads
    None where the device refused a register; else `regs`), in decode order: _values' first loop in
    device.py.j2. A function of a plain shape (no fragment, no expression, no scale factor) has its
    decoder's lines inlined (a call and a list of its registers cost more than the decoding); the
    others call their decoder, one a line."""
    out: list[str] = []
    floats = False  # whether an inlined body assigns x (its decoder declares `x: float`)
    for f in readable:
        ident, span, slots = f.ident, f.span, f.slots
        if f.resolved.decode_shape is not None and not f.args:
            lines = inline_lines(f.decode_body, "regs", slots, f"v_{ident}")
            if lines is not None:
                out.append(lines)
                floats = floats or "    x = " in lines
                continue
        buffer = "raw" if f.resolved.compiled is not None else "regs"
        if span:
            regs = f"{buffer}[{span[0]}:{span[1]}]"
        elif len(slots) == 1:
            regs = f"[{buffer}[{slots[0]}]]"
        else:
            regs = "[" + ", ".join([f"{buffer}[{slot}]" for slot in slots]) + "]"
        out.append(f"    v_{ident} = _decode_{ident}({regs}{f.args})")
    return "\n".join(["    x: float", *out] if floats else out)


def store_lines(readable: list[FunctionCode]) -> str:
    """_values' storing of each function's value under its name, one a line: its second loop in
    device.py.j2."""
    return "\n".join([f"    values[{ascii(f.name)}] = v_{f.ident}" for f in readable])
