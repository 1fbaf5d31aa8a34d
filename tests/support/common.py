"""Where things are (the checkout, tests/data, the conformance data), CI's rule for a missing tool, and
small builders of MDL text."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent.parent
ROOT = TESTS.parent


def _conformance_root() -> Path:
    """Conformance data from elsewhere: $MDL_CONFORMANCE_DIR, else ../shared/conformance beside the checkout."""
    configured = os.environ.get("MDL_CONFORMANCE_DIR")
    return Path(configured).resolve() if configured else ROOT.parent / "shared" / "conformance"


CONFORMANCE = _conformance_root()
ORNL = CONFORMANCE / "ornl"
REFERENCE = CONFORMANCE / "modbus-schema-reference"
EXAMPLE = ROOT / "examples" / "temco_tstat"
DATA = TESTS / "data"
GOLDEN = TESTS / "golden"
CPP = TESTS / "cpp"

MDL_NS = "http://www.ornl.gov/ModbusXMLSchema"


def in_ci() -> bool:
    return os.environ.get("CI") == "true"


def skip_or_fail(reason: str) -> None:
    """A missing optional tool or data set skips its test with the reason; under CI=true it is a failure."""
    if in_ci():
        pytest.fail(f"{reason} (required when CI=true)", pytrace=False)
    pytest.skip(reason)


def device_xml(functions: str, name: str = "Test Device", version: str | None = "1.0") -> str:
    attr = f' version="{version}"' if version else ""
    return (
        f'<?xml version="1.0" encoding="US-ASCII"?>\n<device xmlns="{MDL_NS}"{attr}>\n'
        f"  <name>{name}</name>\n  <description>test</description>\n{functions}</device>\n"
    )


def fn_xml(name: str, addresses, **fields) -> str:
    """A <function> with the given fields in schema order."""
    from mdl.model import EXTENSION_FIELDS  # the 1.0 elements, in schema order, as the writer uses them

    order = (
        *("length", "count", "format", "block_label", "multiplier", "units"),
        *("read_function_code", "write_function_code"),
        *EXTENSION_FIELDS,
    )
    body = f"    <name>{name}</name>\n    <description>{name}</description>\n    <addresses>{addresses}</addresses>\n"
    for key in order:
        if key in fields:
            value = fields[key]
            if key == "values":
                inner = "".join(f'<value key="{k}">{v}</value>' for k, v in value.items())
                body += f"    <values>{inner}</values>\n"
            else:
                body += f"    <{key}>{value}</{key}>\n"
    return f"  <function>\n{body}  </function>\n"


def import_generated(path: Path, module_name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(module_name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
