"""MDL model -> a standalone Python module over pymodbus (SPEC section 5).

The module is typed for `mypy --strict` and clean under ruff's default rules: it carries only the
helpers it calls and imports only what it uses. The decoders and encoders are written here as
whole functions; the names they use decide which runtime helpers (fragments' and expressions',
copied from their pyhelpers.py) and which standard-library imports the module gets.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from mdl import __version__
from mdl.lang.cfrag import FALLIBLE, compile_fragment
from mdl.lang.expr.fields import evaluation_order
from mdl.lang.expr.pyemit import HELPERS_SOURCE as RUNTIME_SOURCE
from mdl.lang.expr.pyemit import body as expr_body
from mdl.model import Device, Function
from mdl.model.layout import Layout, layout
from mdl.model.names import PY_HARD_KEYWORDS, camel, identifier, stem, unique_identifiers
from mdl.plan import plan_reads, split_request
from mdl.targets.base import Target
from mdl.targets.render import environment, pycomment, pyrepr
from mdl.values.codec import int_range, scales
from mdl.values.straight import span_bits, unit_shift, units_msb_first

# The lowest pymodbus a generated module runs on: the client methods' `device_id=` keyword
# arrived in 3.10.0 (before it: `slave=`). tests/test_generated_python_lint.py runs a driver on it.
PYMODBUS_REQUIREMENT = "pymodbus >= 3.10.0, < 4"

# standard-library names generated code may use -> the module that binds each (`import m` where the
# name is the module's)
STDLIB_IMPORTS = {
    "decimal": "decimal",
    "math": "math",
    "struct": "struct",
    "Callable": "collections.abc",
    "Sequence": "collections.abc",
}
# names the template's own code uses, wherever it is rendered
TEMPLATE_NAMES = {"Callable"}

# expression type -> Python type of its value (every expression value may be None)
EXPR_TYPES = {"double": "float", "long": "int", "string": "str", "bool": "bool", "list": "list[str]"}

Request = tuple[str, int, int]  # (table, first address, count)


def _names(source: str) -> set[str]:
    return {node.id for node in ast.walk(ast.parse(source)) if isinstance(node, ast.Name)}


def _loaded(lines: list[str]) -> set[str]:
    tree = ast.parse("\n".join(lines))
    return {node.id for node in ast.walk(tree) if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load)}


@lru_cache(maxsize=1)
def runtime_helpers() -> dict[str, tuple[str, frozenset[str]]]:
    """Fragments' and expressions' helper name -> (its source, the names it uses), in file order."""
    out = {}
    for node in ast.parse(RUNTIME_SOURCE).body:
        if isinstance(node, ast.FunctionDef):
            source = ast.get_source_segment(RUNTIME_SOURCE, node)
            assert source is not None
            out[node.name] = (source, frozenset(_names(source)))
    return out


def helpers_for(names: set[str]) -> list[str]:
    """Sources of the runtime helpers `names` call, and of those they call in turn, in file order."""
    helpers = runtime_helpers()
    wanted: set[str] = set()
    todo = [name for name in names if name in helpers]
    while todo:
        name = todo.pop()
        if name not in wanted:
            wanted.add(name)
            todo += [n for n in helpers[name][1] if n in helpers]
    return [source for name, (source, _) in helpers.items() if name in wanted]


def import_lines(names: set[str]) -> list[str]:
    """Standard-library imports for `names`, in isort's order: `import x` first, then `from x import a, b`."""
    modules: dict[str, list[str]] = {}
    for name in sorted(n for n in names if n in STDLIB_IMPORTS):
        modules.setdefault(STDLIB_IMPORTS[name], []).append(name)
    plain = [f"import {m}" for m, found in modules.items() if found == [m]]
    froms = [f"from {m} import {', '.join(found)}" for m, found in modules.items() if found != [m]]
    return sorted(plain) + sorted(froms)


# -- value types


def value_type(fn: Function) -> str:
    """The Python type of the function's value as read."""
    if fn.compiled is not None:
        return EXPR_TYPES[fn.compiled.type] + " | None"
    kind = layout(fn).kind
    if fn.read_function_code or kind == "float" or (kind == "int" and scales(fn)):
        base = "float"
    else:
        base = {"int": "int", "string": "str", "bool": "bool"}[kind]
    return base + " | None" if fn.not_implemented else base


def write_type(fn: Function) -> str:
    """The Python type a write method accepts."""
    kind = layout(fn).kind
    if fn.write_function_code or kind in ("int", "float"):
        return "float"
    return {"string": "str", "bool": "bool"}[kind]


