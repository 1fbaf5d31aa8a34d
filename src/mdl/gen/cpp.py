"""MDL model -> C++17 driver on libmodbus (<stem>.h / <stem>.cc), SPEC section 5.

Values are packed and unpacked with the generated code's own shifts for every byte and word order
(libmodbus 3.1.6's float helpers do not round-trip). Fragments are pasted verbatim, only after the
safe-subset check, inside functions where r1..rn are uint16_t locals and arg a double.
"""

from __future__ import annotations

from mdl import __version__
from mdl.codec import int_range, scales
from mdl.expr.cppemit import CPP_HELPERS, cpp_type
from mdl.expr.cppemit import body as expr_body
from mdl.expr.fields import evaluation_order
from mdl.gen.python import runs
from mdl.gen.straight import span_bits, unit_shift, units_msb_first
from mdl.layout import int_type_bits, layout
from mdl.model import Device, Function
from mdl.names import camel, identifier, unique_identifiers
from mdl.plan import plan_reads, split_request

TABLE_CONST = {"coil": "kCoil", "discrete": "kDiscrete", "holding": "kHolding", "input": "kInput"}


def cpp_number(x: float) -> str:
    text = repr(float(x))
    if "inf" in text or "nan" in text:
        raise ValueError(f"{x} cannot be a C++ literal")
    return text if any(c in text for c in ".e") else text + ".0"


def value_type(fn: Function) -> str:
    """T of read_<name>(T *out) / write_<name>(T value), before std::optional."""
    if fn.compiled is not None:
        return cpp_type(fn.compiled.type)
    lay = layout(fn)
    if fn.read_function_code or fn.write_function_code or scales(fn):
        return "double"
    if lay.kind == "bool":
        return "bool"
    if lay.kind == "string":
        return "std::string"
    if lay.kind == "float":
        return "float" if lay.bits == 32 else "double"
    return f"{'' if lay.signed else 'u'}int{int_type_bits(lay.bits)}_t"


def _unit_expr(i: int, part: str) -> str:
    return {"word": f"static_cast<uint64_t>(r[{i}])",
            "swap": f"static_cast<uint64_t>(((r[{i}] & 0xFFu) << 8) | (r[{i}] >> 8))",
            "low": f"static_cast<uint64_t>(r[{i}] & 0xFFu)",
            "high": f"static_cast<uint64_t>(r[{i}] >> 8)"}[part]


def _compose_lines(lay) -> list[str]:
    lines = ["uint64_t v = 0;"]
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        shift = unit_shift(lay, pos)
        lines.append(f"v |= {_unit_expr(i, part)}{f' << {shift}' if shift else ''};")
    return lines


def _fragment(code: str) -> list[str]:
    return ["#pragma GCC diagnostic push",
            '#pragma GCC diagnostic ignored "-Wparentheses"',
            '#pragma GCC diagnostic ignored "-Wsign-compare"',
            '#pragma GCC diagnostic ignored "-Wtype-limits"',
            '#pragma GCC diagnostic ignored "-Wbool-operation"',
            '#pragma GCC diagnostic ignored "-Wint-in-bool-context"',
            *code.splitlines(),
            "#pragma GCC diagnostic pop"]


