"""MDL model -> a standalone Python module over pymodbus (SPEC section 5).

The module is typed for `mypy --strict` and clean under ruff's default rules: it carries only the
helpers it calls and imports only what it uses. The decoders and encoders are printed whole by
templates/ops.j2, their bodies from the IR once per distinct IR; the names they use decide which
runtime helpers (fragments' and expressions', copied from their pyhelpers.py) and which
standard-library imports the module gets. The other parts printed once per function (methods, the
rows of the tables) are printed by per_function.py from each function's FunctionCode, worked out once.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import jinja2

from mdl import __version__
from mdl.dsl.cfrag import FALLIBLE
from mdl.dsl.expr.pyemit import HELPERS_SOURCE as RUNTIME_SOURCE
from mdl.dsl.expr.pyemit import body as expr_body
from mdl.ir import steps as ir
from mdl.ir.steps import ValueType
from mdl.model import Function
from mdl.model.names import PY_HARD_KEYWORDS, camel, identifier
from mdl.resolver import ResolvedDevice, ResolvedFunction
from mdl.targets.base import Target
from mdl.targets.profile import Interface, check_files
from mdl.targets.python import per_function
from mdl.targets.templating import RuntimePart, SharedRendering, double_literal, pick, pycomment, pyrepr
from mdl.targets.templating import environment as render_environment

# The lowest pymodbus a generated module runs on: the client methods' `device_id=` keyword
# arrived in 3.10.0 (before it: `slave=`). tests/compile/test_generated_python_lint.py runs a driver on it.
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

# a profile role's type -> the Python type of its value (mdl.targets.profile)
ROLE_TYPES = {"float": "float", "int": "int", "bool": "bool"}
# expression type -> Python type of its value (every expression value may be None)
EXPR_TYPES = {"double": "float", "long": "int", "string": "str", "bool": "bool", "list": "list[str]"}

Request = tuple[str, int, int]  # (table, first address, count)


# what is not code in generated Python: string literals (no triple quotes are generated inside
# functions) and comments
_NOT_CODE = re.compile(r"""'(?:\\.|[^'\\\n])*'|"(?:\\.|[^"\\\n])*"|#[^\n]*""")
_IDENTIFIER = re.compile(r"\b[A-Za-z_]\w*\b")


def _names(source: str) -> set[str]:
    """The identifiers of generated Python code outside strings and comments (a superset of the
    names it uses: attribute names and keywords too, which match no helper and no import)."""
    return set(_IDENTIFIER.findall(_NOT_CODE.sub(" ", source)))


def _loaded(lines: list[str]) -> set[str]:
    tree = ast.parse("\n".join(lines))
    return {node.id for node in ast.walk(tree) if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load)}


@lru_cache(maxsize=1)
def runtime_helpers() -> list[RuntimePart]:
    """Fragments' and expressions' helpers (each with the names it uses), in file order."""
    out = []
    lines = RUNTIME_SOURCE.splitlines(keepends=True)
    for node in ast.parse(RUNTIME_SOURCE).body:
        if isinstance(node, ast.FunctionDef):  # top-level: whole lines, from its `def` (helpers have no decorators)
            source = "".join(lines[node.lineno - 1 : node.end_lineno]).rstrip("\n")
            names = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}  # docstrings are not code
            out.append(RuntimePart((node.name,), source, frozenset(names)))
    return out


# every name a `def` at the start of a line of the runtime defines (its helpers, and maybe more),
# found without parsing it
_RUNTIME_DEFS = frozenset(re.findall(r"^def (\w+)", RUNTIME_SOURCE, re.MULTILINE))


def helpers_for(names: set[str]) -> list[str]:
    """Sources of the runtime helpers `names` call, and of those they call in turn, in file order
    (templating.pick)."""
    if _RUNTIME_DEFS.isdisjoint(names):  # it calls none (most devices): the runtime is not parsed
        return []
    return [part.source for part in pick(runtime_helpers(), names)]


def import_lines(names: set[str]) -> list[str]:
    """Standard-library imports for `names`, in isort's order: `import x` first, then `from x import a, b`."""
    modules: dict[str, list[str]] = {}
    for name in sorted(n for n in names if n in STDLIB_IMPORTS):
        modules.setdefault(STDLIB_IMPORTS[name], []).append(name)
    plain = [f"import {m}" for m, found in modules.items() if found == [m]]
    froms = [f"from {m} import {', '.join(found)}" for m, found in modules.items() if found != [m]]
    return sorted(plain) + sorted(froms)


