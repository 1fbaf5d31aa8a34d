"""C fragments (docs/fragments.md) the tests share: the fragments every target must agree on (READS, WRITES,
...), the Python translation's results, and the batch program (CBatch) that runs many fragments' C functions
at once under UBSan (tests/unit/dsl/cfrag/test_cfrag.py, tests/fuzz/test_fuzz_fragments.py, the compiled
drivers' tests)."""

from __future__ import annotations

import math
import random
import subprocess
from collections.abc import Sequence
from pathlib import Path

from mdl.dsl.cfrag import (
    INCLUDES,
    compile_fragment,
    compile_read,
    compile_write,
    helpers_source,
)
from support.common import ROOT
from support.cpp_harness import tool

READS = [
    "arg = (float)r1/10.0f;",
    "arg = (int16_t)r1 / 10.0;",
    "arg = (int16_t)r1 / 7;",
    "arg = (int16_t)r1 % 7;",
    "arg = -(int16_t)r2 % -5;",
    "arg = (r1 >> 3) & 1;",
    "arg = ((uint32_t)r1 << 16 | r2) * 0.01;",
    "arg = (int32_t)((uint32_t)r1 << 16 | r2);",
    "arg = r1 > r2 ? r1 - r2 : r2 - r1;",
    "arg = r1 - r2;",
    "arg = (unsigned)r1 - r2;",
    "arg = (uint16_t)(r1 + r2);",
    "arg = (int8_t)r1;",
    "arg = (uint8_t)(r1 >> 8);",
    "arg = !r1 + ~r2;",
    "arg = r1 && r2 || !r3;",
    "arg = (float)r1 * 0.1f + (float)r2 * 0.01f;",
    "arg = r1 * 65536.0 + r2; arg /= 1000;",
    "arg = (double)(int64_t)((uint64_t)r1 << 48 | (uint64_t)r2 << 32 | (uint64_t)r3 << 16 | r4);",
    "arg = (uint64_t)r1 << 48 | (uint64_t)r2 << 32;",
    "arg = 0x8000u - r1;",
    "arg = -r1 / 3;",
    "arg = r1 * r2 * r3;",
    "arg = (float)r1 / (float)r2;",
    "r1 = r1 * 2; arg = r1;",
    "arg = r1; arg *= 1.5f;",
    "arg = 1e3 * r1 + .5;",
    "arg = r1 % 10u - 11;",
    "arg = 5l * r1 - 100000L * r2;",
    "arg = r1 >= 100 == r2 < 5;",
    "arg = (int)(r1 * 0.37f) ^ r2;",
    "arg = (r1 & 0x00FF) * 256 + (r2 >> 8);",
    "arg = r1 ? (float)r2 / 3 : -1.5f;",
    "arg = r1; arg -= r2; arg += 0.25; arg /= 2;",
    "r2 <<= 3; r2 |= 1; r2 ^= r1; arg = r2;",
    "arg = (double)(float)(r1 / 3.0);",
    "arg = (uint32_t)r1 * (uint32_t)r2 * 3u;",
    "arg = (int64_t)r1 * r2 * r3 * -7;",
    "arg = (int16_t)r1 >> 2;",
]


# what C leaves undefined, or a device can break: each has a defined result or error here
UNDEFINED_READS = [
    "arg = 1000 / r1;",
    "arg = 1000 % (int)r1 + 1000u / r2;",
    "arg = r1 << r2;",
    "arg = (int16_t)r1 << r2;",
    "arg = (int64_t)(int16_t)r1 >> (r2 - 32768);",
    "arg = (uint64_t)r1 >> (int)r2;",
    "arg = (int)((float)r1 * 1e6f);",
    "arg = (uint16_t)((int16_t)r1 * 3.5);",
    "arg = (int32_t)((uint32_t)r1 << 16) / -(int)(r2 == 0);",
    "arg = (int64_t)r1 * r2 * r3 * r4 * r1 * r2;",
    "arg = (int)(r1 - r2) * 65536 * 32768;",
    "arg = (uint8_t)r1 < 300;",
    "arg = (unsigned)r1 >= 0u;",
    "arg = r1 && 5;",
    "arg = 1 ? r1 : r2;",
    "arg = r1 ? 2 : 2;",
    "arg = 0 && r1 / 0x1;",
    "arg = (float)(uint64_t)((uint64_t)r1 << 48 | r2) * 3;",
    "arg = (double)r1 / (double)(r2 - r3);",
    "r1 = r1 - 40000; arg = r1;",
    "r1 = -1; arg = r1;",
    "r3 = r1 * r2; arg = r3 / 2;",
    # what compilers and clang-tidy call suspicious: identical operands, self-assignment, constants
    "arg = ((r1 % r2) ? r3 : r3) * 2 + (r1 ? 7 : 7);",
    "arg = (uint64_t)~r1 + (r1 && r1) + (r2 & r2) + (r3 ^ r3) + (r1 > r1) + ((r1 | 3) != 0);",
    "r1 = r1; r2 = (uint16_t)r2; arg = arg; arg = r1 + r2;",
    "r2 = 33; arg = r2 ? 64 : r4 >= 2147483648;",
    "arg = 0.0 - (double)r1 + (0.0f - (float)r2) + (0.0 + -1.0 * r3);",  # gcc folds these to -0.0
]