def decode_lines(fn: Function, t: str) -> list[str]:
    """Body of `static T decode(const uint16_t *r)`."""
    if fn.compiled is not None:
        return expr_body(fn.compiled.lowered)
    lay = layout(fn)
    n = len(lay.addresses)
    lines: list[str] = []
    for token in fn.not_implemented or []:
        pattern = int(token, 16)
        if len(token) <= 6:
            test = " && ".join(f"r[{i}] == 0x{pattern:04X}u" for i in range(n))
        else:
            test = " && ".join(f"r[{i}] == 0x{(pattern >> (16 * (n - 1 - i))) & 0xFFFF:04X}u" for i in range(n))
        lines.append(f"if ({test}) return std::nullopt;  // not implemented: {token}")
    if fn.read_function_code:
        regs = ", ".join(f"r{i + 1} = r[{i}]" for i in range(n))
        lines += [f"uint16_t {regs};", "double arg = 0;",
                  "(void)" + "; (void)".join(f"r{i + 1}" for i in range(n)) + ";"]
        lines += _fragment(fn.read_function_code)
        return lines + ["return arg;"]
    if lay.kind == "bool":
        return lines + ["return r[0] != 0;"]
    span = span_bits(lay)
    if lay.kind == "string":
        nbytes = span // 8
        lines.append(f"char s[{nbytes}];")
        for pos, (i, part) in enumerate(units_msb_first(lay)):
            if lay.unit == "word":
                hi, lo = (f"r[{i}] >> 8", f"r[{i}] & 0xFFu") if part == "word" else (f"r[{i}] & 0xFFu", f"r[{i}] >> 8")
                lines.append(f"s[{2 * pos}] = static_cast<char>({hi}); s[{2 * pos + 1}] = static_cast<char>({lo});")
            else:
                src = f"r[{i}] & 0xFFu" if part == "low" else f"r[{i}] >> 8"
                lines.append(f"s[{pos}] = static_cast<char>({src});")
        lines += [f"size_t len = {nbytes};",
                  "while (len > 0 && (s[len - 1] == '\\0' || s[len - 1] == ' ')) --len;",
                  "return std::string(s, len);"]
        return lines
    lines += _compose_lines(lay)
    if lay.kind == "float":
        ctype, width = ("float", "uint32_t") if lay.bits == 32 else ("double", "uint64_t")
        lines += [f"{width} bits = static_cast<{width}>(v);", f"{ctype} f;", "std::memcpy(&f, &bits, sizeof f);"]
        raw = "f"
    else:
        if lay.bits < 64:
            lines.append(f"v &= 0x{(1 << lay.bits) - 1:X}ull;")
        if lay.signed:
            if lay.bits < 64:
                sign = f"0x{1 << (lay.bits - 1):X}ull"
                lines.append(f"int64_t s = static_cast<int64_t>(v ^ {sign}) - static_cast<int64_t>({sign});")
            else:
                lines += ["int64_t s;", "std::memcpy(&s, &v, sizeof s);"]
            raw = "s"
        else:
            raw = "v"
    if scales(fn):
        return lines + [f"return static_cast<double>({raw}) * {cpp_number(fn.eff_multiplier)} + {cpp_number(fn.eff_offset)};"]
    return lines + [f"return static_cast<{t}>({raw});"]


def encode_lines(fn: Function, t: str) -> list[str]:
    """Body of `static int encode(T value, uint16_t *r)`: 0, or -1 with errno = EINVAL."""
    lay = layout(fn)
    n = len(lay.addresses)
    lines: list[str] = []
    if t == "double" or t == "float":
        lines.append("if (std::isnan(value)) { errno = EINVAL; return -1; }")
    if fn.minimum is not None:
        lines.append(f"if (value < {cpp_number(fn.minimum)}) {{ errno = EINVAL; return -1; }}")
    if fn.maximum is not None:
        lines.append(f"if (value > {cpp_number(fn.maximum)}) {{ errno = EINVAL; return -1; }}")
    if fn.write_function_code:
        regs = ", ".join(f"r{i + 1} = 0" for i in range(n))
        lines += [f"uint16_t {regs};", "double arg = value;", "(void)arg;"]
        lines += _fragment(fn.write_function_code)
        return lines + [f"r[{i}] = r{i + 1};" for i in range(n)] + ["return 0;"]
    if lay.kind == "bool":
        return lines + ["r[0] = value ? 1 : 0;", "return 0;"]
    span = span_bits(lay)
    if lay.kind == "string":
        nbytes = span // 8
        lines += [f"if (value.size() > {nbytes}) {{ errno = EINVAL; return -1; }}",
                  f"unsigned char s[{nbytes}] = {{0}};", "std::memcpy(s, value.data(), value.size());"]
        for pos, (i, part) in enumerate(units_msb_first(lay)):
            if lay.unit == "word":
                hi, lo = (f"s[{2 * pos}]", f"s[{2 * pos + 1}]") if part == "word" else (f"s[{2 * pos + 1}]", f"s[{2 * pos}]")
                lines.append(f"r[{i}] = static_cast<uint16_t>(({hi} << 8) | {lo});")
            else:
                lines.append(f"r[{i}] = static_cast<uint16_t>(s[{pos}]{' << 8' if part == 'high' else ''});")
        return lines + ["return 0;"]
    if lay.kind == "float":
        if scales(fn):
            lines.append(f"double x = (value - {cpp_number(fn.eff_offset)}) / {cpp_number(fn.eff_multiplier)};")
        else:
            lines.append("double x = value;")
        ctype, width = ("float", "uint32_t") if lay.bits == 32 else ("double", "uint64_t")
        lines += [f"{ctype} f = static_cast<{ctype}>(x);", f"{width} bits;", "std::memcpy(&bits, &f, sizeof bits);",
                  "uint64_t v = bits;"]
    else:
        lo, hi = int_range(lay)
        if scales(fn):
            lines += [f"double x = std::floor((value - {cpp_number(fn.eff_offset)}) / {cpp_number(fn.eff_multiplier)} + 0.5);",
                      f"if (!(x >= {cpp_number(lo)} && x <= {cpp_number(hi)})) {{ errno = EINVAL; return -1; }}"]
            if lay.bits == 64:  # the double range check is inexact at 2^63/2^64
                edge = "9223372036854775807.0" if lay.signed else "18446744073709551615.0"
                lines.append(f"if (x >= {edge}) {{ errno = EINVAL; return -1; }}")
            ctype = "int64_t" if lay.signed else "uint64_t"
            lines.append(f"uint64_t v = static_cast<uint64_t>(static_cast<{ctype}>(x));")
        else:
            tbits = int_type_bits(lay.bits)
            if tbits != lay.bits:
                lines.append(f"if (value < {lo}{'ll' if lay.signed else 'ull'} || value > {hi}{'ll' if lay.signed else 'ull'}) {{ errno = EINVAL; return -1; }}" if lay.signed
                             else f"if (value > {hi}ull) {{ errno = EINVAL; return -1; }}")
            lines.append("uint64_t v = static_cast<uint64_t>(value);")
        if span < 64:
            lines.append(f"v &= 0x{(1 << span) - 1:X}ull;")
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        shift = unit_shift(lay, pos)
        unit = f"(v >> {shift})" if shift else "v"
        expr = {"word": f"{unit} & 0xFFFFu", "swap": f"(({unit} & 0xFFu) << 8) | (({unit} >> 8) & 0xFFu)",
                "low": f"{unit} & 0xFFu", "high": f"({unit} & 0xFFu) << 8"}[part]
        lines.append(f"r[{i}] = static_cast<uint16_t>({expr});")
    return lines + ["return 0;"]


