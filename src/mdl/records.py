"""Frozen records: the value classes mdl makes by the dozen (IR steps, plans, layouts, tokens), as
`@dataclass(frozen=True)` makes them, without its cost at import.

Python 3.10 and 3.11 compile six methods from source for each frozen dataclass as its class is made
(__init__, __repr__, __eq__, __hash__, __setattr__, __delattr__): some 3 M instructions a class, and a
one-shot `mdl read` made some 50 of them before it read a register, most of the instructions it spent past
its libraries' imports (docs/performance.md). `record` compiles nothing per class: its `__init__` (as fast
as the dataclass's) is the code of every record of as many fields, compiled once, with the class's names put
in; the rest are the same functions on every record: equality and hash over its fields as a tuple (only
with a record of the same class), the same repr text (`Mask(bits=16)`), fields that cannot be assigned or
deleted (dataclasses.FrozenInstanceError), `__match_args__`, and `__record_fields__` (the field names, in
order).

A record is a class of fields and their defaults, nothing more: no `field(...)`, no `__post_init__`, no
mutable default, no fields inherited from another record (a plain subclass adding methods is fine), no
methods of its own among those above, no field named `self`, `_values` or `_shown`; `record` refuses the
rest with a TypeError as the class is made. It is no dataclass: `dataclasses.fields()`, `replace()` and
`asdict()` refuse it (`replace` below is its own), so the types the library's users build and change
themselves (mdl.Diagnostic, the document model) stay dataclasses. Type checkers see a frozen dataclass
(`dataclass_transform`).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from dataclasses import Field, FrozenInstanceError
from operator import attrgetter
from types import CodeType, FunctionType
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from typing_extensions import dataclass_transform
else:

    def dataclass_transform(**_: Any) -> Callable[[Any], Any]:
        return lambda decorated: decorated


C = TypeVar("C", bound=type)

_MUTABLE = (list, dict, set, bytearray)
_RESERVED = ("self", "_values", "_shown", "__record_fields__", "__match_args__")  # names a field cannot have


class Record:
    """The methods every record has (`record` puts these functions on each: no record is a Record), over
    `_values(record)` and `_shown`, which `record` sets per class."""

    __record_fields__: tuple[str, ...] = ()
    _values: Callable[[Any], Any]

    _shown: str  # the repr's format: "{}(a={!r}, b={!r})", the class's __qualname__ first

    def __eq__(self, other: object) -> bool:
        if other.__class__ is self.__class__:
            values = self._values
            return values(self) == values(other)  # type: ignore[no-any-return]
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self._values(self))

    def __repr__(self) -> str:
        return self._shown.format(type(self).__qualname__, *self._values(self))

    def __setattr__(self, name: str, value: Any) -> None:
        raise FrozenInstanceError(f"cannot assign to field {name!r}")

    def __delattr__(self, name: str) -> None:
        raise FrozenInstanceError(f"cannot delete field {name!r}")


def _names(cls: type) -> tuple[list[str], dict[str, Any]]:
    """The class's fields in order, and the defaults of those that have one."""
    names: list[str] = []
    defaults: dict[str, Any] = {}
    for name, note in inspect.get_annotations(cls).items():  # its own, as written
        if name in _RESERVED:
            raise TypeError(f"{cls.__qualname__}.{name}: a record's own attribute, not a field's name")
        text = note if isinstance(note, str) else getattr(note, "__name__", "")
        if text.startswith(("ClassVar", "typing.ClassVar", "InitVar", "dataclasses.InitVar")):
            raise TypeError(f"{cls.__qualname__}.{name}: a record has no ClassVar or InitVar fields")
        names.append(name)
        if name in cls.__dict__:
            default = cls.__dict__[name]
            if isinstance(default, (Field, *_MUTABLE)):
                raise TypeError(f"{cls.__qualname__}.{name}: a record's default is a plain immutable value")
            defaults[name] = default
        elif defaults:
            raise TypeError(f"{cls.__qualname__}.{name}: a field without a default follows one with a default")
    return names, defaults


@functools.cache
def _init_code(count: int) -> CodeType:
    """The code of an __init__ of `count` fields, compiled once for every record of as many: it sets each
    field as a frozen dataclass's __init__ does. Its parameters `_p0`... and the field names it sets, the
    constants `"_n0"`..., stand for the names `_init` puts in their place."""
    params = "".join(f", _p{i}" for i in range(count))
    body = "".join(f"\n    _set(self, '_n{i}', _p{i})" for i in range(count)) or "\n    pass"
    scope: dict[str, Any] = {}
    exec(f"def __init__(self{params}) -> None:{body}", scope)  # noqa: S102
    code: CodeType = scope["__init__"].__code__
    return code


def _init(cls: type, names: list[str], defaults: dict[str, Any]) -> Callable[..., None]:
    """`__init__(self, <fields>)` of the class: _init_code's, its parameters and constants named."""
    code = _init_code(len(names))
    placed = {f"_n{i}": name for i, name in enumerate(names)}
    consts = tuple(placed.get(c, c) if isinstance(c, str) else c for c in code.co_consts)
    code = code.replace(co_varnames=("self", *names, *code.co_varnames[len(names) + 1 :]), co_consts=consts)
    given = tuple(defaults[name] for name in names if name in defaults) or None
    init = FunctionType(code, {"_set": object.__setattr__}, "__init__", given)
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__module__ = cls.__module__
    return init


def _values(names: list[str]) -> Callable[[Any], Any]:
    """The fields' values of a record as one object to compare, hash and show: a C callable, which the
    class holds as it is (no method binding). Several fields: their tuple. One field: it twice (an
    attrgetter of one name gives the bare value, which a tuple-valued field would spread over the repr's
    format; the format uses the first). No field: its class's empty tuple of field names."""
    if not names:
        return attrgetter("__record_fields__")
    return attrgetter(*names) if len(names) >= 2 else attrgetter(names[0], names[0])


# the methods every record has, Record's own functions
_SHARED = ("__eq__", "__hash__", "__repr__", "__setattr__", "__delattr__")


@dataclass_transform(eq_default=True, frozen_default=True)
def record(cls: C) -> C:
    """`cls` made a record, in place: its __init__, Record's methods, its field names."""
    if any("__record_fields__" in base.__dict__ for base in cls.__mro__[1:]) or "__post_init__" in cls.__dict__:
        raise TypeError(f"{cls.__qualname__}: a record inherits no fields and has no __post_init__")
    if mine := [name for name in ("__init__", *_SHARED) if name in cls.__dict__]:
        raise TypeError(f"{cls.__qualname__}: a record's {', '.join(mine)} are its own")
    names, defaults = _names(cls)
    made: dict[str, Any] = {name: Record.__dict__[name] for name in _SHARED}
    made.update(
        __init__=_init(cls, names, defaults),
        __match_args__=tuple(names),
        __record_fields__=tuple(names),
        _values=_values(names),
        _shown="{}(" + ", ".join(f"{n}={{!r}}" for n in names) + ")",
    )
    for name, value in made.items():
        setattr(cls, name, value)
    return cls


R = TypeVar("R")


def replace(made: R, **changes: Any) -> R:
    """A new record of `made`'s class, of its fields with `changes` (as `dataclasses.replace`)."""
    fields = {name: getattr(made, name) for name in made.__record_fields__}  # type: ignore[attr-defined]
    return type(made)(**{**fields, **changes})