WRITES = [
    ("r1 = (uint16_t)(arg/10.0f);", (0.0, 600000.0)),
    ("r1 = (uint16_t)(arg * 10);", (0.0, 6000.0)),
    ("r1 = (int16_t)(arg * 10);", (-3000.0, 3000.0)),
    ("r1 = (uint32_t)(arg * 100) >> 16; r2 = (uint32_t)(arg * 100) & 0xFFFF;", (0.0, 4.0e7)),
    ("r1 = arg;", (0.0, 65535.0)),
    ("r1 = (int32_t)(arg * 1000.0f) >> 16; r2 = (int32_t)(arg * 1000.0f);", (-2.0e6, 2.0e6)),
    ("r1 = arg > 50 ? 1 : 0; r2 = (uint16_t)(arg * 2.5f) % 7u;", (0.0, 100.0)),
]


UNDEFINED_WRITES = [
    ("r1 = arg * 10;", (-5000.0, 8000.0)),
    ("r1 = 1000 / (int)arg;", (-3.0, 3.0)),
    ("r1 = (int)arg; r2 = r1 * 2;", (-70000.0, 70000.0)),
    ("arg = arg * 2; r1 = (uint16_t)(int)arg;", (-1e10, 1e10)),
    ("r2 = 7;", (0.0, 1.0)),
]


WRITE_SPECIALS = [
    0.0,
    -0.0,
    0.5,
    -0.5,
    1.0,
    -1.0,
    6553.5,
    65535.0,
    65535.99,
    65536.0,
    -32768.0,
    -32769.0,
    2147483647.0,
    2147483648.0,
    -2147483649.0,
    1e300,
    -1e300,
    math.inf,
    -math.inf,
    math.nan,
]


EDGE_REGISTERS = [0, 1, 2, 3, 31, 32, 33, 64, 0x7FFF, 0x8000, 0x8001, 0xFFFE, 0xFFFF]


ERRNO = {ZeroDivisionError: "EDOM", FloatingPointError: "EDOM", OverflowError: "ERANGE"}


UBSAN = ["-fsanitize=undefined,integer-divide-by-zero,float-cast-overflow", "-fno-sanitize-recover=all"]


C99_STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Wshadow", "-Werror"]


CPP_STRICT = ["-std=c++17", "-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Wshadow", "-Werror"]


TIDY_CONFIG = ROOT / "tests" / "cpp" / "clang-tidy.yaml"


NREGS = 4


def python_result(code: str, reading: bool, given: Sequence[int] | float) -> str:
    """ "ok VALUE" (a read's double, as float.hex), "ok R1 R2 .." (a write's registers) or "err ERRNO"."""
    try:
        if reading:
            assert isinstance(given, Sequence)
            return "ok " + canonical(compile_read(code, NREGS)(list(given)))
        assert isinstance(given, float)
        return "ok " + " ".join(map(str, compile_write(code, NREGS)(given)))
    except (ZeroDivisionError, FloatingPointError, OverflowError) as exc:
        return "err " + ERRNO[type(exc)]


def canonical(x: float) -> str:
    """A double bit for bit, but every NaN alike (C leaves a NaN's sign and payload open)."""
    return "nan" if math.isnan(x) else x.hex()