# -- value types


# a value type's kind -> the Python type of its value as read (None aside), and the one a write takes
# (an int is a float to mypy)
VALUE_TYPES = {"int": "int", "float": "float", "string": "str", "bool": "bool"}
WRITE_TYPES = {"int": "float", "float": "float", "string": "str", "bool": "bool"}


def value_type(vt: ValueType) -> str:
    """The Python type of a function's value as read."""
    if vt.kind == "expr":
        return EXPR_TYPES[vt.expr_type] + " | None"
    base = VALUE_TYPES[vt.kind]
    return base + " | None" if vt.nullable else base


# -- fragments: mdl.dsl.cfrag translates them to Python (docs/fragments.md says what they compute)

# what a translated fragment's errors (ArithmeticError) become in a driver: the device's registers
# have no value, or the value written has no registers (docs/fragments.md)
FRAGMENT_ERRORS = {"read_function_code": "FragmentDomainError", "write_function_code": "ValueRangeError"}


def _guarded(fn: Function, attr: str, body: list[str]) -> list[str]:
    """The fragment's lines; where they can fail, in a try that raises the driver's exception
    naming the function."""
    if not _names("\n".join(body)) & set(FALLIBLE):
        return body
    prefix = pyrepr(f"function {fn.name!r}: {attr}: ")
    return [
        "try:",
        *("    " + line for line in body),
        "except ArithmeticError as exc:",
        f"    raise {FRAGMENT_ERRORS[attr]}({prefix} + str(exc)) from None",
    ]


def _fragment_read_lines(fn: Function, step: ir.Fragment) -> list[str]:
    body = step.tree.python_lines()
    loaded = _loaded(body)
    unpack = [f"r{i + 1} = r[{i}]" for i in range(step.nregs) if f"r{i + 1}" in loaded]
    return [*unpack, "arg = 0.0", *_guarded(fn, "read_function_code", body), "return arg"]


def _fragment_write_lines(fn: Function, step: ir.Fragment) -> list[str]:
    regs = [f"r{i + 1}" for i in range(step.nregs)]
    body = step.tree.python_lines()
    start = ["arg = float(value)"] if "arg" in _loaded(body) else []
    return [
        *start,
        *(f"{r} = 0" for r in regs),
        *_guarded(fn, "write_function_code", body),
        f"return [{', '.join(regs)}]",
    ]


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


def _read_plan(resolved: ResolvedDevice) -> list[tuple[Request, int, tuple[Request, ...]]]:
    """Each request of the read plan, its first slot in the buffer, and the smaller requests that
    replace it when the device refuses it."""
    return [
        (
            (g.request.table, g.request.start, g.request.count),
            g.offset,
            tuple((s.table, s.start, s.count) for s in g.smaller),
        )
        for g in resolved.plan
    ]


def span(slots: tuple[int, ...]) -> tuple[int, int] | None:
    """(first, end) where the slots are more than 4 and consecutive: a slice of the buffer; else None:
    a list of its items (cheaper than a slice for a few)."""
    if len(slots) > 4 and slots == tuple(range(slots[0], slots[0] + len(slots))):
        return slots[0], slots[0] + len(slots)
    return None


def _typed_dict_form(names: list[str]) -> str:
    """ "class" where every key can be a class attribute (ruff asks for that form), else "call"."""
    ok = all(n.isidentifier() and n not in PY_HARD_KEYWORDS and not n.startswith("__") for n in names)
    return "class" if ok else "call"


@dataclass(eq=False, slots=True)  # compared by identity: one per function
class FunctionCode:
    """What the templates and the printers (per_function.py) write for one function."""

    resolved: ResolvedFunction
    fn: Function
    name: str  # its MDL name
    ident: str
    codec: ir.Codec  # its value IR, which templates/ops.j2 prints
    runs: str  # the requests reading its registers, (table, first address, count), as a list literal
    doc: str  # its description, as the string literal its methods' docstring is
    type: str  # of its value
    write_type: str | None
    params: str  # of its decoder
    args: str  # ", v_a, v_b": the values of the functions its expression names
    slots: tuple[int, ...]  # where its registers are in read_all's buffer, if readable
    span: tuple[int, int] | None  # (first, end) where those are read as a slice
    # (the sequences below are () where empty, the one empty tuple: no object of its own per function,
    # fewer for the garbage collector to count)
    closure: Sequence[str]  # the functions to decode before it, dependencies first
    fragment_read: Sequence[str]  # a read fragment's Python lines
    fragment_write: Sequence[str]
    expression_body: Sequence[str]  # an expression's Python lines
    merge: ir.Merge | None  # a function with bits: how its registers are written (read-modify-write or FC22)
    factor: str | None  # the function whose value scales it (scale_exponent, scale_by)
    decode_body: str = ""  # the body of _decode_<ident> (ops.j2), if readable
    encode_body: str = ""  # the body of _encode_<ident>, if writable


