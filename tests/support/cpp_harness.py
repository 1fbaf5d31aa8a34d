"""Build generated C++ drivers with a small test program that speaks a line protocol on stdin:

    all                 -> one line per readable function: NAME KIND:VALUE (or NAME null), then "end"
    read NAME           -> the same for one function, or "error ERRNO TEXT", then "end"
    write NAME VALUE    -> "ok" or "error ERRNO TEXT", then "end"   (VALUE: strings as hex bytes)
    connect             -> modbus_close, then modbus_connect on the same context: "ok" or "error ERRNO TEXT"

TEXT is modbus_strerror(ERRNO). A read's value holds a poison value before the call (77, "poison",
true, ...), and a read that fails but leaves anything else there aborts the program: a failed read
must not store a value.

`harness WHERE [TIMEOUT_MS [UNIT]]`: WHERE is a TCP port on 127.0.0.1 (a `modbus_new_tcp` context), or
`rtu:DEVICE` (`rtu(device)`: a `modbus_new_rtu` context on that serial device at 19200 8N1, as
`mdl sim --serial` serves by default); TIMEOUT_MS sets libmodbus' response and byte timeouts (0 keeps
its defaults); UNIT goes to `modbus_set_slave` (1 by default). A context that cannot be made or
connected prints "connect failed: TEXT" and exits 1.

Every driver is compiled with STRICT (the flags docs/cpp-api.md promises) by g++ and by clang++,
once per compiler and content in a session: `compile_driver` keeps the objects, and a test that
builds a driver again (or the golden files' identical driver) reuses them. A missing compiler,
libmodbus or clang-tidy skips what needs it, except under CI (CI=true), where it fails.
"""

from __future__ import annotations

import atexit
import hashlib
import os
import re
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path

from mdl.model import Device
from mdl.resolver import resolve
from mdl.targets import render
from mdl.targets.cpp import emit as cppgen
from mdl.targets.templating import cstring
from support.common import CPP, skip_or_fail
from support.tiers import require_tier

STRICT = ["-std=c++17", "-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Wshadow", "-Werror"]
COMPILERS = ("g++", "clang++")
TIDY_CONFIG = CPP / "clang-tidy.yaml"
MODBUS_ENOBASE = 112345678


def unavailable(problem: str) -> None:
    """Skip the test, or fail it under CI, where every tool must be there."""
    skip_or_fail(f"C++ driver tests: {problem}")


def tool(name: str) -> str:
    """The path of a compiler or clang-tool (or its -14 variant), or skip (fail under CI)."""
    require_tier("compile", f"the C++ tool {name}")
    found = shutil.which(name) or shutil.which(f"{name}-14")
    if found is None:
        unavailable(f"{name} is not installed")
    assert found is not None
    return found


def modbus_flags() -> tuple[list[str], list[str]]:
    """(cflags, libs) of libmodbus, or skip (fail under CI)."""
    pkg = shutil.which("pkg-config")
    if not pkg or subprocess.run([pkg, "--exists", "libmodbus"]).returncode != 0:
        unavailable("libmodbus-dev is not installed (apt-get install libmodbus-dev)")
    assert pkg is not None
    cflags = subprocess.run([pkg, "--cflags", "libmodbus"], capture_output=True, text=True).stdout.split()
    libs = subprocess.run([pkg, "--libs", "libmodbus"], capture_output=True, text=True).stdout.split()
    return cflags, libs


def toolchain() -> tuple[str, list[str], list[str]]:
    """(g++, cflags, libs) that build and link the test programs, or skip (fail under CI)."""
    gxx = tool("g++")
    return (gxx, *modbus_flags())


_objects: dict[str, Path] = {}
_object_dir: list[Path] = []


def _cache_dir() -> Path:
    if not _object_dir:
        _object_dir.append(Path(tempfile.mkdtemp(prefix="mdl-cpp-objects-")))
        atexit.register(shutil.rmtree, _object_dir[0], True)
    return _object_dir[0]


