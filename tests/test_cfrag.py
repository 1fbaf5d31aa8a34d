"""C fragments: the safe subset is enforced, and the Python translation computes what gcc does."""

from __future__ import annotations

import math
import random
import shutil
import subprocess

import pytest

from mdl.cfrag import FragmentError, _compile, check

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
WRITES = [
    ("r1 = (uint16_t)(arg/10.0f);", (0.0, 600000.0)),
    ("r1 = (uint16_t)(arg * 10);", (0.0, 6000.0)),
    ("r1 = (int16_t)(arg * 10);", (-3000.0, 3000.0)),
    ("r1 = (uint32_t)(arg * 100) >> 16; r2 = (uint32_t)(arg * 100) & 0xFFFF;", (0.0, 4.0e7)),
    ("r1 = arg;", (0.0, 65535.0)),
    ("r1 = (int32_t)(arg * 1000.0f) >> 16; r2 = (int32_t)(arg * 1000.0f);", (-2.0e6, 2.0e6)),
    ("r1 = arg > 50 ? 1 : 0; r2 = (uint16_t)(arg * 2.5f) % 7u;", (0.0, 100.0)),
]

C_HEADER = """#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
"""


def _c_program() -> str:
    parts = [C_HEADER]
    for i, code in enumerate(READS):
        parts.append(f"static double rd{i}(uint16_t r1, uint16_t r2, uint16_t r3, uint16_t r4) {{\n"
                     f"  double arg = 0; (void)r1; (void)r2; (void)r3; (void)r4;\n  {code}\n  return arg;\n}}\n")
    for i, (code, _) in enumerate(WRITES):
        parts.append(f"static void wr{i}(double arg, uint16_t *out) {{\n"
                     f"  uint16_t r1 = 0, r2 = 0; (void)arg;\n  {code}\n  out[0] = r1; out[1] = r2;\n}}\n")
    reads = "".join(f"      case {i}: v = rd{i}(r[0], r[1], r[2], r[3]); break;\n" for i in range(len(READS)))
    writes = "".join(f"      case {i}: wr{i}(a, out); break;\n" for i in range(len(WRITES)))
    parts.append(f"""int main(void) {{
  char kind; int idx;
  while (scanf(" %c %d", &kind, &idx) == 2) {{
    if (kind == 'r') {{
      unsigned r[4]; double v = 0;
      if (scanf("%u %u %u %u", &r[0], &r[1], &r[2], &r[3]) != 4) return 2;
      switch (idx) {{
{reads}      }}
      printf("%a\\n", v);
    }} else {{
      double a; uint16_t out[2];
      if (scanf("%la", &a) != 1) return 2;
      switch (idx) {{
{writes}      }}
      printf("%u %u\\n", out[0], out[1]);
    }}
  }}
  return 0;
}}
""")
    return "".join(parts)


@pytest.fixture(scope="module")
def c_fragments(tmp_path_factory):
    gcc = shutil.which("gcc") or shutil.which("cc")
    if gcc is None:
        pytest.skip("no C compiler (gcc) on this machine")
    d = tmp_path_factory.mktemp("cfrag")
    src, exe = d / "frag.c", d / "frag"
    src.write_text(_c_program())
    # -fwrapv: signed overflow wraps, as the translation does (plain C leaves it undefined)
    subprocess.run([gcc, "-std=c99", "-O1", "-fwrapv", "-w", "-o", str(exe), str(src)], check=True)
    return exe


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def test_reads_match_gcc(c_fragments):
    rng = random.Random(1234)
    cases = []
    for i in range(len(READS)):
        for _ in range(150):
            regs = [rng.choice([0, 1, 2, 0x7FFF, 0x8000, 0xFFFF, rng.randrange(65536)]) for _ in range(4)]
            cases.append((i, regs))
    stdin = "".join(f"r {i} {' '.join(map(str, regs))}\n" for i, regs in cases)
    out = subprocess.run([str(c_fragments)], input=stdin, capture_output=True, text=True, check=True).stdout.split()
    assert len(out) == len(cases)
    for (i, regs), c_value in zip(cases, out):
        py = _compile(READS[i], 4, True)(regs)
        expected = float.fromhex(c_value) if "nan" not in c_value else math.nan
        assert _same(py, expected), (READS[i], regs, py, c_value)


def test_writes_match_gcc(c_fragments):
    rng = random.Random(99)
    cases = []
    for i, (_, (lo, hi)) in enumerate(WRITES):
        for _ in range(200):
            cases.append((i, round(rng.uniform(lo, hi), rng.choice([0, 1, 2, 3]))))
    stdin = "".join(f"w {i} {a.hex()}\n" for i, a in cases)
    out = subprocess.run([str(c_fragments)], input=stdin, capture_output=True, text=True, check=True).stdout.splitlines()
    for (i, a), line in zip(cases, out):
        py = _compile(WRITES[i][0], 2, False)(a)
        assert py == [int(x) for x in line.split()], (WRITES[i][0], a, py, line)


@pytest.mark.parametrize("code, token", [
    ('arg = system("rm -rf /");', '"'),
    ("arg = foo(r1);", "foo"),
    ("arg = r1; }", "}"),
    ("#include <stdlib.h>\narg = r1;", "#"),
    ("arg = r1; /* */ arg = exit(1);", "exit"),
    ("arg = r1; // hidden \\\n arg = 0;", "\\"),
    ("arg = r1; /* arg = r2; */", "comment"),
    ("arg = r9;", "r9"),
    ("arg = errno;", "errno"),
    ("x = 1;", "x"),
    ("arg == r1;", "=="),
    ("arg = r1++;", "+"),
    ("arg = *r1;", "*"),
    ("arg = r1[0];", "["),
    ("arg = 'a';", "'"),
    ("arg = (long double)r1;", "long"),
    ("arg = sizeof(r1);", "sizeof"),
    ("if (r1) arg = 1;", "if"),
    ("arg = r1, arg = r2;", ","),
    ("arg = 010;", "010"),
])
def test_hostile_fragments_are_refused(code, token):
    with pytest.raises(FragmentError) as exc:
        check(code, 2)
    assert token in str(exc.value), str(exc.value)


def test_fragment_may_carry_plain_comment():
    check("arg = (float)r1 / 10.0f; /* tenths of a degree */", 1)