class CBatch:
    """Fragments as the functions f0, f1, ... of one C99 program (built with gcc, UBSan and -Werror)
    that reads "IDX R1 R2 R3 R4" (read fragments) or "IDX ARG" (write fragments, ARG as %la) and
    writes "ok %.17g", "ok R1 R2 R3 R4" or "err EDOM|ERANGE" per line; a function that fails must
    leave its output untouched."""

    def __init__(self, codes: Sequence[tuple[str, bool]], workdir: Path):
        self.codes = list(codes)
        fragments = [compile_fragment(code, NREGS, reading).c("c") for code, reading in self.codes]
        self.source = workdir / "batch.c"
        self.exe = workdir / "batch"
        self.source.write_text(self._program(fragments))

    def _program(self, fragments: list) -> str:
        head = "".join(f"#include <{h}>\n" for h in (*INCLUDES["c"], "stdio.h"))
        functions = "\n".join(f.function(f"f{i}") for i, f in enumerate(fragments))
        cases = "".join(
            f"        case {i}: rc = f{i}({'r, &x' if reading else 'x, r'}); break;\n"
            for i, (_, reading) in enumerate(self.codes)
        )
        readers = ", ".join("1" if reading else "0" for _, reading in self.codes)
        return f"""{head}
{helpers_source(fragments, "c")}
{functions}
static const int reading[] = {{{readers}}};

int main(void) {{
    int idx = 0;
    while (scanf("%d", &idx) == 1) {{
        uint16_t r[4] = {{0xDEAD, 0xDEAD, 0xDEAD, 0xDEAD}};
        double x = -12345.0;
        unsigned in[4] = {{0, 0, 0, 0}};
        int rc = 0;
        if (reading[idx] ? scanf("%u %u %u %u", &in[0], &in[1], &in[2], &in[3]) != 4 : scanf("%la", &x) != 1) {{
            return 2;
        }}
        for (int i = 0; i < 4; i++) {{
            r[i] = reading[idx] ? (uint16_t)in[i] : (uint16_t)0xDEAD;
        }}
        switch (idx) {{
{cases}        default: return 3;
        }}
        if (rc != 0) {{
            int untouched = reading[idx] ? x == -12345.0 : r[0] == 0xDEAD && r[3] == 0xDEAD;
            printf("err %s\\n", !untouched ? "TOUCHED" : errno == EDOM ? "EDOM" : errno == ERANGE ? "ERANGE" : "OTHER");
        }} else if (reading[idx]) {{
            printf("ok %.17g\\n", x);
        }} else {{
            printf("ok %u %u %u %u\\n", (unsigned)r[0], (unsigned)r[1], (unsigned)r[2], (unsigned)r[3]);
        }}
    }}
    return 0;
}}
"""

    def build(self) -> subprocess.CompletedProcess[str]:
        gcc = tool("gcc")
        return subprocess.run(
            [gcc, *C99_STRICT, "-O1", *UBSAN, "-o", str(self.exe), str(self.source)],
            capture_output=True,
            text=True,
            timeout=600,
        )

    def run(self, cases: Sequence[tuple[int, Sequence[int] | float]]) -> subprocess.CompletedProcess[str]:
        lines = []
        for idx, given in cases:
            text = " ".join(map(str, given)) if isinstance(given, Sequence) else float(given).hex()
            lines.append(f"{idx} {text}\n")
        return subprocess.run([str(self.exe)], input="".join(lines), capture_output=True, text=True, timeout=600)


def c_result(line: str, reading: bool) -> str:
    """A batch output line as python_result writes the same result."""
    status, _, rest = line.partition(" ")
    if status != "ok" or not reading:
        return line
    return "ok " + canonical(float(rest))


def disagreements(batch: CBatch, cases: Sequence[tuple[int, Sequence[int] | float]]) -> list[tuple]:
    """Cases where the C functions (run under UBSan) and the Python translation differ; fails the test
    on a compiler warning, a UBSan report or a crash."""
    built = batch.build()
    assert built.returncode == 0, built.stderr[-3000:]
    ran = batch.run(cases)
    assert ran.returncode == 0 and ran.stderr == "", (ran.returncode, ran.stderr[-3000:])
    out = ran.stdout.splitlines()
    assert len(out) == len(cases)
    wrong = []
    for (idx, given), line in zip(cases, out, strict=True):
        code, reading = batch.codes[idx]
        expected = python_result(code, reading, given)
        if c_result(line, reading) != expected:
            wrong.append((code, given, line, expected))
    return wrong


def register_samples(rng: random.Random, count: int) -> list[list[int]]:
    return [[rng.choice([*EDGE_REGISTERS, rng.randrange(65536)]) for _ in range(NREGS)] for _ in range(count)]


def cpp_unit(codes: Sequence[tuple[str, bool]]) -> str:
    """A C++ translation unit holding the fragments' C++ functions, as a driver holds them (in an
    anonymous namespace), and a function calling each."""
    fragments = [compile_fragment(code, NREGS, reading).c("c++") for code, reading in codes]
    functions = "\n".join(f.function(f"frag_{i}") for i, f in enumerate(fragments))
    calls = "".join(
        f"    rc |= frag_{i}({'r.data(), &out' if f.reading else 'out, r.data()'});\n" for i, f in enumerate(fragments)
    )
    head = "".join(f"#include <{h}>\n" for h in (*INCLUDES["c++"], "array"))
    return (
        f"{head}\nnamespace {{\n\n{helpers_source(fragments, 'c++')}\n{functions}\n}}  // namespace\n\n"
        f"int run_all(double out);\n\nint run_all(double out) {{\n    std::array<uint16_t, 4> r{{1, 2, 3, 4}};\n"
        f"    int rc = 0;\n{calls}    return rc;\n}}\n"
    )
