"""The parts of a Python driver printed once per function (templates/device.py.j2 puts them in
place): its read_ and write_ methods, its rows in _SLOTS and _NAMES, its key in the values TypedDict
and its lines in _values. Printed here with f-strings and one join each rather than by template
loops, which cost twice as much at 10,000 functions; the text is the same those loops printed. Its
decoder and encoder, _decode_<ident> and _encode_<ident>, are templates/ops.j2's, def line and body."""

from __future__ import annotations

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


def decode_lines(readable: list[FunctionCode]) -> str:
    """_values' decoding of each function from the buffer (`raw` for an expression, which reads
    None where the device refused a register; else `regs`), one a line, in decode order: _values'
    first loop in device.py.j2."""
    out: list[str] = []
    for f in readable:
        ident, span, slots = f.ident, f.span, f.slots
        buffer = "raw" if f.resolved.compiled is not None else "regs"
        if span:
            regs = f"{buffer}[{span[0]}:{span[1]}]"
        elif len(slots) == 1:
            regs = f"[{buffer}[{slots[0]}]]"
        else:
            regs = "[" + ", ".join([f"{buffer}[{slot}]" for slot in slots]) + "]"
        out.append(f"    v_{ident} = _decode_{ident}({regs}{f.args})")
    return "\n".join(out)


def store_lines(readable: list[FunctionCode]) -> str:
    """_values' storing of each function's value under its name, one a line: its second loop in
    device.py.j2."""
    return "\n".join([f"    values[{ascii(f.name)}] = v_{f.ident}" for f in readable])
