"""The per-function parts of a C driver, printed with Python rather than Jinja loops (each `{{ x }}` of a
template loop over 10,000 functions cost a generator step and a str(): the loops were most of
rendering a large device). device.h.j2 and device.c.j2 keep the files' skeletons and put these texts
in place; each printer says which part of them it prints, byte for byte as the templates did.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from mdl.targets.clike import Chunk, Shared

if TYPE_CHECKING:
    from mdl.targets.c.emit import CFunction

Comment = Callable[[object], str]  # the template filter ccomment (memoized: one text, one escaping)

# a request a read or write makes: (table, first address, count, first register in r) as the code
# spells them, a table and address that are a shared read's or write's parameters included
Request = tuple[str, int | str, int, int]
_FAIL = " == -1) {\n        return -1;\n    }\n"  # the end of a call that returns -1 when it fails


def header(functions: list[CFunction], readable: list[CFunction], stem: str, ccomment: Comment) -> tuple[str, str, str]:
    """device.h.j2's per-function parts: the `<STEM>_<NAME>_SIZE` of each text, the members of
    `struct <stem>_values` and the declarations of `<stem>_read_<name>`/`<stem>_write_<name>`."""
    upper = stem.upper()
    sizes = "".join(f"#define {upper}_{f.ident.upper()}_SIZE {f.text_size}\n" for f in functions if f.is_text)
    about: dict[str, str] = {}  # each function's description and units, as its comments print them
    declarations = []
    for f in functions:
        fn = f.fn
        text = about[f.ident] = ccomment(fn.description) + (f" [{ccomment(fn.units)}]" if fn.units else "")
        if f.decode is not None:
            declarations.append(f"\n/** Read {text} */\nint {stem}_read_{f.ident}(modbus_t *ctx, {f.t} {_out(f)});\n")
        if f.encode is not None:
            declarations.append(
                f"\n/** Write {text} */\nint {stem}_write_{f.ident}(modbus_t *ctx, {f.wt_param}value);\n"
            )
    members = []
    for f in readable:
        ident = f.ident
        members.append(f"    /** {about[ident]} */\n")
        members.append(f"    char {ident}[{f.text_size}];\n" if f.is_text else f"    {f.t} {ident};\n")
        if f.nullable:
            members.append(f"    bool has_{ident};\n")
    return sizes, "".join(members), "".join(declarations)


def _out(f: CFunction) -> str:
    """The parameter a read of f fills: an array for a text."""
    return f"out[{f.text_size}]" if f.is_text else "*out"


def _s(count: int) -> str:
    """The plural's ending, after "1 more function" or "2 more functions"."""
    return "s" if count > 1 else ""


def _decode_args(g: CFunction, single: bool, target: str, has: str, regs: str) -> str:
    """The arguments of decode_<g.decoder>: its registers `regs` (and which were answered), the values
    its expression names (v_<name> in a single read, values-><name> in read_all; a scalar one
    converted to its parameter's type) and whether each has one, where its value and whether it
    has one go."""
    out = [regs]
    for d in g.deps:
        value = ("v_" if single else "values->") + d.ident
        if g.factor is not None:
            value = "(double)" + value
        elif d.expr is None and d.t not in ("char", "bool"):
            value = "(" + d.param_type.strip() + ")" + value
        elif d.t.startswith("struct"):
            value = "&" + value
        present = f"v_{d.ident}_has" if single else f"values->has_{d.ident}" if d.nullable else "true"
        out.append(f", {value}, {present}")
    out.append(f", {target if g.is_text else '&' + target}, {has}")
    return "".join(out)


