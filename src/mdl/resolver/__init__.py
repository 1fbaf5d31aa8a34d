"""The resolve step: a document model (from any source) -> an immutable resolved device.

`resolve(device)` runs every check of SPEC 2 in order (mdl.resolver.checks), compiles fragments
and expressions, computes each function's layout and value IR once, its identifier, the order
functions are decoded in (expressions after the fields they name) and the read plan. Everything
after it (the runtime, the simulator, scenarios, every target) reads the resolved device and
derives nothing again.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING, Any, Generic, TypeVar, overload

from mdl.diagnostics import Diagnostic, MdlError
from mdl.ir.build import build, build_shared
from mdl.ir.steps import Codec, DecodeStep, EncodeStep, Expression, Fragment
from mdl.model import Device, Function
from mdl.model.layout import Layout, layout
from mdl.model.names import camel, stem, unique_identifiers
from mdl.plan import Request, plan_groups
from mdl.records import record
from mdl.resolver.checks import check_device

if TYPE_CHECKING:
    from mdl.dsl.expr.fields import Compiled

T = TypeVar("T")


class cached_property(Generic[T]):  # noqa: N801 (it stands in for functools.cached_property)
    """functools.cached_property without the lock it takes on every first read before Python 3.12:
    worked out for every function of a large device, the lock cost more than the values. Like it,
    the value is kept in the instance's __dict__ (a frozen dataclass's too), where later reads find it."""

    def __init__(self, func: Callable[[Any], T]) -> None:
        self.func = func
        self.name = func.__name__
        self.__doc__ = func.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, instance: None, owner: type | None = None) -> cached_property[T]: ...

    @overload
    def __get__(self, instance: object, owner: type | None = None) -> T: ...

    def __get__(self, instance: object | None, owner: type | None = None) -> T | cached_property[T]:
        if instance is None:
            return self
        value = instance.__dict__[self.name] = self.func(instance)
        return value


@record
class ResolvedFunction:
    fn: Function
    ident: str  # its identifier in generated code (SPEC 3)
    layout: Layout
    codec: Codec
    compiled: Compiled | None = None  # its expression, compiled (None: it has none)

    @cached_property
    def name(self) -> str:
        return self.fn.name

    @cached_property
    def runs(self) -> tuple[tuple[int, int], ...]:
        """Its layout's runs (first address, count), worked out once."""
        return self.layout.runs

    @cached_property
    def deps(self) -> tuple[str, ...]:
        """The functions its decoder takes the values of, in parameter order: those its expression
        names, or the one whose value scales it (scale_exponent, scale_by)."""
        if self.compiled is not None:
            return tuple(self.compiled.deps)
        return (self.fn.factor,) if self.fn.factor is not None else ()

    @cached_property
    def decode_shape(self) -> str | None:
        """Its decode IR as text (`repr` tells 0.0 from -0.0 and 1 from 1.0): functions of the same
        shape decode alike whatever their names and addresses, so the targets print each shape once
        and the runtime compiles it once. None where it cannot be read, or where it has a fragment
        or an expression (their text need not show their compiled trees)."""
        return _shape(self.codec.decode)

    @cached_property
    def encode_shape(self) -> str | None:
        """Its encode IR as text, as `decode_shape`."""
        return _shape(self.codec.encode)


_NO_TEXT = "\0"  # not a shape's text (a repr has no NUL)


def _shape(steps: tuple[DecodeStep, ...] | tuple[EncodeStep, ...] | None) -> str | None:
    if steps is None:
        return None
    for s in steps:  # a plain loop: asked of every function's two programs
        if isinstance(s, (Fragment, Expression)):
            return None
    return repr(steps)


@record
class PlanGroup:
    """A request of the read plan, the smaller ones used when the device refuses it (exception 2),
    and where its registers go in a read_all buffer holding the whole plan's, group after group."""

    request: Request
    smaller: tuple[Request, ...]
    offset: int


