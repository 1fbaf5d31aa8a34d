"""`mdl gen --lang all`: one <stem>.h serves the C++ driver (<stem>.cc) and the C driver (<stem>.c)
(mdl.targets.shared_header, docs/c-api.md "One header for C and C++"). Both drivers compile with the
strict flags their documents promise (g++ and clang++ -std=c++17, gcc and clang -std=c99) against the
same header, and a small C program and a small C++ program, each linked with its driver, read
`mdl sim` through it. Hostile text (comment ends, trigraphs, quotes, `#define`, control characters,
non-ASCII) stays inside comments and string literals in the merged header seen from either language.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
from pathlib import Path

import pytest

from mdl.formats.mdl import load_device
from mdl.resolver import resolve
from mdl.targets import render
from support.c_harness import STRICT as C_STRICT
from support.c_harness import compile_driver as compile_c
from support.c_harness import tool
from support.common import DATA, EXAMPLE, fn_xml
from support.cpp_harness import STRICT as CXX_STRICT
from support.cpp_harness import compile_driver as compile_cxx
from support.cpp_harness import modbus_flags
from support.run import cli

TSTAT = EXAMPLE / "temco_tstat.xml"
ALL = DATA / "all_tables.xml"
# source, a readable double the programs print, the simulator's --set for it
SOURCES = [(TSTAT, "room_temperature", "21.5"), (ALL, "setpoint", "21.5")]


def generate_all(source: Path, out: Path) -> tuple[Path, Path, Path]:
    """`mdl gen --lang all` into out: (<stem>.h, <stem>.c, <stem>.cc)."""
    proc = cli("gen", source, "--lang", "all", "-o", out)
    assert proc.returncode == 0, proc.stderr
    header = next(out.glob("*.h"))
    c_file, cc = header.with_suffix(".c"), header.with_suffix(".cc")
    assert c_file.exists() and cc.exists() and header.with_suffix(".py").exists()
    assert len(list(out.glob("*.h"))) == 1
    return header, c_file, cc


C_PROGRAM = """#include "{stem}.h"

#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv) {{
    static struct {stem}_values v;
    modbus_t *ctx;
    int rc;
    if (argc != 2) return 2;
    ctx = modbus_new_tcp("127.0.0.1", atoi(argv[1]));
    if (ctx == NULL || modbus_connect(ctx) == -1) return 3;
    modbus_set_slave(ctx, 1);
    rc = {stem}_read_all(ctx, &v);
    printf("c %d %.17g %s\\n", rc, (double)v.{name}, {macro});
    modbus_close(ctx);
    modbus_free(ctx);
    return rc == 0 ? 0 : 1;
}}
"""

CXX_PROGRAM = """#include "{stem}.h"

#include <cstdio>
#include <cstdlib>

int main(int argc, char **argv) {{
    if (argc != 2) return 2;
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", std::atoi(argv[1]));
    if (ctx == nullptr || modbus_connect(ctx) == -1) return 3;
    modbus_set_slave(ctx, 1);
    {cls} dev(ctx);
    {cls}Values v;
    const int rc = dev.read_all(&v);
    std::printf("c++ %d %.17g %s\\n", rc, static_cast<double>(v.{name}), {cls}::kDeviceName);
    modbus_close(ctx);
    modbus_free(ctx);
    return rc == 0 ? 0 : 1;
}}
"""


def link(compiler: str, strict: list[str], program: Path, driver_obj: Path, exe: Path) -> Path:
    cflags, libs = modbus_flags()
    proc = subprocess.run(
        [
            tool(compiler),
            *strict,
            "-O0",
            *cflags,
            f"-I{program.parent}",
            "-o",
            str(exe),
            str(program),
            str(driver_obj),
            *libs,
            "-lm",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, f"{compiler} {program.name}:\n{proc.stderr}"
    return exe


@pytest.mark.parametrize("source, name, value", SOURCES, ids=lambda x: x.name if isinstance(x, Path) else "")
def test_lang_all_compiles_both_drivers_against_one_header(source, name, value, tmp_path, sim_factory):
    header, c_file, cc = generate_all(source, tmp_path)
    text = header.read_text(encoding="utf-8")
    assert "#ifdef __cplusplus" in text and "\n#else\n" in text  # the merged header, not one driver's
    objects = {compiler: compile_c(c_file, compiler) for compiler in ("gcc", "clang")}
    objects |= {compiler: compile_cxx(cc, compiler) for compiler in ("g++", "clang++")}
    stem = header.stem
    rd = resolve(load_device(source))
    (tmp_path / "user.c").write_text(C_PROGRAM.format(stem=stem, name=name, macro=f"{stem.upper()}_DEVICE_NAME"))
    (tmp_path / "user.cc").write_text(CXX_PROGRAM.format(stem=stem, name=name, cls=rd.class_name))
    programs = [
        link(compiler, C_STRICT, tmp_path / "user.c", objects[compiler], tmp_path / f"user_{compiler}")
        for compiler in ("gcc", "clang")
    ]
    programs += [
        link(compiler, CXX_STRICT, tmp_path / "user.cc", objects[compiler], tmp_path / f"user_{compiler}")
        for compiler in ("g++", "clang++")
    ]
    sim = sim_factory(source, "--set", f"{name}={value}")
    for exe in programs:
        run = subprocess.run([str(exe), str(sim.port)], capture_output=True, text=True, timeout=30)
        assert run.returncode == 0, (exe.name, run.stdout, run.stderr)
        lang = "c++" if exe.name.endswith("++") else "c"
        assert run.stdout == f"{lang} 0 {value} {rd.device.name}\n", exe.name


def test_the_c_program_sees_no_cxx_and_the_cxx_program_no_c(tmp_path):
    """The control: each language gets only its own declarations from the merged header."""
    header, _, _ = generate_all(ALL, tmp_path)
    cflags, _ = modbus_flags()
    (tmp_path / "c_uses_class.c").write_text('#include "all_tables.h"\nAllTables *p;\n')
    (tmp_path / "cxx_uses_c.cc").write_text(
        '#include "all_tables.h"\nvoid f() { all_tables_init(nullptr, nullptr); }\n'
    )
    for compiler, strict, program in (("gcc", C_STRICT, "c_uses_class.c"), ("g++", CXX_STRICT, "cxx_uses_c.cc")):
        proc = subprocess.run(
            [tool(compiler), *strict, "-fsyntax-only", *cflags, f"-I{header.parent}", str(tmp_path / program)],
            capture_output=True,
            text=True,
        )
        assert proc.returncode != 0, (compiler, program)


NASTY = 'x */ int evil_symbol; /* \\ " ??/ &#10;#define evil_macro 1&#10;// next &#9;\\'
# characters XML cannot carry, set on the loaded model: NUL and other controls, C1, line separators
CONTROL = "a\x00b\x01c\x1b[0m\x7f\x85\u2028\u2029 \u00e9\u4e2d\U0001f600 */ ??/\\"


def hostile_device(write_device, control: bool):
    path = write_device(
        fn_xml("t", "1", format="UINT16", units=NASTY).replace(
            "<description>t</description>", f"<description>{NASTY}</description>"
        )
        + fn_xml("splice ??/", "2", format="UINT16")
        + fn_xml("splice \\", "3", format="UINT16")
        + fn_xml("#define evil_name", "4", format="STRING", count="2"),
        name=f"Dev {NASTY} &#176;",
    )
    device = load_device(path)
    if control:
        functions = [
            dataclasses.replace(f, description=f.description + CONTROL, units=(f.units or "") + CONTROL)
            for f in device.functions
        ]
        device = dataclasses.replace(device, name=device.name + CONTROL, description=CONTROL, functions=functions)
    return device


NAME_PROGRAM_C = """#include "{stem}.h"

