"""Build generated C99 drivers with a test program that speaks cpp_harness's line protocol on stdin
(`all`, `read NAME`, `write NAME VALUE`, `connect`; see cpp_harness), so `cpp_harness.Harness` runs it.

Every driver is compiled with STRICT (the flags docs/c-api.md promises) by gcc and by clang, once per
compiler and content in a session; `build_sanitized` builds it and the program with ASan and UBSan.
tests/support/drivers.py's `Native` puts this and support/cpp_harness.py behind one interface.

A read's value holds a poison value before the call (a text: as much of "poison" as its array holds), and a
read that fails but leaves anything else there aborts the program. A single read that finds the value null
(-1 with ENODATA, docs/c-api.md) prints `NAME null`.
"""

from __future__ import annotations

import atexit
import hashlib
import shutil
import subprocess
import tempfile
from pathlib import Path

from mdl.model import Device
from mdl.resolver import resolve
from mdl.targets import render
from mdl.targets.c import emit as cgen
from mdl.targets.templating import cstring
from support.common import skip_or_fail
from support.cpp_harness import modbus_flags
from support.tiers import require_tier

STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Wshadow", "-Werror"]
COMPILERS = ("gcc", "clang")


def tool(name: str) -> str:
    require_tier("compile", f"the C compiler {name}")
    found = shutil.which(name) or shutil.which(f"{name}-14")
    if found is None:
        skip_or_fail(f"C driver tests: {name} is not installed")
    assert found is not None
    return found


_objects: dict[str, Path] = {}
_object_dir: list[Path] = []


def _cache_dir() -> Path:
    if not _object_dir:
        _object_dir.append(Path(tempfile.mkdtemp(prefix="mdl-c-objects-")))
        atexit.register(shutil.rmtree, _object_dir[0], True)
    return _object_dir[0]


def compile_driver(c_file: Path, compiler: str, flags: tuple[str, ...] = ()) -> Path:
    """The object of a generated driver (the .c and the .h beside it), compiled with STRICT -O0 (and
    flags) by `compiler`, once per session for each content."""
    path = tool(compiler)
    cflags, _ = modbus_flags()
    header = c_file.with_suffix(".h")
    key = hashlib.sha256(
        b"\0".join(
            [
                compiler.encode(),
                *(f.encode() for f in flags),
                header.name.encode(),
                header.read_bytes(),
                c_file.read_bytes(),
            ]
        )
    ).hexdigest()
    if key not in _objects:
        obj = _cache_dir() / f"{key}.o"
        proc = subprocess.run(
            [path, *STRICT, "-O0", *flags, *cflags, "-c", str(c_file), "-o", str(obj)], capture_output=True, text=True
        )
        assert proc.returncode == 0, f"{compiler} {c_file.name}:\n{proc.stderr}"
        _objects[key] = obj
    return _objects[key]


_PRINT = r"""
static void put_null(const char *n) { printf("%s null\n", n); }
static void put_i(const char *n, long long v) { printf("%s i:%lld\n", n, v); }
static void put_u(const char *n, unsigned long long v) { printf("%s i:%llu\n", n, v); }
static void put_f(const char *n, double v) { printf("%s f:%.17g\n", n, v); }
static void put_b(const char *n, bool v) { printf("%s b:%d\n", n, v ? 1 : 0); }
static void put_s(const char *n, const char *v) {
    printf("%s s:", n);
    for (; *v; ++v) printf("%02x", (unsigned char)*v);
    printf("\n");
}
static void put_hex(const char *v) {
    for (; *v; ++v) printf("%02x", (unsigned char)*v);
}
static void error_(int e) { printf("error %d %s\n", e, modbus_strerror(e)); }
static void unhex(const char *h, char *out, size_t size) {
    size_t i = 0;
    unsigned c = 0;
    while (h[0] && h[1] && i + 1 < size && sscanf(h, "%2x", &c) == 1) {
        out[i++] = (char)c;
        h += 2;
    }
    out[i] = '\0';
}
/* "poison", cut to fit a text array of `size` bytes (NUL included) */
static void poison_s(char *v, size_t size) {
    const size_t n = size - 1 < 6 ? size - 1 : 6;
    memcpy(v, "poison", n);
    v[n] = '\0';
}
static int still_poison_s(const char *v, size_t size) {
    const size_t n = size - 1 < 6 ? size - 1 : 6;
    return strlen(v) == n && strncmp(v, "poison", n) == 0;
}
static void poison_fail(const char *n) {
    fprintf(stderr, "a failed read stored a value in %s\n", n);
    abort();
}
"""


