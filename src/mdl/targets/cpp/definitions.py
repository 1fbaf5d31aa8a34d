"""The per-function parts of a C++ driver's source (<stem>.cc), printed with Python strings: the
rows of the read plan's tables, read_all's decode parts, and the read_<name> and write_<name> defined
out of line. A loop of Jinja over 10,000 functions, with a macro call per function, cost some 2.5 times
these (templates/device.cc.j2 keeps the file's skeleton; templates/ops.j2 prints the decoders and
encoders, which are some ten for a device of 10,000 functions)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mdl.targets.base import GroupRow, SplitRow
from mdl.targets.clike import Chunk
from mdl.targets.cpp.declarations import value_param
from mdl.targets.templating import ccomment

if TYPE_CHECKING:
    from mdl.targets.cpp.emit import CppFunction


def group_rows(groups: list[GroupRow]) -> str:
    """The rows of the read plan's table kGroups, a line each."""
    return "".join([f"    {{{t}, {s}, {c}, {o}, {first}, {n}}},\n" for t, s, c, o, first, n in groups])


def split_rows(splits: list[SplitRow]) -> str:
    """The rows of kSplits, the smaller requests of the plan's groups, a line each."""
    return "".join([f"    {{{t}, {s}, {c}, {delta}}},\n" for t, s, c, delta in splits])


def range_rows(ranges: list[tuple[int, int]]) -> str:
    """The rows of kNeeded, the ranges of read_all's buffer that functions without an expression read."""
    return "".join([f"    {{{first}, {end}}},\n" for first, end in ranges])


def decode_into(f: CppFunction, target: str, deps_from: str, indent: str) -> str:
    """The statements decoding f's registers r (and present) into target, an lvalue, without a final
    line break; the values f depends on are deps_from + their names. A decoder that returns a status
    sets its *out, and a failure returns -1."""
    regs = ("r, present" if f.expr else "r") if f.n else ""
    deps = ", ".join([arg % (deps_from,) for arg in f.dep_args])
    args = regs + (", " if regs and deps else "") + deps
    if not f.status:
        return f"{indent}{target} = decode_{f.decoder}({args});"
    out = target[1:] if target.startswith("*") else "&" + target
    return (
        f"{indent}if (decode_{f.decoder}({args}{', ' if args else ''}{out}) == -1) {{\n"
        f"{indent}    return -1;\n"
        f"{indent}}}"
    )


def decode_parts(chunks: list[Chunk[CppFunction]], raw_total: int, class_name: str) -> str:
    """read_all's decode parts (decode_part_<k>), each decoding its functions' registers from read_all's
    buffer into the values, each after a blank line."""
    out: list[str] = []
    count = len(chunks)
    for k, chunk in enumerate(chunks):
        raw = f"const std::array<uint16_t, {raw_total}> &raw, " if chunk.uses_raw else ""
        have = f"const std::array<bool, {raw_total}> &have, " if chunk.uses_have else ""
        out.append(
            f"\n// read_all's decoding, part {k + 1} of {count}: small functions, kept out of line (each is\n"
            "// called once: inlined, they would make read_all one function again), keep the compile time linear\n"
            f"[[gnu::noinline]] int decode_part_{k}({raw}{have}{class_name}Values &values) {{\n"
        )
        for f in chunk.functions:
            n = f.n
            if not n:
                out.append(decode_into(f, "values." + f.ident, "values.", "    ") + "\n")
                continue
            regs = "raw[" + "], raw[".join(map(str, f.slots)) + "]"
            if not (f.expr or f.status or f.factor is not None):  # most
                out.append(
                    f"    {{\n        const std::array<uint16_t, {n}> r{{ {regs} }};\n"
                    f"        values.{f.ident} = decode_{f.decoder}(r);\n    }}\n"
                )
                continue
            out.append(f"    {{\n        const std::array<uint16_t, {n}> r{{ {regs} }};\n")
            if f.expr:
                answered = "have[" + "], have[".join(map(str, f.slots)) + "]"
                out.append(f"        const std::array<bool, {n}> present{{ {answered} }};\n")
            out.append(decode_into(f, "values." + f.ident, "values.", "        ") + "\n    }\n")
        out.append("    return 0;\n}\n")
    return "".join(out)