def compile_driver(cc: Path, compiler: str) -> Path:
    """The object of a generated driver (cc and the header beside it), compiled with STRICT -O0 by
    `compiler`; compiled once per session for each content."""
    compiler_path = tool(compiler)
    cflags, _ = modbus_flags()
    header = cc.with_suffix(".h")
    key = hashlib.sha256(
        b"\0".join([compiler.encode(), header.name.encode(), header.read_bytes(), cc.read_bytes()])
    ).hexdigest()
    if key not in _objects:
        obj = _cache_dir() / f"{key}.o"
        proc = subprocess.run(
            [compiler_path, *STRICT, "-O0", *cflags, "-c", str(cc), "-o", str(obj)], capture_output=True, text=True
        )
        assert proc.returncode == 0, f"{compiler} {cc.name}:\n{proc.stderr}"
        _objects[key] = obj
    return _objects[key]


def clang_tidy(cc: Path) -> subprocess.CompletedProcess[str]:
    """clang-tidy with tests/cpp/clang-tidy.yaml on a driver and its header."""
    tidy = tool("clang-tidy")
    cflags, _ = modbus_flags()
    header_filter = "^" + re.sub(r"([][.^$|(){}*+?\\])", r"\\\1", str(cc.parent.resolve())) + "/"
    return subprocess.run(
        [
            tidy,
            "--quiet",
            f"--config-file={TIDY_CONFIG}",
            f"--header-filter={header_filter}",
            str(cc),
            "--",
            "-std=c++17",
            *cflags,
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )


_PRINT = r"""
template <typename T> static void put(const char *n, const T &v) {
    if constexpr (std::is_same_v<T, std::vector<std::string>>) {
        std::printf("%s l:", n);
        for (size_t i = 0; i < v.size(); ++i) {
            if (i) std::printf(",");
            for (unsigned char c : v[i]) std::printf("%02x", c);
        }
        std::printf("\n");
    } else if constexpr (std::is_same_v<T, std::string>) {
        std::printf("%s s:", n);
        for (unsigned char c : v) std::printf("%02x", c);
        std::printf("\n");
    } else if constexpr (std::is_same_v<T, bool>) {
        std::printf("%s b:%d\n", n, v ? 1 : 0);
    } else if constexpr (std::is_floating_point_v<T>) {
        std::printf("%s f:%.17g\n", n, static_cast<double>(v));
    } else if constexpr (std::is_signed_v<T>) {
        std::printf("%s i:%lld\n", n, static_cast<long long>(v));
    } else {
        std::printf("%s i:%llu\n", n, static_cast<unsigned long long>(v));
    }
}
template <typename T> static void put(const char *n, const std::optional<T> &v) {
    if (!v) std::printf("%s null\n", n);
    else put(n, *v);
}
[[maybe_unused]] static std::string unhex(const std::string &h) {
    std::string out;
    for (size_t i = 0; i + 1 < h.size(); i += 2) out += static_cast<char>(std::stoi(h.substr(i, 2), nullptr, 16));
    return out;
}
template <typename T> struct Poison {
    static T get() {
        if constexpr (std::is_same_v<T, std::vector<std::string>>) return {"poison"};
        else if constexpr (std::is_same_v<T, std::string>) return "poison";
        else if constexpr (std::is_same_v<T, bool>) return true;
        else return static_cast<T>(77);
    }
};
template <typename T> struct Poison<std::optional<T>> {
    static std::optional<T> get() { return Poison<T>::get(); }
};
template <typename T> static void poison(T *v) { *v = Poison<T>::get(); }
template <typename T> static void still_poison(const char *n, const T &v) {
    if (!(v == Poison<T>::get())) {
        std::fprintf(stderr, "a failed read stored a value in %s\n", n);
        std::abort();
    }
}
static void error(int e) { std::printf("error %d %s\n", e, modbus_strerror(e)); }
"""


def _parse(t: str) -> str:
    return {
        "std::string": "unhex(text)",
        "bool": 'text == "1"',
        "double": "std::strtod(text.c_str(), nullptr)",
        "float": "std::strtof(text.c_str(), nullptr)",
    }.get(t, f"static_cast<{t}>(std::strto{'ull' if t.startswith('u') else 'll'}(text.c_str(), nullptr, 10))")


def harness_source(device: Device, stem: str) -> str:
    ctx = cppgen.context(resolve(device), "harness")
    cls = ctx["class_name"]
    fns = ctx["functions"]
    reads = [f for f in fns if f.readable]
    all_lines = "".join(f"            put({cstring(f.fn.name)}, v.{f.ident});\n" for f in reads)
    poison_all = "".join(f"        poison(&v.{f.ident});\n" for f in reads)
    check_all = "".join(f"                still_poison({cstring(f.fn.name)}, v.{f.ident});\n" for f in reads)
    read_cases = "".join(
        f"        if (name == {cstring(f.fn.name)}) {{ {f.rt} x; poison(&x); if (dev.read_{f.ident}(&x) == -1) "
        f"{{ const int e = errno; still_poison({cstring(f.fn.name)}, x); error(e); }} "
        f"else put({cstring(f.fn.name)}, x); }}\n"
        for f in reads
    )
    write_cases = "".join(
        f"        if (name == {cstring(f.fn.name)}) {{ if (dev.write_{f.ident}({_parse(f.t)}) == -1) "
        f'error(errno); else std::printf("ok\\n"); }}\n'
        for f in fns
        if f.writable
    )
    return f"""#include "{stem}.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>
{_PRINT}
int main(int argc, char **argv) {{
    // harness WHERE [TIMEOUT_MS [UNIT]]: WHERE is a TCP port on 127.0.0.1 or rtu:DEVICE (19200 8N1);
    // a timeout of 0 keeps libmodbus' default
    if (argc < 2 || argc > 4) return 2;
    const std::string where = argv[1];
    modbus_t *ctx = where.rfind("rtu:", 0) == 0 ? modbus_new_rtu(where.substr(4).c_str(), 19200, 'N', 8, 1)
                                                : modbus_new_tcp("127.0.0.1", std::atoi(argv[1]));
    if (ctx == nullptr) {{
        std::printf("connect failed: %s\\n", modbus_strerror(errno));
        return 1;
    }}
    modbus_set_slave(ctx, argc == 4 ? std::atoi(argv[3]) : 1);
    if (argc >= 3 && std::atoi(argv[2]) > 0) {{
        const auto us = static_cast<uint32_t>(std::atoi(argv[2]) * 1000);
        modbus_set_response_timeout(ctx, us / 1000000U, us % 1000000U);
        modbus_set_byte_timeout(ctx, us / 1000000U, us % 1000000U);
    }}
    if (modbus_connect(ctx) == -1) {{
        std::printf("connect failed: %s\\n", modbus_strerror(errno));
        modbus_free(ctx);
        return 1;
    }}
    {cls} dev(ctx);
    std::string cmd, name, text;
    while (std::cin >> cmd) {{
        if (cmd == "all") {{
            {cls}Values v;
{poison_all}            if (dev.read_all(&v) == -1) {{
                const int e = errno;
{check_all}                error(e);
            }} else {{
{all_lines}            }}
        }} else if (cmd == "read" && std::cin >> name) {{
{read_cases}        }} else if (cmd == "write" && std::cin >> name >> text) {{
{write_cases}        }} else if (cmd == "connect") {{
            modbus_close(ctx);
            if (modbus_connect(ctx) == -1) error(errno);
            else std::printf("ok\\n");
        }}
        std::printf("end\\n");
        std::fflush(stdout);
    }}
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}}
"""


def build(device: Device, workdir: Path, sanitize: bool = False, source_name: str = "harness.xml") -> Path:
    """Generate the driver into workdir, compile it with STRICT by g++ and by clang++ (when installed)
    and link it with the harness. source_name is the file the driver's first line names: pass the
    golden drivers' own to share their objects."""
    gxx, cflags, libs = toolchain()
    files = render(device, source_name, "cpp")
    stem = next(name for name in files if name.endswith(".h"))[:-2]
    for name, text in files.items():
        (workdir / name).write_text(text)
    (workdir / "harness.cc").write_text(harness_source(device, stem))
    cc = workdir / f"{stem}.cc"
    if sanitize:
        exe = workdir / "harness_san"
        sources = [str(cc), str(workdir / "harness.cc")]
        flags = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-g", "-O1"]
    else:
        exe = workdir / "harness"
        sources = [str(workdir / "harness.cc"), str(compile_driver(cc, "g++"))]
        if shutil.which("clang++") or shutil.which("clang++-14"):
            compile_driver(cc, "clang++")  # without clang++, the tests that need it say so
        flags = ["-O0"]
    proc = subprocess.run(
        [gxx, *STRICT, *flags, *cflags, "-o", str(exe), *sources, *libs], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    return exe


def rtu(device: str) -> str:
    """The harness' WHERE for an RTU context on a serial device (19200 8N1)."""
    return f"rtu:{device}"


class Harness:
    """A running harness on a TCP port (int) or `rtu(device)`, `with` it or `close()` it. Every `ask` is
    bounded: a harness that has not answered within `ask_timeout` seconds is killed and the ask fails."""

    def __init__(
        self, exe: Path, where: int | str, timeout_ms: int | None = None, unit: int = 1, ask_timeout: float = 60
    ):
        env = {**os.environ, "ASAN_OPTIONS": "detect_leaks=1", "UBSAN_OPTIONS": "print_stacktrace=1"}
        args = [str(exe), str(where), str(timeout_ms or 0), str(unit)]
        self.ask_timeout = ask_timeout
        self.proc = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
        )

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, kind: object, *_: object) -> None:
        if kind is None:
            self.close()
        else:  # the test failed already: end the harness without a second failure hiding the first
            self.proc.kill()
            self.proc.communicate(timeout=30)

    def ask(self, line: str) -> list[str]:
        overdue = threading.Event()

        def kill() -> None:
            overdue.set()
            self.proc.kill()

        watchdog = threading.Timer(self.ask_timeout, kill)
        watchdog.start()
        try:
            return self._answer(line)
        except (AssertionError, BrokenPipeError) as exc:
            if overdue.is_set():
                raise AssertionError(f"harness gave no answer to {line!r} within {self.ask_timeout} s") from exc
            raise
        finally:
            watchdog.cancel()

    def _answer(self, line: str) -> list[str]:
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        out = []
        while True:
            got = self.proc.stdout.readline()
            if not got:
                raise AssertionError(f"harness ended: {self.proc.stderr.read()}")
            got = got.rstrip("\n")
            if got == "end":
                return out
            out.append(got)

    def values(self, line: str = "all") -> dict:
        """NAME -> value (int, float, str, bool or None); an error line becomes {'error': errno}."""
        out = {}
        for item in self.ask(line):
            if item.startswith("error "):
                return {"error": int(item.split()[1])}
            name, _, value = item.rpartition(" ")
            if value == "null":
                out[name] = None
                continue
            kind, _, text = value.partition(":")
            out[name] = {
                "i": int,
                "f": float,
                "b": lambda t: t == "1",
                "s": lambda t: bytes.fromhex(t).decode("utf-8", "replace"),
                "l": lambda t: [bytes.fromhex(x).decode("utf-8", "replace") for x in t.split(",")] if t else [],
            }[kind](text)
        return out

    def close(self) -> str:
        self.proc.stdin.close()
        self.proc.wait(timeout=30)
        err = self.proc.stderr.read()
        self.proc.stdout.close()
        self.proc.stderr.close()
        assert self.proc.returncode == 0, err
        return err