# -- decoders


def _unit_expr(i: int, part: str) -> str:
    return {"word": f"r[{i}]", "swap": f"((r[{i}] & 0xFF) << 8) | (r[{i}] >> 8)",
            "low": f"r[{i}] & 0xFF", "high": f"r[{i}] >> 8"}[part]


def _compose(lay: Layout) -> str:
    """The expression composing the registers into one unsigned value."""
    units = units_msb_first(lay)
    if len(units) == 1:
        return _unit_expr(*units[0])
    terms = []
    for pos, (i, part) in enumerate(units):
        term = _unit_expr(i, part) if part == "word" else f"({_unit_expr(i, part)})"
        shift = unit_shift(lay, pos)
        terms.append(f"({term} << {shift})" if shift else term)
    return " | ".join(terms)


def _number(x: float) -> str:
    return repr(int(x)) if float(x).is_integer() and abs(x) < 1e15 else repr(float(x))


def _scale_lines(fn: Function, var: str) -> list[str]:
    if not scales(fn):
        return [f"return {var}"]
    return [f"return float(f'{{{var} * {_number(fn.eff_multiplier)} + {_number(fn.eff_offset)}:.15g}}')"]


# what a translated fragment's errors (ArithmeticError) become in a driver: the device's registers
# have no value, or the value written has no registers (docs/fragments.md)
FRAGMENT_ERRORS = {"read_function_code": "FragmentDomainError", "write_function_code": "ValueRangeError"}


def _guarded(fn: Function, attr: str, body: list[str]) -> list[str]:
    """The fragment's lines; where they can fail, in a try that raises the driver's exception
    naming the function."""
    if not _names("\n".join(body)) & set(FALLIBLE):
        return body
    prefix = pyrepr(f"function {fn.name!r}: {attr}: ")
    return ["try:", *("    " + line for line in body), "except ArithmeticError as exc:",
            f"    raise {FRAGMENT_ERRORS[attr]}({prefix} + str(exc)) from None"]


def _fragment_read_lines(fn: Function, nregs: int) -> list[str]:
    body = compile_fragment(fn.read_function_code or "", nregs, True).python_lines()
    loaded = _loaded(body)
    unpack = [f"r{i + 1} = r[{i}]" for i in range(nregs) if f"r{i + 1}" in loaded]
    return [*unpack, "arg = 0.0", *_guarded(fn, "read_function_code", body), "return arg"]


def decode_lines(fn: Function) -> list[str]:
    """The body of the function's decoder: registers `r` (and p0..pn for an expression) -> value."""
    if fn.compiled is not None:
        return expr_body(fn.compiled.lowered)
    lay = layout(fn)
    lines = []
    if fn.not_implemented:
        lines += [f"if _not_implemented(r, {tuple(fn.not_implemented)!r}):", "    return None"]
    if fn.read_function_code:
        return lines + _fragment_read_lines(fn, len(lay.addresses))
    if lay.kind == "bool":
        return lines + ["return bool(r[0])"]
    span = span_bits(lay)
    lines.append(f"v = {_compose(lay)}")
    if lay.kind == "string":
        return lines + [f"return v.to_bytes({span // 8}, 'big').rstrip(b'\\x00 ').decode('utf-8', 'replace')"]
    if lay.kind == "float":
        fmt = "f" if lay.bits == 32 else "d"
        lines.append(f"x: float = struct.unpack('>{fmt}', v.to_bytes({span // 8}, 'big'))[0]")
        return lines + _scale_lines(fn, "x")
    if lay.bits < span:
        lines.append(f"v &= {hex((1 << lay.bits) - 1)}")
    if lay.signed:
        lines += [f"if v >> {lay.bits - 1}:", f"    v -= {hex(1 << lay.bits)}"]
    return lines + _scale_lines(fn, "v")


def _decoder(fn: Function, ident: str, types: dict[str, str]) -> str:
    """The whole decoder; `types` gives the value type of each function an expression names."""
    if fn.compiled is not None:
        params = ["r: Sequence[int | None]"] + [f"p{i}: {types[d]}" for i, d in enumerate(fn.compiled.deps)]
    else:
        params = ["r: list[int]"]
    head = f"def _decode_{ident}({', '.join(params)}) -> {value_type(fn)}:"
    return "\n".join([head] + ["    " + line for line in decode_lines(fn)])


# -- encoders


