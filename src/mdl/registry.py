"""The one shape of mdl's registries: the formats (mdl.formats.FORMATS), the targets
(mdl.targets.TARGETS) and the exports (mdl.exports.ENGINES). Each is a Registry of entries with a
`name` and a `summary`, kept in the order the commands list them; what an entry calls is imported
when first called (`lazy`), so that reading a registry (every `mdl --help`) imports nothing."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from typing import Any, Protocol, TypeVar


class Entry(Protocol):
    @property
    def name(self) -> str: ...

    @property
    def summary(self) -> str: ...


E = TypeVar("E", bound=Entry)


class Registry(Mapping[str, E]):
    """Entries by name (a read-only mapping, iterated in their order); a name given twice is a mistake of
    mdl's own (ValueError)."""

    def __init__(self, *entries: E) -> None:
        self._entries = {entry.name: entry for entry in entries}
        if len(self._entries) != len(entries):
            raise ValueError(f"a name registered twice among {[entry.name for entry in entries]}")

    def __getitem__(self, name: str) -> E:
        """The entry called `name`; KeyError for a name not registered."""
        return self._entries[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def names(self) -> list[str]:
        return list(self._entries)

    def summaries(self) -> list[str]:
        """`name: summary` of each entry, as `--help` lists them."""
        return [f"{entry.name}: {entry.summary}" for entry in self.values()]

    def __add__(self, other: Registry[E]) -> Registry[E]:
        return Registry(*self.values(), *other.values())


def lazy(module: str, name: str) -> Callable[..., Any]:
    """The function `name` of `module`, imported when it is first called."""

    def call(*args: Any, **kwargs: Any) -> Any:
        return getattr(importlib.import_module(module), name)(*args, **kwargs)

    call.__qualname__ = call.__name__ = f"{module}.{name}"
    return call