def _put(f: cgen.CFunction, value: str, has: str | None) -> str:
    name = cstring(f.fn.name)
    if f.t == "char":
        put = f"put_s({name}, {value});"
    elif f.t.startswith("struct"):
        put = (
            f'{{ size_t k; printf("%s l:", {name}); for (k = 0; k < ({value}).count; ++k) {{ '
            f'if (k) printf(","); put_hex(({value}).items[k]); }} printf("\\n"); }}'
        )
    elif f.t == "bool":
        put = f"put_b({name}, {value});"
    elif f.t in ("float", "double"):
        put = f"put_f({name}, (double)({value}));"
    elif f.t.startswith("u"):
        put = f"put_u({name}, (unsigned long long)({value}));"
    else:
        put = f"put_i({name}, (long long)({value}));"
    return f"if (!({has})) put_null({name}); else {put}" if has else put


def _poison(f: cgen.CFunction, value: str) -> str:
    if f.t == "char":  # within its array, however short
        return f"poison_s({value}, sizeof({value}));"
    if f.t.startswith("struct"):
        return f'({value}).count = 1; ({value}).items[0] = "poison";'
    return f"{value} = ({f.t})77;" if f.t != "bool" else f"{value} = true;"


def _still_poison(f: cgen.CFunction, value: str) -> str:
    if f.t == "char":
        test = f"still_poison_s({value}, sizeof({value}))"
    elif f.t.startswith("struct"):
        test = f'({value}).count == 1 && strcmp(({value}).items[0], "poison") == 0'
    else:
        test = f"{value} == ({f.t})77" if f.t != "bool" else f"{value}"
    return f"if (!({test})) poison_fail({cstring(f.fn.name)});"


def _parse(f: cgen.CFunction) -> str:
    t = f.wt
    if t == "char":
        return "buf"
    if t == "bool":
        return 'strcmp(text, "1") == 0'
    if t == "double":
        return "strtod(text, NULL)"
    if t == "float":
        return "strtof(text, NULL)"
    return f"({t})strto{'ull' if t.startswith('u') else 'll'}(text, NULL, 10)"