def context(device: Device, source_name: str) -> dict:
    stem = identifier(device.name)
    idents = unique_identifiers(fn.name for fn in device.functions)
    plan = plan_reads(device)
    groups, splits, offset = [], [], 0
    slot: dict[tuple[str, int], int] = {}
    for req in plan:
        parts = split_request(device, req)
        groups.append({"table": TABLE_CONST[req.table], "start": req.start, "count": req.count, "offset": offset,
                       "split_first": len(splits), "split_count": len(parts) if parts != [req] else 0})
        for a in range(req.start, req.end):
            slot[(req.table, a)] = offset + a - req.start
        splits += [{"table": TABLE_CONST[s.table], "start": s.start, "count": s.count,
                    "delta": s.start - req.start} for s in (parts if parts != [req] else [])]
        offset += req.count
    functions = []
    ident_of = dict(zip((fn.name for fn in device.functions), idents))
    for fn, ident in zip(device.functions, idents):
        lay = layout(fn)
        t = value_type(fn)
        deps = fn.compiled.deps if fn.compiled is not None else []
        functions.append({
            "fn": fn, "ident": ident, "t": t, "n": len(lay.addresses),
            "rt": f"std::optional<{t}>" if fn.not_implemented or fn.compiled is not None else t,
            "deps": [ident_of[d] for d in deps],
            "closure": [ident_of[f.name] for f in evaluation_order(device, [fn.name])] if deps else None,
            "runs": [{"table": TABLE_CONST[tb], "start": s, "count": c} for tb, s, c in runs(lay)],
            "bit": lay.unit == "bit",
            "decode": decode_lines(fn, t) if fn.readable else None,
            "encode": encode_lines(fn, t) if fn.writable else None,
            "not_implemented": [int(tok, 16) for tok in fn.not_implemented or []],
            "ni_tokens": fn.not_implemented or [],
            "slots": [slot[(lay.table, a)] for a in lay.addresses] if fn.readable else [],
            "doc": fn.description, "units": fn.units,
        })
    by_ident = {f["ident"]: f for f in functions}
    for f in functions:
        f["params"] = "".join(f", const std::optional<{by_ident[d]['t']}> &p{i}" for i, d in enumerate(f["deps"]))
        f["steps"] = [by_ident[i] for i in (f["closure"] or [f["ident"]])]
        f["expr"] = f["fn"].compiled is not None
        f["present"] = ", present" if f["expr"] else ""
    order = [ident_of[f.name] for f in evaluation_order(device, [fn.name for fn in device.functions if fn.readable])]
    return {
        "readable": [by_ident[i] for i in order], "by_ident": by_ident,
        "uses_expressions": any(fn.expression is not None for fn in device.functions),
        "expression_helpers": CPP_HELPERS,
        "uses_vector": any(f["t"] == "std::vector<std::string>" for f in functions),
        "device": device, "version": __version__, "source": source_name, "stem": stem,
        "class_name": camel(stem), "guard": f"MDL_{stem.upper().rstrip('_')}_H", "functions": functions,
        "groups": groups, "splits": splits, "raw_total": offset,
        "uses_optional": any(f["rt"].startswith("std::optional") for f in functions),
        "uses_string": any("std::string" in f["t"] for f in functions),
    }