def _range_lines(fn: Function) -> list[str]:
    lines = []
    if fn.minimum is not None:
        lines += [f"if value < {fn.minimum!r}:",
                  f"    raise ValueRangeError(f'{{value}} is below the minimum {fn.minimum:g}')"]
    if fn.maximum is not None:
        lines += [f"if value > {fn.maximum!r}:",
                  f"    raise ValueRangeError(f'{{value}} is above the maximum {fn.maximum:g}')"]
    return lines


def _fragment_write_lines(fn: Function, nregs: int) -> list[str]:
    regs = [f"r{i + 1}" for i in range(nregs)]
    body = compile_fragment(fn.write_function_code or "", nregs, False).python_lines()
    start = ["arg = float(value)"] if "arg" in _loaded(body) else []
    return [*start, *(f"{r} = 0" for r in regs), *_guarded(fn, "write_function_code", body),
            f"return [{', '.join(regs)}]"]


def _text_lines(span: int) -> list[str]:
    return ["if not isinstance(value, str):", "    raise ValueRangeError(f'expects text, got {value!r}')",
            "data = value.encode('utf-8')",
            f"if len(data) > {span // 8}:",
            f"    raise ValueRangeError(f'text of {{len(data)}} bytes does not fit {span // 8} bytes')",
            f"v = int.from_bytes(data.ljust({span // 8}, b'\\x00'), 'big')"]


def _integer_lines(lay: Layout, span: int) -> list[str]:
    lo, hi = int_range(lay)
    return ["if not isinstance(value, int):",
            "    if not math.isfinite(value):",
            "        raise ValueRangeError(f'{value} is not a finite number')",
            "    value = math.floor(value + 0.5)",
            f"if not {lo} <= value <= {hi}:",
            f"    raise ValueRangeError(f'{{value}} does not fit {'' if lay.signed else 'u'}int{lay.bits}')",
            f"v = value & {hex((1 << span) - 1)}"]


def _register_parts(lay: Layout) -> list[str]:
    regs = [""] * len(lay.addresses)
    for pos, (i, part) in enumerate(units_msb_first(lay)):
        shift = unit_shift(lay, pos)
        unit = f"(v >> {shift})" if shift else "v"
        regs[i] = {"word": f"{unit} & 0xFFFF", "swap": f"(({unit} & 0xFF) << 8) | (({unit} >> 8) & 0xFF)",
                   "low": f"{unit} & 0xFF", "high": f"({unit} & 0xFF) << 8"}[part]
    return regs


def encode_lines(fn: Function) -> list[str]:
    """The body of the function's encoder: `value` -> registers, or ValueRangeError."""
    lay = layout(fn)
    lines = []
    if lay.kind in ("int", "float") or fn.write_function_code:
        lines += ["if isinstance(value, bool) or not isinstance(value, (int, float)):",
                  "    raise ValueRangeError(f'expects a number, got {value!r}')"]
    if lay.kind != "string":
        lines += _range_lines(fn)
    if fn.write_function_code:
        return lines + _fragment_write_lines(fn, len(lay.addresses))
    if lay.kind == "bool":
        return lines + ["return [1 if value else 0]"]
    span = span_bits(lay)
    if lay.kind == "string":
        lines += _text_lines(span)
    else:
        if fn.eff_offset:
            lines.append(f"value = value - {_number(fn.eff_offset)}")
        if fn.eff_multiplier != 1.0:
            lines.append(f"value = value / {_number(fn.eff_multiplier)}")
        if lay.kind == "float":
            fmt = "f" if lay.bits == 32 else "d"
            lines.append(f"v = int.from_bytes(struct.pack('>{fmt}', float(value)), 'big')")
        else:
            lines += _integer_lines(lay, span)
    return lines + [f"return [{', '.join(_register_parts(lay))}]"]


def _encoder(fn: Function, ident: str) -> str:
    head = f"def _encode_{ident}(value: {write_type(fn)}) -> list[int]:"
    return "\n".join([head] + ["    " + line for line in encode_lines(fn)])


# -- the module


def docstring(text: str) -> str:
    """A docstring literal of `text` on one line: nothing in the text can end it early (a quote or a
    backslash at its end, quotes inside, line breaks of any kind)."""
    body = pycomment(text)
    if body.endswith('"'):
        body = body[:-1] + '\\"'
    return f'"""{body}"""'


def doc_text(fn: Function) -> str:
    text = " ".join(fn.description.split()) or fn.name
    return f"{text} [{fn.units.strip()}]" if fn.units and fn.units.strip() else text