def _runs(f: ResolvedFunction) -> str:
    """The requests reading the function's registers, (table, first address, count), as a list literal."""
    table, runs = f.layout.table, f.runs
    if len(runs) == 1:  # most functions: one run (its repr spelled out, without the list of one tuple)
        ((start, count),) = runs
        return f"[({table!r}, {start}, {count})]"
    return repr([(table, start, count) for start, count in runs])


def function_code(
    resolved: ResolvedDevice, f: ResolvedFunction, types: dict[str, str], idents: dict[str, str]
) -> FunctionCode:
    fn, codec = f.fn, f.codec
    decode, encode = codec.decode, codec.encode
    deps = f.deps
    if f.compiled is not None:
        params = ", ".join(["r: Sequence[int | None]"] + [f"p{i}: {types[d]}" for i, d in enumerate(deps)])
        factor = fn.factor
    elif deps:  # scaled by another function's value
        params = "r: list[int], p0: int | None"  # a factor is an integer (mdl.resolver.packing)
        factor = deps[0]  # without an expression, deps is the factor alone
    else:
        params = "r: list[int]"
        factor = None
    fragment_read: Sequence[str] = ()
    expression_body: Sequence[str] = ()
    if decode is not None and f.decode_shape is None:  # it has a fragment or an expression
        read_fragment = ir.find_step(decode, ir.Fragment)
        expression = ir.find_step(decode, ir.Expression)
        fragment_read = _fragment_read_lines(fn, read_fragment) if read_fragment else ()
        expression_body = expr_body(expression.lowered) if expression else ()
    fragment_write: Sequence[str] = ()
    merge = None
    if encode is not None:
        if f.encode_shape is None:  # it has a fragment
            write_fragment = ir.find_step(encode, ir.Fragment)
            fragment_write = _fragment_write_lines(fn, write_fragment) if write_fragment else ()
        merge = ir.find_step(encode, ir.Merge)
    slots = resolved.slots_of(f) if decode is not None else ()  # decode: None where it cannot be read
    name = fn.name
    return FunctionCode(
        f,
        fn,
        name,
        f.ident,
        codec,
        _runs(f),
        ascii(doc_text(fn)),  # pyrepr
        types[name],
        WRITE_TYPES[codec.write_type.kind] if encode is not None else None,
        params,
        "".join([f", v_{idents[d]}" for d in deps]) if deps else "",
        slots,
        span(slots),
        [g.name for g in resolved.closure([name])[:-1]] if deps else (),
        fragment_read,
        fragment_write,
        expression_body,
        merge,
        factor,
    )


def print_bodies(functions: list[FunctionCode], env: jinja2.Environment) -> None:
    """Each function's decoder and encoder body, printed by ops.j2 from its IR: functions of the
    same IR share one printing."""
    ops = env.get_template("python/templates/ops.j2").module
    decode_body = SharedRendering(ops.decode_body)  # type: ignore[attr-defined]
    encode_body = SharedRendering(ops.encode_body)  # type: ignore[attr-defined]
    decoded: dict[object, str] = {}  # shape, or an expression's lines -> body
    encoded: dict[tuple[str, str], str] = {}
    for code in functions:
        f, codec = code.resolved, code.codec
        if codec.decode is not None:
            shape = f.decode_shape
            # an expression's body is its lines alone (its one step): the same lines, the same body
            key: object = (
                shape
                if shape is not None
                else tuple(code.expression_body)
                if code.expression_body and len(codec.decode) == 1
                else None
            )
            body = decoded.get(key) if key is not None else None
            if body is None:
                body = decode_body(shape, codec.decode, code.fragment_read, code.expression_body).rstrip()
                if key is not None:
                    decoded[key] = body
            code.decode_body = body
        if codec.encode is not None:
            key = (f.encode_shape, codec.write_type.kind) if f.encode_shape is not None else None
            body = encoded.get(key) if key is not None else None
            if body is None:
                body = encode_body(f.encode_shape, codec.encode, codec.write_type.kind, code.fragment_write).rstrip()
                if key is not None:
                    encoded[key] = body
            code.encode_body = body


