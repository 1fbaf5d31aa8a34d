"""Fuzzing the C fragment subset (docs/fragments.md): random fragments from a grammar of the subset,
and junk text, through the checker, the Python translation and the C emitter.

Every text is accepted or refused with a FragmentError naming a column, never another exception;
an accepted fragment's Python translation, run on random registers (or values written), returns a
value or raises only the documented errors; and the C functions of all accepted fragments, in ONE
gcc program built with UBSan and -Werror (tests/unit/dsl/cfrag/test_cfrag.py's CBatch), compile without a warning,
run without a UBSan report and give the Python translation's results bit for bit, errno included;
clang finds nothing in them either, and their C++ functions compile under g++ and clang++ without
a warning.
"""

from __future__ import annotations

import random
import subprocess

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mdl.dsl.cfrag import FragmentError, compile_fragment
from support.cpp_harness import tool
from support.fragments import (
    C99_STRICT,
    CPP_STRICT,
    NREGS,
    WRITE_SPECIALS,
    CBatch,
    cpp_unit,
    disagreements,
    python_result,
    register_samples,
)

LEAVES = [
    "r1",
    "r2",
    "r3",
    "r4",
    "arg",
    "0",
    "1",
    "2",
    "3",
    "7",
    "10",
    "15",
    "16",
    "31",
    "32",
    "33",
    "63",
    "64",
    "100",
    "255",
    "256",
    "1000",
    "32767",
    "32768",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "0x7FFFFFFF",
    "0x80000000",
    "0xFFFFFFFF",
    "0xffffffffu",
    "4294967295u",
    "1u",
    "0u",
    "5l",
    "7L",
    "3ul",
    "9223372036854775807",
    "0x8000000000000000",
    "0xFFFFFFFFFFFFFFFF",
    "1ull",
    "0.5",
    "0.1",
    "1.5f",
    "0.1f",
    "3.4e38f",
    "1e-45f",
    "1e308",
    "2.5e-308",
    ".5",
    "1.",
    "1e10",
    "1e-3f",
    "0.0",
    "1e19",
    "-0.0",
    "65535.5",
]
PREFIXES = [
    "-",
    "- ",
    "+",
    "~",
    "!",
    "(int8_t)",
    "(uint8_t)",
    "(int16_t)",
    "(uint16_t)",
    "(int32_t)",
    "(uint32_t)",
    "(int64_t)",
    "(uint64_t)",
    "(int)",
    "(unsigned)",
    "(float)",
    "(double)",
]
BINARY = ["+", "-", "*", "/", "%", "<<", ">>", "&", "|", "^", "&&", "||", "==", "!=", "<", ">", "<=", ">="]
ASSIGN = ["=", "=", "=", "+=", "-=", "*=", "/=", "%=", "<<=", ">>=", "&=", "|=", "^="]
TARGETS = ["arg", "arg", "r1", "r2", "r3", "r4"]
JUNK = [
    "arg",
    "r1",
    "r5",
    "r0",
    "=",
    ";",
    "(",
    ")",
    "{",
    "}",
    "#",
    '"',
    "'",
    "\\",
    "//",
    "/*",
    "*/",
    "\n",
    "\r",
    "\r\n",
    "\v",
    "\f",
    "\t",
    " ",
    "\u2028",
    "\x85",
    "\u00a0",
    "exit",
    "(7)",
    "0x",
    "1e",
    "e+",
    "1.2.3",
    "08",
    "1f",
    "1lL",
    "?",
    ":",
    "++",
    "--",
    "<<=",
    "sizeof",
    "long",
    "double",
    "\u0663",
    "x",
    ",",
    "[0]",
    "->",
    ".",
]

INTEGER_LEAVES = [leaf for leaf in LEAVES if leaf[0] == "r" or leaf.isdigit()]
expressions = st.recursive(
    st.one_of(st.sampled_from(INTEGER_LEAVES), st.sampled_from(LEAVES)),
    lambda inner: st.one_of(
        st.builds("({})".format, inner),
        st.builds("{}{}".format, st.sampled_from(PREFIXES), inner),
        st.builds("{} {} {}".format, inner, st.sampled_from(BINARY), inner),
        st.builds("{} ? {} : {}".format, inner, inner, inner),
    ),
    max_leaves=10,
)
statements = st.builds("{} {} {};".format, st.sampled_from(TARGETS), st.sampled_from(ASSIGN), expressions)
fragments = st.lists(statements, min_size=1, max_size=4).map(" ".join)
commented = st.builds(
    "{} /* {} */ {} // {}\n".format,
    fragments,
    st.sampled_from(["note", "x = 1;", "a\rb"]),
    fragments,
    st.sampled_from(["tenths", "x\rexit(7);", "y\r\nr1 = 0;"]),
)
junk = st.one_of(st.text(max_size=60), st.lists(st.sampled_from(JUNK + LEAVES + BINARY), max_size=30).map("".join))
texts = st.one_of(*[fragments] * 6, commented, junk)


@pytest.mark.compile  # it compiles what it accepts (gcc)
@pytest.mark.exhaustive  # a fuzzer: CI runs it
def test_fragments_are_refused_cleanly_or_agree_in_python_and_c(tmp_path):
    rng = random.Random(2024)
    registers = register_samples(rng, 24)
    values = WRITE_SPECIALS + [round(rng.uniform(-1e5, 1e5), rng.choice([0, 1, 3])) for _ in range(8)]
    accepted: dict[tuple[str, bool], None] = {}

    @settings(
        max_examples=3000,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(texts, st.booleans())
    def check(code: str, reading: bool) -> None:
        try:
            fragment = compile_fragment(code, NREGS, reading)
        except FragmentError as exc:
            event("refused")
            assert exc.col is not None and 1 <= exc.col <= len(code) + 1, (code, str(exc), exc.col)
            return
        event("accepted")
        fragment.c("c").function("f")
        fragment.c("c++").function("f")
        for given_ in registers if reading else values:
            event(python_result(code, reading, given_).split()[0])  # a value, or a documented error
        accepted[(code, reading)] = None

    check()
    codes = list(accepted)
    print(
        f"fragment fuzz: {len(codes)} distinct fragments accepted; C and Python compared on "
        f"{len(registers)} register sets or {len(values)} values each"
    )
    assert len(codes) > 300, len(codes)
    batch = CBatch(codes, tmp_path)
    cases = [(i, given_) for i, (_, reading) in enumerate(codes) for given_ in (registers if reading else values)]
    wrong = disagreements(batch, cases)
    assert wrong == [], wrong[:10]
    proc = subprocess.run(
        [tool("clang"), *C99_STRICT, "-fsyntax-only", str(batch.source)], capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, ("clang", proc.stderr[-3000:])
    source = tmp_path / "fragments.cc"  # the same functions as C++, as the C++ driver compiles them
    source.write_text(cpp_unit(codes))
    for compiler in ("g++", "clang++"):
        proc = subprocess.run(
            [tool(compiler), *CPP_STRICT, "-fsyntax-only", str(source)], capture_output=True, text=True, timeout=600
        )
        assert proc.returncode == 0, (compiler, proc.stderr[-3000:])
