"""Identifiers (SPEC section 3): the same under every Python, never a keyword of a target language,
never a name the generated files use themselves."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from mdl.model.names import camel, identifier, stem, unique_identifiers
from support.common import ROOT, fn_xml, import_generated
from support.cpp_harness import STRICT, toolchain
from support.run import run_mdl

# name -> identifier; each of these once depended on the Python running mdl, or gave code that does not compile
EXPECTED = {
    "type": "type_",
    "match": "match_",
    "case": "case_",
    "class": "class_",
    "int": "int_",
    "and": "and_",
    "register": "register_",
    "restrict": "restrict_",
    "_Bool": "bool_",
    "int32_t": "int32_t_",
    "uint8_t": "uint8_t_",
    "size_t": "size_t_",
    "nullptr": "nullptr_",
    "NULL": "null",
    "true": "true_",
    "errno": "errno_",
    "all": "all_",
    "modbus": "modbus_",
    "typing": "typing_",
    "async": "async_",
    "xor_eq": "xor_eq_",
    "Type Of Unit": "type_of_unit",
    "2nd value": "f_2nd_value",
    "": "unnamed",
}
OTHER_PYTHONS = [
    p
    for p in (Path(sys.base_prefix).parent / v / "bin" / "python3" for v in ("3.10.13", "3.12.1", "3.13.0"))
    if p.exists()
]


def test_reserved_words_get_an_underscore():
    assert {name: identifier(name) for name in EXPECTED} == EXPECTED


@pytest.mark.skipif(not OTHER_PYTHONS, reason="no other Python interpreter installed beside this one")
@pytest.mark.parametrize("python", OTHER_PYTHONS, ids=lambda p: p.parent.parent.name)
def test_identifiers_do_not_depend_on_the_python_running_mdl(python):
    code = (
        "import json, sys; from mdl.model.names import identifier; "
        "print(json.dumps([identifier(n) for n in sys.argv[1:]]))"
    )
    proc = subprocess.run(
        [str(python), "-c", code, *EXPECTED],
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(ROOT / "src")},
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == list(EXPECTED.values())


def test_repeats_are_numbered_without_a_double_underscore():
    assert unique_identifiers(["type", "Type", "type 2", "room temp", "room_temp"]) == [
        "type_",
        "type_2",
        "type_2_2",
        "room_temp",
        "room_temp_2",
    ]


@pytest.mark.parametrize(
    "device, cls",
    [
        ("None", "None_"),
        ("true", "True_"),
        ("Request", "Request_"),
        ("group", "Group_"),
        ("TABLE", "Table_"),
        ("Device Error", "DeviceError_"),
        ("value error", "ValueError_"),
        ("Exception", "Exception_"),
        ("Typed Dict", "TypedDict_"),
        ("Temco Tstat8", "TemcoTstat8"),
        ("class", "Class"),
        ("3 phase meter", "F3PhaseMeter"),
    ],
)
def test_class_names_avoid_the_generated_files_own_names(device, cls):
    assert camel(identifier(device)) == cls


HOSTILE_FUNCTIONS = [
    "type",
    "match",
    "class",
    "int",
    "and",
    "register",
    "restrict",
    "_Bool",
    "int32_t",
    "uint16_t",
    "errno",
    "all",
    "true",
    "None",
    "type ",
]


@pytest.mark.compile
@pytest.mark.parametrize(
    "device, cls",
    [
        ("None", "None_"),
        ("Table", "Table_"),
        ("Request", "Request_"),
        ("Group", "Group_"),
        ("Device Error", "DeviceError_"),
    ],
)
def test_generated_drivers_with_hostile_names_import_and_compile(tmp_path, write_device, device, cls):
    functions = "".join(fn_xml(name, str(i), format="UINT16") for i, name in enumerate(HOSTILE_FUNCTIONS))
    path = write_device(functions, name=device)
    proc = run_mdl("gen", path, "-o", tmp_path)
    assert proc.returncode == 0, proc.stderr
    stem = identifier(device)
    module = import_generated(tmp_path / f"{stem}.py", f"hostile_{stem}")
    driver = getattr(module, cls)
    assert issubclass(module.CommunicationError, module.DeviceError)
    assert issubclass(module.ValueRangeError, ValueError)
    idents = unique_identifiers(HOSTILE_FUNCTIONS)
    assert all(hasattr(driver, f"read_{i}") for i in idents) and hasattr(driver, "read_all")
    assert "type_2" in idents
    gxx, cflags, _ = toolchain()
    proc = subprocess.run(
        [gxx, *STRICT, *cflags, "-fsyntax-only", str(tmp_path / f"{stem}.cc")], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr


def test_a_device_named_like_a_standard_header_gets_an_underscore_in_its_stem():
    assert {
        name: stem(name)
        for name in ("String", "Time", "vector", "cstdint", "String View", "Math", "errno", "Strings", "Temco Tstat8")
    } == {
        "String": "string_",
        "Time": "time_",
        "vector": "vector_",
        "cstdint": "cstdint_",
        "String View": "string_view_",
        "Math": "math_",
        "errno": "errno_",
        "Strings": "strings",
        "Temco Tstat8": "temco_tstat8",
    }
    assert identifier("time") == "time"  # a function's identifier is not a file name


HEADER_DEVICES = {"String": "string_", "Stdint": "stdint_", "Time": "time_", "Math": "math_", "Vector": "vector_"}


@pytest.mark.compile  # builds generated C++/C: heavier than its folder
def test_drivers_of_devices_named_like_headers_compile_beside_each_other(tmp_path, write_device):
    """With the output directory on the include path, no generated header stands in for a standard one."""
    out = tmp_path / "out"
    for device, expected_stem in HEADER_DEVICES.items():
        path = write_device(fn_xml("time", "0", format="UINT16"), name=device, filename=f"{expected_stem}.xml")
        proc = run_mdl("gen", path, "-o", out)
        assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(
        f"{s}.{ext}" for s in HEADER_DEVICES.values() for ext in ("py", "h", "cc", "c")
    )
    gxx, cflags, _ = toolchain()
    for expected_stem in HEADER_DEVICES.values():
        module = import_generated(out / f"{expected_stem}.py", f"header_{expected_stem}")
        assert hasattr(getattr(module, camel(expected_stem)), "read_time")
        proc = subprocess.run(
            [gxx, *STRICT, f"-I{out}", *cflags, "-fsyntax-only", str(out / f"{expected_stem}.cc")],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 0, proc.stderr
        proc = subprocess.run(
            [
                "gcc",
                "-std=c99",
                "-Wall",
                "-Wextra",
                "-Wpedantic",
                "-Werror",
                f"-I{out}",
                *cflags,
                "-fsyntax-only",
                str(out / f"{expected_stem}.c"),
            ],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 0, proc.stderr