def _step(g: CppFunction, target: str, indent: str) -> str:
    """g's registers read into r (and present) and decoded into target, as a read_<name> does it."""
    out = []
    n = g.n
    if n:
        out.append(f"{indent}std::array<uint16_t, {n}> r{{}};\n")
        if g.expr:
            out.append(f"{indent}const std::array<bool, {n}> present{{ {', '.join(['true'] * n)} }};\n")
        for table, start, count, at in g.runs:
            into = f"&r[{at}]" if at else "r.data()"
            out.append(
                f"{indent}if (read_table_({table}, {start}, {count}, {into}) == -1) {{\n"
                f"{indent}    return -1;\n{indent}}}\n"
            )
    out.append(decode_into(g, target, "v_", indent) + "\n")
    return "".join(out)


def _read(f: CppFunction, blocks: dict[str, str]) -> list[str]:
    """The definition of f's read_<name>: each of its steps' registers read into r (and present) and
    decoded into its value, the last into *out; with several (the value depends on others), each in a
    block of its own. `blocks`: the block of each function read before another's value, by identifier
    (the same in every read that needs it)."""
    steps = f.steps
    out = []
    if not f.reads_device:
        out.append(
            "// NOLINTNEXTLINE(readability-convert-member-functions-to-static): every read is a member function\n"
        )
    out.append(f"int {f.owner}::read_{f.ident}({f.rt} *out) {{\n")
    if len(steps) == 1:
        out.append(_step(steps[0], "*out", "    "))
    else:
        for g in steps[:-1]:
            block = blocks.get(g.ident)
            if block is None:
                target = "v_" + g.ident
                block = blocks[g.ident] = f"    {g.rt} {target}{{}};\n    {{\n{_step(g, target, '        ')}    }}\n"
            out.append(block)
        out.append(f"    {{\n{_step(steps[-1], '*out', '        ')}    }}\n")
    out.append("    return 0;\n}\n")
    return out


def _write(f: CppFunction) -> list[str]:
    """The definition of f's write_<name>: a scale factor read first, the value encoded into r, and r
    written; a function of bits merges its bits into the registers as they are read now, or writes
    them with function 22 (Mask Write Register)."""
    out = [f"int {f.owner}::write_{f.ident}({value_param(f.t)}value) {{\n"]
    factor = f.factor
    if factor is not None:
        out.append(
            f"    {factor.rt} factor{{}};  // read now: never a stale one\n"
            f"    if (read_{factor.ident}(&factor) == -1) {{\n        return -1;\n    }}\n"
        )
    out.append(
        f"    std::array<uint16_t, {f.n}> r{{}};\n"
        f"    if (encode_{f.encoder}(value, {'factor_of(factor), ' if factor is not None else ''}r) == -1) {{\n"
        "        return -1;\n    }\n"
    )
    if f.mask_write:
        out.append("    // function 22: the device changes only this function's bits\n")
        for m in f.merge:
            if m.mask:
                out.append(
                    f"    if (mask_write_({m.address}, 0x{m.keep:04X}U, r[{m.index}]) == -1) {{\n"
                    "        return -1;\n    }\n"
                )
        out.append("    return 0;\n}\n")
        return out
    if f.merge:
        out.append(
            "    // only this function's bits change: the others are written back as they are read now\n"
            f"    std::array<uint16_t, {f.n}> current{{}};\n"
        )
        for table, start, count, at in f.runs:
            into = f"&current[{at}]" if at else "current.data()"
            out.append(
                f"    if (read_table_({table}, {start}, {count}, {into}) == -1) {{\n        return -1;\n    }}\n"
            )
        for m in f.merge:
            i = m.index
            if m.mask:
                out.append(
                    f"    r[{i}] = static_cast<uint16_t>((current[{i}] & 0x{m.keep:04X}U) | "
                    f"(r[{i}] & 0x{m.mask:04X}U));\n"
                )
            else:
                out.append(f"    r[{i}] = current[{i}];\n")
    write = "write_multiple_" if f.fn.write_multiple else "write_table_"
    for table, start, count, at in f.runs:
        into = f"&r[{at}]" if at else "r.data()"
        out.append(f"    if ({write}({table}, {start}, {count}, {into}) == -1) {{\n        return -1;\n    }}\n")
    out.append("    return 0;\n}\n")
    return out


def methods(functions: list[CppFunction]) -> str:
    """The read_<name> and write_<name> defined here (those not calling a shared read_<k>_ or
    write_<j>_ inline), each function's after a blank line and a comment naming it."""
    out: list[str] = []
    blocks: dict[str, str] = {}
    for f in functions:
        reads = f.readable and f.reader is None
        writes = f.writable and f.writer is None
        if not (reads or writes):
            continue
        out.append(f"\n// {ccomment(f.fn.name)}\n")
        if reads:
            out += _read(f, blocks)
        if writes:
            if reads:
                out.append("\n")
            out += _write(f)
    return "".join(out)