def harness_source(device: Device, stem: str) -> str:
    ctx = cgen.context(resolve(device), "harness")
    fns: list[cgen.CFunction] = ctx["functions"]
    reads = [f for f in fns if f.decode is not None]
    poison_all = "".join(f"        {_poison(f, 'v.' + f.ident)}\n" for f in reads)
    check_all = "".join(f"                {_still_poison(f, 'v.' + f.ident)}\n" for f in reads)
    put_all = "".join(
        f"                {_put(f, 'v.' + f.ident, ('v.has_' + f.ident) if f.nullable else None)}\n" for f in reads
    )
    read_cases = []
    for f in reads:
        decl = f"char x[{f.text_size}];" if f.is_text else f"{f.t} x;"
        arg = "x" if f.is_text else "&x"
        read_cases.append(
            f"        if (strcmp(name, {cstring(f.fn.name)}) == 0) {{ {decl} {_poison(f, 'x')} "
            f"if ({stem}_read_{f.ident}(ctx, {arg}) == -1) {{ const int e = errno; {_still_poison(f, 'x')} "
            f"if (e == ENODATA) put_null({cstring(f.fn.name)}); else error_(e); }} "
            f"else {{ {_put(f, 'x', None)} }} }}\n"
        )
    write_cases = "".join(
        f"        if (strcmp(name, {cstring(f.fn.name)}) == 0) {{ if ({stem}_write_{f.ident}(ctx, {_parse(f)}) == -1) "
        f'error_(errno); else printf("ok\\n"); }}\n'
        for f in fns
        if f.encode is not None
    )
    return f"""#include "{stem}.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
{_PRINT}
int main(int argc, char **argv) {{
    static char cmd[64], name[256], text[4096], buf[4096];
    struct {stem}_driver dev;
    modbus_t *ctx;
    if (argc < 2 || argc > 4) return 2;
    ctx = strncmp(argv[1], "rtu:", 4) == 0 ? modbus_new_rtu(argv[1] + 4, 19200, 'N', 8, 1)
                                           : modbus_new_tcp("127.0.0.1", atoi(argv[1]));
    if (ctx == NULL) {{
        printf("connect failed: %s\\n", modbus_strerror(errno));
        return 1;
    }}
    modbus_set_slave(ctx, argc == 4 ? atoi(argv[3]) : 1);
    if (argc >= 3 && atoi(argv[2]) > 0) {{
        const unsigned us = (unsigned)atoi(argv[2]) * 1000U;
        modbus_set_response_timeout(ctx, us / 1000000U, us % 1000000U);
        modbus_set_byte_timeout(ctx, us / 1000000U, us % 1000000U);
    }}
    if (modbus_connect(ctx) == -1) {{
        printf("connect failed: %s\\n", modbus_strerror(errno));
        modbus_free(ctx);
        return 1;
    }}
    {stem}_init(&dev, ctx);
    while (scanf("%63s", cmd) == 1) {{
        if (strcmp(cmd, "all") == 0) {{
            static struct {stem}_values v;
{poison_all}            if ({stem}_driver_read_all(&dev, &v) == -1) {{
                const int e = errno;
{check_all}                error_(e);
            }} else {{
{put_all}            }}
        }} else if (strcmp(cmd, "read") == 0 && scanf("%255s", name) == 1) {{
{"".join(read_cases)}        }} else if (strcmp(cmd, "write") == 0 && scanf("%255s %4095s", name, text) == 2) {{
            unhex(text, buf, sizeof buf);
{write_cases}        }} else if (strcmp(cmd, "connect") == 0) {{
            modbus_close(ctx);
            if (modbus_connect(ctx) == -1) error_(errno);
            else printf("ok\\n");
        }}
        printf("end\\n");
        fflush(stdout);
    }}
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}}
"""


def build(device: Device, workdir: Path, source_name: str = "harness.xml") -> Path:
    """Generate the C driver into workdir, compile it with STRICT by gcc and by clang (when installed)
    and link it with the harness."""
    gcc = tool("gcc")
    cflags, libs = modbus_flags()
    files = render(device, source_name, "c")
    stem = next(name for name in files if name.endswith(".h"))[:-2]
    for name, text in files.items():
        (workdir / name).write_text(text, encoding="utf-8")
    (workdir / "c_harness.c").write_text(harness_source(device, stem), encoding="utf-8")
    c_file = workdir / f"{stem}.c"
    obj = compile_driver(c_file, "gcc")
    if shutil.which("clang") or shutil.which("clang-14"):
        compile_driver(c_file, "clang")
    exe = workdir / "c_harness"
    proc = subprocess.run(
        [gcc, "-std=c99", "-O0", *cflags, "-o", str(exe), str(workdir / "c_harness.c"), str(obj), *libs, "-lm"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    return exe


SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-g", "-O1"]


def build_sanitized(device: Device, workdir: Path, source_name: str = "harness.xml") -> Path:
    """The C driver of `device` and the C harness, compiled by gcc with ASan and UBSan: the driver with
    STRICT (the flags docs/c-api.md promises), the harness (test code) with -std=c99."""
    gcc = tool("gcc")
    cflags, libs = modbus_flags()
    files = render(device, source_name, "c")
    stem = next(name for name in files if name.endswith(".c"))[:-2]
    for name, text in files.items():
        (workdir / name).write_text(text, encoding="utf-8")
    (workdir / "c_harness.c").write_text(harness_source(device, stem), encoding="utf-8")
    driver = workdir / f"{stem}.o"
    proc = subprocess.run(
        [gcc, *STRICT, *SANITIZE, *cflags, "-c", str(workdir / f"{stem}.c"), "-o", str(driver)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    exe = workdir / "c_harness_san"
    proc = subprocess.run(
        [gcc, "-std=c99", *SANITIZE, *cflags, "-o", str(exe), str(workdir / "c_harness.c"), str(driver), *libs, "-lm"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    return exe
