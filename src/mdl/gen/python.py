"""MDL model -> a standalone Python module over pymodbus (SPEC section 5)."""

from __future__ import annotations

from mdl import __version__
from mdl.cfrag import HELPERS_SOURCE, python_body
from mdl.expr.fields import evaluation_order
from mdl.expr.pyemit import HELPERS_SOURCE as EXPR_HELPERS
from mdl.expr.pyemit import body as expr_body
from mdl.codec import int_range, scales
from mdl.gen.straight import span_bits, unit_shift, units_msb_first
from mdl.layout import layout
from mdl.model import Device, Function
from mdl.names import camel, identifier, unique_identifiers
from mdl.plan import plan_reads, split_request


def _unit_expr(i: int, part: str) -> str:
    return {"word": f"r[{i}]", "swap": f"(((r[{i}] & 0xFF) << 8) | (r[{i}] >> 8))",
            "low": f"(r[{i}] & 0xFF)", "high": f"(r[{i}] >> 8)"}[part]


def _compose(lay) -> str:
    terms = []
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        shift = unit_shift(lay, pos)
        terms.append(_unit_expr(i, part) + (f" << {shift}" if shift else ""))
    return " | ".join(f"({t})" if "<<" in t else t for t in terms)


def _number(x: float) -> str:
    return repr(int(x)) if float(x).is_integer() and abs(x) < 1e15 else repr(float(x))


def decode_lines(fn: Function) -> list[str]:
    if fn.compiled is not None:
        return expr_body(fn.compiled.lowered)
    lay = layout(fn)
    lines = []
    if fn.not_implemented:
        lines.append(f"if _not_implemented(r, {tuple(fn.not_implemented)!r}):")
        lines.append("    return None")
    if fn.read_function_code:
        regs = ", ".join(f"r{i + 1}" for i in range(len(lay.addresses)))
        lines += [f"{regs}, = r", "arg = 0.0"] + python_body(fn.read_function_code, len(lay.addresses))
        return lines + ["return arg"]
    if lay.kind == "bool":
        return lines + ["return bool(r[0])"]
    span = span_bits(lay)
    lines.append(f"v = {_compose(lay)}")
    if lay.kind == "string":
        return lines + [f"return v.to_bytes({span // 8}, 'big').rstrip(b'\\x00 ').decode('utf-8', 'replace')"]
    if lay.kind == "float":
        return lines + [f"v = struct.unpack('>{'f' if lay.bits == 32 else 'd'}', v.to_bytes({span // 8}, 'big'))[0]"] + _scale_lines(fn)
    if lay.bits < span:
        lines.append(f"v &= {hex((1 << lay.bits) - 1)}")
    if lay.signed:
        lines.append(f"if v >> {lay.bits - 1}:")
        lines.append(f"    v -= {hex(1 << lay.bits)}")
    return lines + _scale_lines(fn)


def _scale_lines(fn: Function) -> list[str]:
    if not scales(fn):
        return ["return v"]
    return [f"return float(f'{{v * {_number(fn.eff_multiplier)} + {_number(fn.eff_offset)}:.15g}}')"]