@record
class ResolvedDevice:
    device: Device
    functions: tuple[ResolvedFunction, ...]
    warnings: tuple[Diagnostic, ...]

    @cached_property
    def by_name(self) -> dict[str, ResolvedFunction]:
        return {f.name: f for f in self.functions}

    @cached_property
    def layouts(self) -> dict[str, Layout]:
        """name -> layout of every function (an expression's too), as mdl.plan takes them."""
        return {f.name: f.layout for f in self.functions}

    @property
    def name(self) -> str:
        return self.device.name

    @cached_property
    def stem(self) -> str:
        return stem(self.device.name)

    @cached_property
    def class_name(self) -> str:
        return camel(self.stem)

    def closure(self, names: list[str]) -> list[ResolvedFunction]:
        """The named functions and those their expressions need, each after what it needs (that of
        one function worked out once: every target asks it of each function with dependencies)."""
        if len(names) == 1:
            found = self._closures.get(names[0])
            if found is None:
                found = self._closures[names[0]] = self._closure(names)
            return list(found)
        return self._closure(names)

    def _closure(self, names: list[str]) -> list[ResolvedFunction]:
        """Depth first over `deps` (resolve refused cycles), iteratively: chains may be long."""
        out: list[ResolvedFunction] = []
        seen: set[str] = set()
        by_name = self.by_name
        for name in names:
            if name in seen:
                continue
            seen.add(name)
            first = by_name[name]
            if not first.deps:  # most functions: nothing to put before it
                out.append(first)
                continue
            stack = [(first, 0)]
            while stack:
                f, i = stack.pop()
                if i < len(f.deps):
                    stack.append((f, i + 1))
                    dep = f.deps[i]
                    if dep not in seen:
                        seen.add(dep)
                        stack.append((by_name[dep], 0))
                else:
                    out.append(f)
        return out

    @cached_property
    def _closures(self) -> dict[str, list[ResolvedFunction]]:
        return {}

    @cached_property
    def readable(self) -> tuple[ResolvedFunction, ...]:
        """Every readable function, in decode order."""
        return tuple(self.closure([f.name for f in self.functions if f.fn.readable]))

    @cached_property
    def plan(self) -> tuple[PlanGroup, ...]:
        out = []
        offset = 0
        for req, parts in plan_groups(self.device, {f.name: f.layout for f in self.functions}):
            out.append(PlanGroup(req, tuple(parts) if parts != [req] else (), offset))
            offset += req.count
        return tuple(out)

    @cached_property
    def buffer_size(self) -> int:
        """The registers and bits of the whole read plan."""
        return sum(g.request.count for g in self.plan)

    @cached_property
    def slots(self) -> dict[tuple[str, int], int]:
        """(table, address) -> its position in the read plan's buffer."""
        return {(table, a): slot for table, slots in self.table_slots.items() for a, slot in slots.items()}

    @cached_property
    def table_slots(self) -> dict[str, dict[int, int]]:
        """table -> address -> its position in the read plan's buffer."""
        out: dict[str, dict[int, int]] = {}
        for g in self.plan:
            req = g.request
            out.setdefault(req.table, {}).update(
                zip(range(req.start, req.end), range(g.offset, g.offset + req.count), strict=True)
            )
        return out

    def slots_of(self, f: ResolvedFunction) -> tuple[int, ...]:
        """Where a readable function's registers are in the read plan's buffer, in address order
        (worked out once per function: every target asks)."""
        found = self._slots_of.get(f.name)
        if found is None:
            table = self.table_slots.get(f.layout.table, {})
            found = self._slots_of[f.name] = tuple(map(table.__getitem__, f.layout.addresses))
        return found

    @cached_property
    def _slots_of(self) -> dict[str, tuple[int, ...]]:
        return {}


def resolve(device: Device, path: str | None = None) -> ResolvedDevice:
    """The resolved device, or MdlError with every problem found, errors and warnings in file order
    (warnings are kept on the result when there is no error). The model is read, never written:
    what resolving derives (layouts, compiled expressions, the IR) lives on the result."""
    layouts: dict[str, Layout] = {}
    compiled: dict[str, Compiled] = {}
    found = check_device(device, path, layouts, compiled)
    if any(d.severity == "error" for d in found):
        raise MdlError(found)
    names = [fn.name for fn in device.functions]
    functions = []
    built: dict[Hashable, Codec] = {}  # build_shared's codecs, one per shape
    texts: dict[int, str | None] = {}  # id of a function's steps -> _shape of them
    for fn, ident in zip(device.functions, unique_identifiers(names), strict=True):
        expression = compiled.get(fn.name)
        lay = layouts[fn.name] if fn.name in layouts else layout(fn, expression)  # an expression's: its registers
        codec = build(fn, lay, expression) if expression is not None else build_shared(fn, lay, built)
        rf = ResolvedFunction(fn, ident, lay, codec, expression)
        # functions of one shape share their steps (build_shared): each shape's text is made once, and
        # put where the cached properties keep it (the steps live as long as the functions: ids hold)
        for attr, steps in (("decode_shape", codec.decode), ("encode_shape", codec.encode)):
            text = texts.get(id(steps), _NO_TEXT)
            if text is _NO_TEXT:
                text = texts[id(steps)] = _shape(steps)
            rf.__dict__[attr] = text
        functions.append(rf)
    warnings = [*device.notes, *(d for d in found if d.severity != "error")]
    return ResolvedDevice(device, tuple(functions), tuple(warnings))
