"""C fragments (docs/fragments.md): the subset on one token stream, the refusals, the defined results,
and agreement of the three targets: the Python translation, the C99 and C++17 functions of the C
emitter (compiled warning-free, run under UBSan), and gcc on the fragment's own text where C
defines the result.

The batch harness (`CBatch`, tests/support/fragments.py) is shared with tests/fuzz/test_fuzz_fragments.py:
many fragments as functions of one C program, run on the same inputs, printing what each returns."""

from __future__ import annotations

import json
import math
import random
import struct
import subprocess
from collections.abc import Sequence

import pytest

from mdl.dsl.cfrag import (
    INCLUDES,
    MAX_DEPTH,
    FragmentError,
    compile_fragment,
    compile_read,
    compile_write,
    helpers_source,
)
from support.common import fn_xml
from support.cpp_harness import tool
from support.fragments import (
    C99_STRICT,
    CPP_STRICT,
    NREGS,
    READS,
    TIDY_CONFIG,
    UNDEFINED_READS,
    UNDEFINED_WRITES,
    WRITE_SPECIALS,
    WRITES,
    CBatch,
    canonical,
    cpp_unit,
    disagreements,
    python_result,
    register_samples,
)
from support.run import assert_clean_error, run_mdl

# ---- the Python translation's results, written as the batch program writes the C ones


# ---- the batch program: many fragments' C functions in one program


@pytest.mark.compile
def test_python_and_the_c_emitter_agree_under_ubsan(tmp_path):
    rng = random.Random(1234)
    reads, writes = READS + UNDEFINED_READS, WRITES + UNDEFINED_WRITES
    codes = [(code, True) for code in reads] + [(code, False) for code, _ in writes]
    cases: list[tuple[int, Sequence[int] | float]] = []
    for i in range(len(reads)):
        cases += [(i, regs) for regs in register_samples(rng, 120)]
    for j, (_, (lo, hi)) in enumerate(writes):
        values = [round(rng.uniform(lo, hi), rng.choice([0, 1, 2, 3])) for _ in range(100)] + WRITE_SPECIALS
        cases += [(len(reads) + j, value) for value in values]
    assert disagreements(CBatch(codes, tmp_path), cases) == []


# ---- the translation is C where C defines the result: gcc on the fragment's own text

C_HEADER = "#include <stdint.h>\n#include <stdio.h>\n"


def _own_text_program() -> str:
    parts = [C_HEADER]
    for i, code in enumerate(READS):
        parts.append(
            f"static double rd{i}(uint16_t r1, uint16_t r2, uint16_t r3, uint16_t r4) {{\n"
            f"  double arg = 0; (void)r1; (void)r2; (void)r3; (void)r4;\n  {code}\n  return arg;\n}}\n"
        )
    for i, (code, _) in enumerate(WRITES):
        parts.append(
            f"static void wr{i}(double arg, uint16_t *out) {{\n"
            f"  uint16_t r1 = 0, r2 = 0; (void)arg;\n  {code}\n  out[0] = r1; out[1] = r2;\n}}\n"
        )
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
def own_text(tmp_path_factory):
    gcc = tool("gcc")
    d = tmp_path_factory.mktemp("owntext")
    src, exe = d / "frag.c", d / "frag"
    src.write_text(_own_text_program())
    # -fwrapv: signed overflow wraps, as the translation defines it (plain C leaves it undefined)
    subprocess.run([gcc, "-std=c99", "-O1", "-fwrapv", "-w", "-o", str(exe), str(src)], check=True)
    return exe


def test_reads_are_what_gcc_computes_where_c_defines_them(own_text):
    """Where the translation fails instead of wrapping (a register assigned a value outside
    -32768..65535), the case is left out."""
    rng = random.Random(99)
    cases = [(i, regs) for i in range(len(READS)) for regs in register_samples(rng, 80)]
    stdin = "".join(f"r {i} {' '.join(map(str, regs))}\n" for i, regs in cases)
    out = subprocess.run([str(own_text)], input=stdin, capture_output=True, text=True, check=True).stdout.split()
    compared = 0
    for (i, regs), c_value in zip(cases, out, strict=True):
        mine = python_result(READS[i], True, regs)
        if mine.startswith("ok"):
            compared += 1
            assert mine == "ok " + canonical(float.fromhex(c_value) if "nan" not in c_value else math.nan), (
                READS[i],
                regs,
                mine,
                c_value,
            )
    assert compared > len(cases) * 0.8