def runs(lay: Layout) -> list[Request]:
    out: list[list[Any]] = []
    for a in lay.addresses:
        if out and out[-1][1] + out[-1][2] == a:
            out[-1][2] += 1
        else:
            out.append([lay.table, a, 1])
    return [(table, start, count) for table, start, count in out]


def _read_plan(device: Device) -> list[tuple[Request, tuple[Request, ...]]]:
    """Each request of the read plan, with the smaller ones that replace it when the device refuses it."""
    groups = []
    for r in plan_reads(device):
        parts = split_request(device, r)
        smaller = tuple((s.table, s.start, s.count) for s in parts) if parts != [r] else ()
        groups.append(((r.table, r.start, r.count), smaller))
    return groups


def _gather(fn: Function, lay: Layout) -> str:
    """The expression in read_all giving the function's registers: None for a missing one where an
    expression can take it, else ModbusExceptionError."""
    if fn.compiled is not None:
        return f"_get(raw, {lay.table!r}, {tuple(lay.addresses)!r})"
    return f"_need(raw, {fn.name!r}, {lay.table!r}, {tuple(lay.addresses)!r})"


def _typed_dict_form(names: list[str]) -> str:
    """"class" where every key can be a class attribute (ruff asks for that form), else "call"."""
    ok = all(n.isidentifier() and n not in PY_HARD_KEYWORDS and not n.startswith("__") for n in names)
    return "class" if ok else "call"


@dataclass
class FunctionCode:
    """What the template writes for one function."""

    fn: Function
    ident: str
    runs: list[Request]  # the requests reading its registers
    doc: str
    type: str  # of its value
    decoder: str | None  # source of _decode_<ident>, if it is readable
    encoder: str | None  # source of _encode_<ident>, if it is writable
    write_type: str | None
    args: str  # ", v_a, v_b": the values of the functions its expression names
    gather: str  # its registers in read_all
    closure: list[str]  # the functions to decode before it, dependencies first


def function_code(device: Device, fn: Function, idents: dict[str, str], types: dict[str, str]) -> FunctionCode:
    lay = layout(fn)
    ident = idents[fn.name]
    deps = fn.compiled.deps if fn.compiled is not None else []
    return FunctionCode(
        fn=fn, ident=ident, runs=runs(lay), doc=doc_text(fn), type=types[fn.name],
        decoder=_decoder(fn, ident, types) if fn.readable else None,
        encoder=_encoder(fn, ident) if fn.writable else None,
        write_type=write_type(fn) if fn.writable else None,
        args="".join(f", v_{idents[d]}" for d in deps), gather=_gather(fn, lay),
        closure=[f.name for f in evaluation_order(device, [fn.name])[:-1]] if deps else [],
    )


def context(device: Device, source_name: str) -> dict[str, Any]:
    names = [fn.name for fn in device.functions]
    idents = dict(zip(names, unique_identifiers(names), strict=True))
    types = {fn.name: value_type(fn) for fn in device.functions}
    functions = [function_code(device, fn, idents, types) for fn in device.functions]
    infos = {f.fn.name: f for f in functions}
    readable = [infos[fn.name] for fn in evaluation_order(device, [fn.name for fn in device.functions if fn.readable])]
    code = [text for f in functions for text in (f.decoder, f.encoder) if text] + [f.gather for f in readable]
    used = set().union(*map(_names, code))
    helpers = helpers_for(used)
    used = used.union(*map(_names, helpers), TEMPLATE_NAMES)
    class_name = camel(identifier(device.name))
    exports = [class_name, f"Async{class_name}", f"{class_name}Values", "CommunicationError", "DeviceError",
               "ModbusExceptionError", "ValueRangeError"]
    exports += [name for name in ("FragmentDomainError",) if name in used]
    return {
        "device": device, "version": __version__, "source": source_name, "requirement": PYMODBUS_REQUIREMENT,
        "functions": functions, "infos": infos, "readable": readable, "class_name": class_name,
        "values_name": f"{class_name}Values", "values_form": _typed_dict_form([f.fn.name for f in readable]),
        "groups": _read_plan(device), "imports": import_lines(used), "helpers": helpers, "uses": used,
        "exports": sorted(exports), "writes": any(f.encoder for f in functions),
        "module_doc": docstring(f"Driver for {device.name}: {device.description}"),
    }


def render_files(device: Device, source_name: str) -> dict[str, str]:
    ctx = context(device, source_name)
    return {f"{stem(device.name)}.py": environment().get_template("python/templates/device.py.j2").render(**ctx)}


TARGET = Target("python", "<stem>.py: a module over pymodbus, sync and asyncio classes", render_files)