class Accessors:
    """device.c.j2's reads and writes: the shared `read_<k>`/`write_<j>` and each function's
    `<stem>_read_<name>`/`<stem>_write_<name>`. A function another one needs is read the same way
    in each read that needs it: that block is printed once."""

    def __init__(self, stem: str, ccomment: Comment) -> None:
        self.stem = stem
        self.ccomment = ccomment
        self.steps: dict[str, tuple[str, str]] = {}  # a needed function's declarations and block, by identifier

    def _step(self, g: CFunction, target: str, runs: Sequence[Request]) -> tuple[str, str]:
        """The declarations of a step's value `target` and the block that reads its registers and
        decodes them into it."""
        value = f"char {target}[{g.text_size}]" if g.is_text else f"{g.t} {target}"
        n = g.n
        expression = g.expr is not None
        if n:
            present = f"        const bool present[{n}] = {{ {', '.join(['true'] * n)} }};\n" if expression else ""
            reads = "".join(
                [
                    f"        if (mdl_read_table(ctx, {table}, {start}, {count}, &r[{at}]) == -1) {{\n"
                    "            return -1;\n        }\n"
                    for table, start, count, at in runs
                ]
            )
            registers = f"        uint16_t r[{n}];\n{present}{reads}"
        else:
            registers = "        const uint16_t *r = NULL;\n        const bool *present = NULL;\n"
        args = _decode_args(g, True, target, f"&{target}_has", "r, present" if expression else "r")
        return (
            f"    {value};\n    bool {target}_has = true;\n",
            f"    {{\n{registers}        if (decode_{g.decoder}({args}) == -1) {{\n"
            "            return -1;\n        }\n    }\n",
        )

    def read_body(self, f: CFunction, runs: Sequence[Request]) -> str:
        """The body of a read of f: its registers (from runs for a function without dependencies,
        else each function's own) and those of the functions it needs, each read into r (and
        present) and decoded into its value, the last into *out."""
        steps = f.steps
        if len(steps) == 1:
            decls, blocks = self._step(f, "value", runs)
        else:
            done = self.steps
            parts = []
            for g in steps[:-1]:
                found = done.get(g.ident)
                if found is None:
                    found = done[g.ident] = self._step(g, f"v_{g.ident}", g.runs)
                parts.append(found)
            last = steps[-1]
            parts.append(self._step(last, "value", last.runs))
            decls = "".join([decl for decl, _ in parts])
            blocks = "".join([block for _, block in parts])
        if f.nullable:
            end = "    if (!value_has) {\n        errno = ENODATA;\n        return -1;\n    }\n"
        else:
            end = "    (void)value_has;\n"
        store = "    memcpy(out, value, sizeof value);\n" if f.is_text else "    *out = value;\n"
        return f"{decls}{blocks}{end}{store}    return 0;\n"

    def write_body(self, f: CFunction, runs: Sequence[Request]) -> str:
        """The body of a write of f: its value encoded (with its scale factor, read first), then written
        run by run; a function with bits merges them into the registers as they are read now, or
        writes them with function 22."""
        out = [f"    uint16_t r[{f.n}];\n"]
        factor = f.factor
        if factor is not None:
            out.append(f"    {factor.t} factor; /* read now: never a stale one (ENODATA where it has no value) */\n")
        if f.merge and not f.mask_write:
            out.append(f"    uint16_t current[{f.n}];\n")
        out.append("    memset(r, 0, sizeof r);\n")
        if factor is not None:
            out.append(f"    if ({self.stem}_read_{factor.ident}(ctx, &factor){_FAIL}")
        scale = "(double)factor, true, " if factor is not None else ""
        out.append(f"    if (encode_{f.encoder}(value, {scale}r){_FAIL}")
        if f.mask_write:
            out.append("    /* function 22: the device changes only this function's bits */\n")
            for m in f.merge:
                if m.mask:
                    out.append(f"    if (mdl_mask_write(ctx, {m.address}, 0x{m.keep:04X}U, r[{m.index}]){_FAIL}")
            out.append("    return 0;\n")
            return "".join(out)
        if f.merge:
            out.append("    /* only this function's bits change: the others are written back as they are read now */\n")
            for table, start, count, at in runs:
                out.append(f"    if (mdl_read_table(ctx, {table}, {start}, {count}, &current[{at}]){_FAIL}")
            for m in f.merge:
                i = m.index
                if m.mask:
                    out.append(
                        f"    r[{i}] = (uint16_t)(((unsigned)current[{i}] & 0x{m.keep:04X}U)"
                        f" | ((unsigned)r[{i}] & 0x{m.mask:04X}U));\n"
                    )
                else:
                    out.append(f"    r[{i}] = current[{i}];\n")
        write = "mdl_write_multiple" if f.fn.write_multiple else "mdl_write_table"
        for table, start, count, at in runs:
            out.append(f"    if ({write}(ctx, {table}, {start}, {count}, &r[{at}]){_FAIL}")
        out.append("    return 0;\n")
        return "".join(out)

    def print(self, functions: list[CFunction], shared: Shared[CFunction]) -> str:
        """The shared reads and writes, then each function's read and write."""
        stem = self.stem
        out = []
        for d in shared.decoders:
            f = d.reads
            if f is None:
                continue
            n = f.n
            out.append(
                f"\n/* Reads one run of {n} register{_s(n)} and decodes {'them' if n > 1 else 'it'} with decode_{d.k}:"
                " the read of each function that does. */\n"
                f"MDL_NOINLINE static int read_{d.k}(modbus_t *ctx, enum mdl_table table, int start, {f.t} *out) {{\n"
                f"{self.read_body(f, [('table', 'start', n, 0)])}}}\n"
            )
        for w in shared.writers:
            f = w.first
            n = f.n
            out.append(
                f"\n/* Encodes a value with encode_{f.encoder} and writes its run of {n} register{_s(n)}:"
                " the write of each function that does. */\n"
                f"MDL_NOINLINE static int write_{w.j}(modbus_t *ctx, enum mdl_table table, int start,"
                f" {f.wt_param}value) {{\n"
                f"{self.write_body(f, [('table', 'start', n, 0)])}}}\n"
            )
        for f in functions:
            reads = f.decode is not None
            writes = f.encode is not None
            if not reads and not writes:
                continue
            text = f"\n/* {self.ccomment(f.fn.name)} */\n"
            if reads:
                if f.reader is not None:
                    table, start, _, _ = f.runs[0]
                    body = f"    return read_{f.reader}(ctx, {table}, {start}, out);\n"
                else:
                    body = ("" if f.reads_device else "    (void)ctx;\n") + self.read_body(f, f.runs)
                text += f"int {stem}_read_{f.ident}(modbus_t *ctx, {f.t} {_out(f)}) {{\n{body}}}\n"
            if writes:
                if f.writer is not None:
                    table, start, _, _ = f.runs[0]
                    body = f"    return write_{f.writer}(ctx, {table}, {start}, value);\n"
                else:
                    body = self.write_body(f, f.runs)
                between = "\n" if reads else ""
                text += f"{between}int {stem}_write_{f.ident}(modbus_t *ctx, {f.wt_param}value) {{\n{body}}}\n"
            out.append(text)
        return "".join(out)