def test_writes_are_what_gcc_computes_where_c_defines_them(own_text):
    rng = random.Random(7)
    cases = [
        (i, round(rng.uniform(lo, hi), rng.choice([0, 1, 2, 3])))
        for i, (_, (lo, hi)) in enumerate(WRITES)
        for _ in range(150)
    ]
    stdin = "".join(f"w {i} {a.hex()}\n" for i, a in cases)
    out = subprocess.run([str(own_text)], input=stdin, capture_output=True, text=True, check=True).stdout.splitlines()
    for (i, a), line in zip(cases, out, strict=True):
        mine = python_result(WRITES[i][0], False, a)
        if mine.startswith("ok"):
            assert mine.split()[1:3] == line.split(), (WRITES[i][0], a, mine, line)


# ---- the C++ dialect: what the C++ driver compiles


def _all_cpp() -> str:
    return cpp_unit(
        [(code, True) for code in READS + UNDEFINED_READS] + [(code, False) for code, _ in WRITES + UNDEFINED_WRITES]
    )


@pytest.mark.compile
@pytest.mark.parametrize("compiler", ["g++", "clang++"])
def test_cpp_functions_compile_without_a_warning(compiler, tmp_path):
    source = tmp_path / "fragments.cc"
    source.write_text(_all_cpp())
    proc = subprocess.run(
        [tool(compiler), *CPP_STRICT, "-c", "-o", str(tmp_path / "fragments.o"), str(source)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]


@pytest.mark.compile  # builds generated C++/C: heavier than its folder
def test_cpp_functions_pass_the_drivers_clang_tidy_checks(tmp_path):
    source = tmp_path / "fragments.cc"
    source.write_text(_all_cpp())
    proc = subprocess.run(
        [tool("clang-tidy"), f"--config-file={TIDY_CONFIG}", str(source), "--", "-std=c++17"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-3000:]


@pytest.mark.compile
@pytest.mark.parametrize("compiler", ["gcc", "clang"])
def test_c99_functions_compile_without_a_warning(compiler, tmp_path):
    fragments = [compile_fragment(code, NREGS, True).c("c") for code in READS + UNDEFINED_READS]
    source = tmp_path / "fragments.c"
    source.write_text(
        "".join(f"#include <{h}>\n" for h in INCLUDES["c"])
        + helpers_source(fragments, "c")
        + "".join(f.function(f"frag_{i}") for i, f in enumerate(fragments))
        + "int (*const frags[])(const uint16_t *, double *) = {"
        + ", ".join(f"frag_{i}" for i in range(len(fragments)))
        + "};\n"
    )
    proc = subprocess.run(
        [tool(compiler), *C99_STRICT, "-c", "-o", str(tmp_path / "f.o"), str(source)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]


def test_the_c_api():
    """What a C or C++ generator calls: one function per fragment, and the helpers they use."""
    reader = compile_fragment("arg = 1000 / r1;", 2, True).c("c++")
    text = reader.function("frag_read_ratio")
    assert text.startswith("int frag_read_ratio(const uint16_t *r, double *out) {\n")
    assert "errno = frag_err;" in text and "return -1;" in text and "*out = arg;" in text
    writer = compile_fragment("r1 = arg * 10;", 1, False).c("c")
    assert writer.function("w").startswith("static int w(double value, uint16_t *r) {\n")
    helpers = helpers_source([reader], "c++")
    assert "\nint32_t mdl_frag_div_i32(int32_t a, int32_t b, int *e) {" in helpers and "static " not in helpers
    assert "mdl_frag_store" not in helpers  # only what the functions call (and what that calls)
    assert "static int32_t mdl_frag_store_f(double v, int *e) {" in helpers_source([writer], "c")


# ---- one token stream: what the checker sees is what every target prints


@pytest.mark.parametrize(
    "code",
    [
        "arg = r1; // x\rexit(7);",
        "arg = r1; // x\r\nexit(7);",
        "arg = r1; // x\nexit(7);",
        "arg = r1; // x\r exit(7)\n;",
    ],
)
def test_a_line_comment_ends_at_every_line_break(code):
    with pytest.raises(FragmentError) as exc:
        compile_fragment(code, 1, True)
    assert "exit" in str(exc.value)


@pytest.mark.parametrize("ch", ["\v", "\f", "\x85", "\u2028", "\u2029", "\x1c", "\x00", "\u00a0"])
def test_other_breaks_and_spaces_are_refused_everywhere(ch):
    for code in (f"arg = r1;{ch}arg = r2;", f"arg = r1; // note{ch}", f"arg = r1; /* note{ch} */"):
        with pytest.raises(FragmentError) as exc:
            compile_fragment(code, 2, True)
        assert "not" in str(exc.value) and exc.value.col == code.index(ch) + 1, (code, str(exc.value))


def test_comments_never_reach_generated_code():
    fragment = compile_fragment("arg = r1; /* tenths of a degree */ // scaled below\narg /= 10;", 1, True)
    texts = [*fragment.python_lines(), fragment.c("c").function("f"), fragment.c("c++").function("f")]
    assert all("tenths" not in t and "scaled" not in t for t in texts)


@pytest.mark.parametrize(
    "code, token",
    [
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
        ("arg = 1f;", "1f"),
        ("arg = 0x1e+1;", "0x1e+1"),
        ("arg = 1.2.3;", "1.2.3"),
        ("arg = 0x1p3;", "0x1p3"),
        ("arg = 1lL;", "1lL"),
        ("arg = 1.5L;", "1.5L"),
        ("arg = \u0663;", "\\u0663"),
        ("arg = r\u0661;", "\\u0661"),
        ("arg = 18446744073709551616u;", "too large"),
    ],
)
def test_hostile_fragments_are_refused(code, token):
    with pytest.raises(FragmentError) as exc:
        compile_fragment(code, 2, True)
    assert token in str(exc.value), str(exc.value)
    assert exc.value.col is not None and 1 <= exc.value.col <= len(code) + 1


@pytest.mark.parametrize(
    "code, message",
    [
        ("arg = 1" + "0" * 5000 + ";", "integer literal '100000000000000000000000000...' is too large"),
        ("arg = 0x1" + "0" * 5000 + ";", "too large"),
        ("arg = 1" + "0" * 5000 + ".5;", "out of range for double"),
        ("arg = 0." + "0" * 5000 + "1;", "too small"),
        ("arg = " + "x" * 5000 + ";", "unknown identifier 'xxxxxxxxxxxxxxxxxxxxxxxxxxx...'"),
    ],
    ids=["decimal", "hex", "float", "tiny", "identifier"],
)
def test_huge_tokens_are_refused_and_shown_short(code, message):
    with pytest.raises(FragmentError) as exc:
        compile_fragment(code, 1, True)
    assert message in str(exc.value) and len(str(exc.value)) < 120, str(exc.value)


def test_fragment_may_carry_plain_comment():
    compile_fragment("arg = (float)r1 / 10.0f; /* tenths of a degree */", 1, True)


# ---- what a compiler would reject or warn about is refused, with its column


@pytest.mark.parametrize(
    "code, message, col",
    [
        ("arg = r1 / 0;", "divides by the constant zero", 10),
        ("arg = r1 % (2 - 2);", "divides by the constant zero", 10),
        ("arg = r1 << 40;", "shift count 40 is outside 0..31", 10),
        ("arg = (uint64_t)r1 << 64;", "shift count 64 is outside 0..63", 20),
        ("arg = r1 >> -1;", "shift count -1", 10),
        ("arg = 2147483647 + 1;", "overflows int", 18),
        ("arg = -(-2147483647 - 1);", "overflows int", 7),
        ("arg = (-2147483647 - 1) / -1;", "overflows int", 25),
        ("arg = 65536 * 65536;", "overflows int", 13),
        ("arg = 3 << 31;", "needs more than 32 bits", 9),
        ("arg = -1 << 1;", "shifts the negative value -1 left", 10),
        ("arg = 9223372036854775807 + 1;", "overflows long", 27),
        ("arg = 1e400;", "out of range for double", 7),
        ("arg = 1e39f;", "out of range for float", 7),
        ("arg = 1e-400;", "too small", 7),
        ("arg = 1e-50f;", "too small", 7),
        ("arg = 9e99999999999;", "out of range", 7),
        ("arg = (int)1e10;", "converts 10000000000.0 to int32_t", 7),
        ("arg = (uint8_t)-1.0;", "converts -1.0 to uint8_t", 7),
        ("r1 = 70000;", "assigns 70000 to r1, outside -32768..65535", 4),
        ("r1 = -40000;", "outside -32768..65535", 4),
        ("r1 = 1e308 * 10;", "assigns inf to r1", 4),
        ("r1 = 0.0 / 0.0;", "assigns nan to r1", 4),
    ],
)
def test_constant_expressions_a_compiler_rejects_are_refused(code, message, col):
    with pytest.raises(FragmentError) as exc:
        compile_fragment(code, 1, True)
    assert message in str(exc.value), str(exc.value)
    assert exc.value.col == col, (str(exc.value), exc.value.col)


def test_unsigned_constants_wrap_as_c_defines_them():
    assert compile_read("arg = 4294967295u + 1u;", 1)([0]) == 0.0
    assert compile_read("arg = 0u - 1u;", 1)([0]) == 4294967295.0
    assert compile_read("arg = (int8_t)300;", 1)([0]) == 44.0
    assert compile_read("arg = 1 << 31;", 1)([0]) == -2147483648.0  # fits the unsigned type: C++14 and gcc agree


@pytest.mark.parametrize(
    "code, message, col",
    [
        ("arg %= 10;", "'%' needs integer operands", 5),
        ("arg <<= 1;", "'<<' needs integer operands", 5),
        ("arg ^= r1;", "'^' needs integer operands", 5),
        ("r1 %= 2.5;", "'%' needs integer operands", 4),
        ("r1 &= arg;", "'&' needs integer operands", 4),
        ("r1 <<= 32;", "shift count 32 is outside 0..31", 4),
        ("r1 /= 0;", "divides by the constant zero", 4),
    ],
)
def test_compound_assignments_are_checked_like_plain_ones(code, message, col):
    with pytest.raises(FragmentError) as exc:
        compile_fragment(code, 1, True)
    assert message in str(exc.value) and exc.value.col == col, (str(exc.value), exc.value.col)


def test_compound_assignments_compute_target_op_value():
    assert compile_read("r1 += 1.5; arg = r1;", 1)([10]) == 11.0
    assert compile_read("arg = 7; arg /= 2;", 1)([0]) == 3.5
    assert compile_read("r1 >>= 2; arg = r1;", 1)([100]) == 25.0


@pytest.mark.parametrize(
    "code",
    [
        "arg = " + "(" * 200 + "r1" + ")" * 200 + ";",
        "arg = " + "- " * 20000 + "r1;",
        "arg = " + "~" * 100 + "r1;",
        "arg = " + " + ".join(["r1"] * 2000) + ";",
        "arg = " + "r1 ? " * 100 + "1" + " : 2" * 100 + ";",
        "arg = " + "(int)" * 100 + "r1;",
    ],
    ids=["parentheses", "minus", "tilde", "sum", "conditional", "casts"],
)
def test_deep_nesting_is_refused_not_a_recursion_error(code):
    with pytest.raises(FragmentError) as exc:
        compile_fragment(code, 1, True)
    assert f"nested more than {MAX_DEPTH} levels" in str(exc.value)


@pytest.mark.parametrize(
    "code",
    [
        "arg = " + "(" * ((MAX_DEPTH - 1) // 2) + "r1" + " * 3 + 1)" * ((MAX_DEPTH - 1) // 2) + ";",
        "arg = " + "(int8_t)(float)" * ((MAX_DEPTH - 1) // 2) + "r1;",
        "arg = " + "(" * (MAX_DEPTH - 1) + "r1" + ")" * (MAX_DEPTH - 1) + ";",
    ],
    ids=["arithmetic", "casts", "parentheses"],
)
def test_the_deepest_accepted_fragments_translate(code):
    fragment = compile_fragment(code, 1, True)
    assert isinstance(compile_read(code, 1)([1]), float)
    assert fragment.c("c").function("f").count("(") > 0


# ---- defined results (docs/fragments.md), in Python; the C functions agree (test above)


@pytest.mark.parametrize(
    "code, regs, expected",
    [
        ("arg = 1000 / r1;", [0], "err EDOM"),
        ("arg = r1 % r2;", [5, 0], "err EDOM"),
        ("arg = ((int)0x80000000 + (int)r1) / ((int)r1 - 1);", [0, 0], "ok " + (-2147483648.0).hex()),
        ("arg = ((int)0x80000000 + (int)r1) % ((int)r1 - 1);", [0, 0], "ok " + (0.0).hex()),
        ("arg = r1 << r2;", [1, 32], "ok " + (0.0).hex()),
        ("arg = r1 << r2;", [1, 31], "ok " + (-2147483648.0).hex()),
        ("arg = (int)(r1 - 1) >> r2;", [0, 40], "ok " + (-1.0).hex()),
        ("arg = (int)(r1 - 1) >> (int)(r2 - 1);", [0, 0], "ok " + (-1.0).hex()),
        ("arg = (unsigned)r1 >> (int)(r2 - 1);", [8, 0], "ok " + (0.0).hex()),
        ("arg = (int)(r1 * 65536.0 * 65536.0);", [1, 0], "err EDOM"),
        ("arg = (int)(r1 * 65536.0 * 32768.0 - 0.5);", [1, 0], "ok " + (2147483647.0).hex()),
        ("arg = (uint16_t)(r1 - 1.5);", [1, 0], "ok " + (0.0).hex()),
        ("arg = (uint16_t)(r1 - 2.0);", [1, 0], "err EDOM"),
        ("arg = (int)(0.0 / r1);", [0, 0], "err EDOM"),
        ("arg = (int)(r1 * 65536 * 32768);", [1, 0], "ok " + (-2147483648.0).hex()),
        ("r1 = r1 * 2; arg = r1;", [40000, 0], "err ERANGE"),
        ("r1 = r1 - 40000; arg = r1;", [7232, 0], "ok " + (32768.0).hex()),
    ],
)
def test_defined_results(code, regs, expected):
    assert python_result(code, True, regs + [0] * (NREGS - len(regs))) == expected


def test_a_write_fragment_refuses_a_register_out_of_range_before_anything_is_sent():
    write = compile_write("r1 = arg * 10;", 1)
    assert write(6553.5) == [65535] and write(-3276.8) == [32768] and write(-0.05) == [0]
    for value in (7000.0, 6553.6, -3276.9, math.nan, math.inf):
        with pytest.raises(OverflowError):
            write(value)
    assert compile_write("r1 = (int16_t)(arg * 10);", 1)(-2.5) == [65511]


def test_float_literals_are_read_as_c_reads_them():
    """Correctly rounded, once: a float literal is not rounded to double first (double rounding)."""
    fragment = compile_read("arg = 1.00000005960464477539062500001f;", 1)
    assert fragment([0]) == struct.unpack("<f", struct.pack("<I", 0x3F800001))[0]


# ---- through the CLI: `mdl validate`, `mdl read` and `mdl write` against `mdl sim`


@pytest.mark.parametrize(
    "code, message",
    [
        ("arg = r1; // x&#13;exit(7);", "read_function_code: unknown identifier 'exit' (column 16)"),
        ("arg = r1 / 0;", "read_function_code: '/' divides by the constant zero (column 10)"),
        ("arg = r1 &lt;&lt; 40;", "read_function_code: shift count 40 is outside 0..31"),
        ("arg = 2147483647 + 1;", "read_function_code: the constant expression overflows int (2147483648) (column 18)"),
        ("arg = 1e400;", "read_function_code: floating literal '1e400' is out of range for double (column 7)"),
        ("arg %= 10;", "read_function_code: '%' needs integer operands (column 5)"),
    ],
)
def test_validate_refuses_with_the_function_and_the_column(write_device, code, message):
    path = write_device(fn_xml("t", "1", format="UINT16", read_function_code=code))
    assert_clean_error(run_mdl("validate", path), 1, f"error: function 't': {message}")


@pytest.mark.commands  # serves or dials a device
def test_mdl_read_names_the_function_whose_fragment_fails_on_the_devices_data(write_device, sim_factory):
    path = write_device(fn_xml("ratio", "10", format="UINT16", read_function_code="arg = 1000 / r1;"))
    sim = sim_factory(path)  # the register holds 0
    proc = run_mdl("read", path, *sim.connection, "ratio")
    assert_clean_error(proc, 1, "function 'ratio': read_function_code: divides the integer 1000 by zero")
    assert proc.stdout == ""


@pytest.mark.commands  # serves or dials a device
def test_mdl_write_refuses_a_register_value_out_of_range_before_sending(write_device, sim_factory):
    path = write_device(
        fn_xml(
            "setpoint",
            "20",
            format="UINT16",
            read_function_code="arg = r1 / 10.0;",
            write_function_code="r1 = arg * 10;",
        )
    )
    sim = sim_factory(path, "--set", "setpoint=21.5")
    proc = run_mdl("write", path, *sim.connection, "setpoint=7000")
    assert_clean_error(proc, 1, "setpoint=7000: write_function_code: assigns 70000.0 to r1, outside -32768..65535")
    proc = run_mdl("read", path, *sim.connection, "setpoint", "--format", "json")
    assert json.loads(proc.stdout) == {"setpoint": 21.5}  # the device got nothing
    assert run_mdl("write", path, *sim.connection, "setpoint=6553.5").returncode == 0
    proc = run_mdl("read", path, *sim.connection, "setpoint", "--format", "json")
    assert json.loads(proc.stdout) == {"setpoint": 6553.5}
