"""mdl: Modbus register tables -> MDL XML -> drivers for C++ (libmodbus) and Python (pymodbus).

`import mdl` is the library (SPEC section 16, docs/api.md): load, validate, resolve, generate, export,
Session, Diagnostic and MdlError, defined in mdl.api and imported from it on first use, so that
`import mdl` (and every `mdl` command) loads nothing it does not use."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"
__all__ = ["Diagnostic", "MdlError", "Session", "export", "generate", "load", "resolve", "validate"]

if TYPE_CHECKING:
    from mdl.api import Diagnostic, MdlError, Session, export, generate, load, resolve, validate


def __getattr__(name: str) -> Any:
    if name in __all__:
        from mdl import api

        value = getattr(api, name)
        globals()[name] = value  # from now on an attribute like any other
        return value
    raise AttributeError(f"module 'mdl' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*__all__, "__version__"])