def read_all_parts(chunks: list[Chunk[CFunction]], stem: str) -> str:
    """read_all's decoding, `read_all_part_<k>` for each chunk of READ_ALL_PART functions."""
    out = []
    total = len(chunks)
    for k, chunk in enumerate(chunks):
        out.append(
            f"\n/* read_all's decoding, part {k + 1} of {total}: small functions keep the compile time linear\n"
            " * in the number of functions. Nothing fails here: read_all has checked the registers and fragments. */\n"
            f"MDL_NOINLINE static void read_all_part_{k}(const uint16_t *raw, const bool *have,"
            f" struct {stem}_values *values) {{\n    bool has = true;\n"
        )
        if not chunk.uses_raw:
            out.append("    (void)raw;\n")
        if not chunk.uses_have:
            out.append("    (void)have;\n")
        for f in chunk.functions:
            n, ident, at = f.n, f.ident, f.at
            has = f"&values->has_{ident}" if f.nullable else "&has"
            if f.expr is not None:
                regs = "NULL, NULL" if not n else "r, present" if at is None else f"&raw[{at}], &have[{at}]"
            else:
                regs = "r" if at is None else f"&raw[{at}]"
            if f.deps or f.expr is not None:
                args = _decode_args(f, False, f"values->{ident}", has, regs)
            else:
                args = f"{regs}, {'' if f.is_text else '&'}values->{ident}, {has}"
            if n and at is None:
                raw = ", ".join([f"raw[{s}]" for s in f.slots])
                out.append(f"    {{\n        const uint16_t r[{n}] = {{ {raw} }};\n")
                if f.expr is not None:
                    have = ", ".join([f"have[{s}]" for s in f.slots])
                    out.append(f"        const bool present[{n}] = {{ {have} }};\n")
                out.append(f"        (void)decode_{f.decoder}({args});\n    }}\n")
            else:
                out.append(f"    (void)decode_{f.decoder}({args});\n")
        out.append("    (void)has;\n}\n")
    return "".join(out)