#include <stdio.h>

int main(void) {{
    size_t i;
    for (i = 0; i + 1 < sizeof {macro}; ++i) printf("%02x", (unsigned)(unsigned char){macro}[i]);
    printf("\\n");
    return 0;
}}
"""

NAME_PROGRAM_CXX = """#include "{stem}.h"

#include <cstdio>

int main() {{
    for (const char *p = {cls}::kDeviceName; *p != '\\0'; ++p) std::printf("%02x", static_cast<unsigned>(
        static_cast<unsigned char>(*p)));
    std::printf("\\n");
    return 0;
}}
"""


@pytest.mark.parametrize("control", [False, True], ids=["xml", "control_characters"])
def test_hostile_text_in_the_merged_header_compiles_as_c_and_cxx(control, tmp_path, write_device):
    device = hostile_device(write_device, control)
    rd = resolve(device)
    out = tmp_path / "out"
    out.mkdir()
    for file_name, text in render(device, "dev */ ??/.xml", "all").items():
        (out / file_name).write_text(text, encoding="utf-8")
    header = out / f"{rd.stem}.h"
    for path in (header, header.with_suffix(".c"), header.with_suffix(".cc")):
        text = path.read_text(encoding="utf-8")
        assert not any(ch in text for ch in "\x00\x01\x1b\x7f\x85\u2028\u2029\r\t"), path.name
        assert not re.search(r"^[ \t]*#[ \t]*define[ \t]+evil", text, re.M), path.name
        assert not [line for line in text.splitlines() if line.rstrip().endswith(("\\", "??/"))]
    objects = {c: compile_c(header.with_suffix(".c"), c) for c in ("gcc", "clang")}
    objects |= {c: compile_cxx(header.with_suffix(".cc"), c) for c in ("g++", "clang++")}
    for compiler, obj in objects.items():
        nm = subprocess.run(["nm", str(obj)], capture_output=True, text=True).stdout
        symbols = {line.split()[-1] for line in nm.splitlines() if line.strip()}
        assert symbols and not symbols & {"evil_symbol", "_Z11evil_symbol", "evil_macro"}, compiler
    (out / "name.c").write_text(NAME_PROGRAM_C.format(stem=rd.stem, macro=f"{rd.stem.upper()}_DEVICE_NAME"))
    (out / "name.cc").write_text(NAME_PROGRAM_CXX.format(stem=rd.stem, cls=rd.class_name))
    # the name's bytes, whole in the C string literal (sizeof), up to its first NUL through a const char *
    name = device.name.encode("utf-8")
    for compiler, strict, program, want in (
        ("gcc", C_STRICT, "name.c", name),
        ("clang", C_STRICT, "name.c", name),
        ("g++", CXX_STRICT, "name.cc", name.split(b"\0")[0]),
        ("clang++", CXX_STRICT, "name.cc", name.split(b"\0")[0]),
    ):
        exe = link(compiler, [*strict, "-trigraphs"], out / program, objects[compiler], out / f"name_{compiler}")
        run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=30)
        assert run.returncode == 0 and run.stdout == want.hex() + "\n", (compiler, run.stdout, want)