def encode_lines(fn: Function) -> list[str]:
    lay = layout(fn)
    n = len(lay.addresses)
    lines = []
    numeric = lay.kind in ("int", "float") or fn.write_function_code
    if numeric:
        lines += ["if isinstance(value, bool) or not isinstance(value, (int, float)):",
                  "    raise ValueRangeError(f'expects a number, got {value!r}')"]
    if fn.minimum is not None:
        lines += [f"if value < {fn.minimum!r}:", f"    raise ValueRangeError(f'{{value}} is below the minimum {fn.minimum:g}')"]
    if fn.maximum is not None:
        lines += [f"if value > {fn.maximum!r}:", f"    raise ValueRangeError(f'{{value}} is above the maximum {fn.maximum:g}')"]
    if fn.write_function_code:
        regs = [f"r{i + 1}" for i in range(n)]
        lines += ["arg = float(value)", f"{', '.join(regs)}, = [0] * {n}"]
        lines += python_body(fn.write_function_code, n)
        return lines + [f"return [{', '.join(regs)}]"]
    if lay.kind == "bool":
        return lines + ["return [1 if value else 0]"]
    span = span_bits(lay)
    if lay.kind == "string":
        lines += ["if not isinstance(value, str):", "    raise ValueRangeError(f'expects text, got {value!r}')",
                  "data = value.encode('utf-8')",
                  f"if len(data) > {span // 8}:",
                  f"    raise ValueRangeError(f'text of {{len(data)}} bytes does not fit {span // 8} bytes')",
                  f"v = int.from_bytes(data.ljust({span // 8}, b'\\x00'), 'big')"]
    else:
        if fn.eff_offset:
            lines.append(f"value = value - {_number(fn.eff_offset)}")
        if fn.eff_multiplier != 1.0:
            lines.append(f"value = value / {_number(fn.eff_multiplier)}")
        if lay.kind == "float":
            fmt = "f" if lay.bits == 32 else "d"
            lines.append(f"v = int.from_bytes(struct.pack('>{fmt}', float(value)), 'big')")
        else:
            lo, hi = int_range(lay)
            lines += ["if isinstance(value, float):",
                      "    if value != value or value in (float('inf'), float('-inf')):",
                      "        raise ValueRangeError(f'{value} is not a finite number')",
                      "    value = math.floor(value + 0.5)",
                      f"if not {lo} <= value <= {hi}:",
                      f"    raise ValueRangeError(f'{{value}} does not fit {'' if lay.signed else 'u'}int{lay.bits}')",
                      f"v = value & {hex((1 << span) - 1)}"]
    regs = [""] * n
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        shift = unit_shift(lay, pos)
        unit = f"(v >> {shift})" if shift else "v"
        regs[i] = {"word": f"{unit} & 0xFFFF", "swap": f"(({unit} & 0xFF) << 8) | (({unit} >> 8) & 0xFF)",
                   "low": f"{unit} & 0xFF", "high": f"({unit} & 0xFF) << 8"}[part]
    return lines + [f"return [{', '.join(regs)}]"]


def doc_text(fn: Function) -> str:
    text = " ".join(fn.description.split()) or fn.name
    return f"{text} [{fn.units.strip()}]" if fn.units and fn.units.strip() else text


def runs(lay) -> list[tuple[str, int, int]]:
    out: list[list] = []
    for a in lay.addresses:
        if out and out[-1][1] + out[-1][2] == a:
            out[-1][2] += 1
        else:
            out.append([lay.table, a, 1])
    return [tuple(r) for r in out]


def context(device: Device, source_name: str) -> dict:
    idents = unique_identifiers(fn.name for fn in device.functions)
    ident_of = dict(zip((fn.name for fn in device.functions), idents))
    functions = []
    for fn, ident in zip(device.functions, idents):
        lay = layout(fn)
        deps = fn.compiled.deps if fn.compiled is not None else []
        functions.append({
            "fn": fn, "ident": ident, "runs": runs(lay), "table": lay.table,
            "regkeys": [(lay.table, a) for a in lay.addresses], "doc": doc_text(fn),
            "decode": decode_lines(fn) if fn.readable else None,
            "encode": encode_lines(fn) if fn.writable else None,
            "params": "".join(f", p{i}" for i in range(len(deps))), "deps": deps,
            "closure": [f.name for f in evaluation_order(device, [fn.name])] if deps else None,
        })
    order = [f.name for f in evaluation_order(device, [fn.name for fn in device.functions if fn.readable])]
    by_name = {f["fn"].name: f for f in functions}
    plan = plan_reads(device)
    groups = []
    for r in plan:
        parts = split_request(device, r)
        groups.append(((r.table, r.start, r.count), [(s.table, s.start, s.count) for s in parts] if parts != [r] else []))
    ident = identifier(device.name)
    return {
        "device": device, "version": __version__, "source": source_name, "functions": functions,
        "class_name": camel(ident), "groups": groups, "ident_of": ident_of,
        "readable": [by_name[name] for name in order],
        "uses_fragments": any(fn.read_function_code or fn.write_function_code for fn in device.functions),
        "fragment_helpers": HELPERS_SOURCE,
        "uses_expressions": any(fn.expression is not None for fn in device.functions),
        "expression_helpers": EXPR_HELPERS,
        "uses_closures": any(f["closure"] for f in functions),
    }