def _tuple(items: list[str]) -> str:
    """A Python tuple literal of the items (a one-item tuple with its comma)."""
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def _hexpatterns(patterns: tuple[tuple[int, ...], ...]) -> str:
    """The "not implemented" patterns as a tuple of tuples of register values in hex."""
    return _tuple([_tuple([f"0x{w:04X}" for w in p]) for p in patterns])


def environment() -> jinja2.Environment:
    env = render_environment()
    env.filters["pyfloat"] = lambda x: double_literal(float(x))  # reads back as the same double
    env.filters["hexpatterns"] = _hexpatterns
    env.filters["docstring"] = docstring
    env.globals["py_types"] = ROLE_TYPES
    return env


def context(resolved: ResolvedDevice, source_name: str, env: jinja2.Environment) -> dict[str, Any]:
    device = resolved.device
    types = {f.name: value_type(f.codec.value_type) for f in resolved.functions}
    idents = {f.name: f.ident for f in resolved.functions}
    functions = [function_code(resolved, f, types, idents) for f in resolved.functions]
    print_bodies(functions, env)
    infos = {f.fn.name: f for f in functions}
    readable = [infos[f.name] for f in resolved.readable]
    # the names the code uses (each distinct text scanned once): which helpers and imports it needs
    code_text = {text for f in functions for text in (f.decode_body, f.params, f.type) if f.decode_body}
    code_text |= {text for f in functions for text in (f.encode_body, f.write_type or "") if f.encode_body}
    used = set().union(*map(_names, code_text))
    helpers = helpers_for(used)
    used = used.union(*map(_names, helpers), TEMPLATE_NAMES)
    class_name = camel(identifier(device.name))
    exports = [
        class_name,
        f"Async{class_name}",
        f"{class_name}Values",
        "CommunicationError",
        "DeviceError",
        "ModbusExceptionError",
        "ValueRangeError",
    ]
    exports += [name for name in ("FragmentDomainError",) if name in used]
    values_form = _typed_dict_form([f.name for f in readable])
    plain = [f for f in readable if f.resolved.compiled is None]
    return {
        "device": device,
        "version": __version__,
        "source": source_name,
        "requirement": PYMODBUS_REQUIREMENT,
        "infos": infos,
        "readable": readable,
        "class_name": class_name,
        "values_name": f"{class_name}Values",
        "values_form": values_form,
        "groups": _read_plan(resolved),
        "buffer_size": resolved.buffer_size,
        "imports": import_lines(used),
        "helpers": helpers,
        "uses": used,
        "plain": plain,
        "function_methods": per_function.methods(functions, infos),
        "functions": functions,  # ops.j2's definitions
        "slot_rows": per_function.slot_rows(plain),
        "name_rows": per_function.name_rows(readable),
        "value_fields": per_function.value_fields(readable, values_form),
        "decode_lines": per_function.decode_lines(readable),
        "store_lines": per_function.store_lines(readable),
        "exports": sorted(exports),
        "writes": any(f.encode_body for f in functions),
        "writes_multiple": any(f.encode_body and f.fn.write_multiple for f in functions),  # FC15/FC16 only
        "mask_writes": any(f.encode_body and f.merge and f.merge.mask_write for f in functions),  # FC22
        "module_doc": docstring(f"Driver for {device.name}: {device.description}"),
    }


def render_files(resolved: ResolvedDevice, source_name: str, interface: Interface | None = None) -> dict[str, str]:
    env = environment()
    ctx = context(resolved, source_name, env)
    ctx["profile"] = interface
    driver = {f"{resolved.stem}.py": env.get_template("python/templates/device.py.j2").render(**ctx)}
    if interface is None:
        return driver
    shared = env.get_template("python/templates/profile.py.j2").render(
        iface=interface,
        version=__version__,
        module_doc=docstring(f"The {interface.name} profile's interface: what every device's driver implements."),
    )
    return check_files(interface, driver, {f"{interface.py_module}.py": shared})


TARGET = Target("python", render_files)
