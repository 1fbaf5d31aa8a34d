"""Hostile input for `mdl gen` (issues 27 and 28): text that would hide code or break the strict builds,
device names too long for a file name, runs killed halfway, and enumerations at the 64-bit edges.

Every case goes through the CLI and, for the C and C++ drivers, through the compilers with the strict
flags of SPEC 5 and the docs (cpp_harness.STRICT, c_harness.STRICT), both compilers of each language.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from mdl.formats.mdl import load_device
from mdl.model.names import STEM_LIMIT
from support.c_harness import STRICT as C_STRICT
from support.c_harness import build as build_c
from support.common import DATA, MDL_NS, fn_xml, import_generated
from support.cpp_harness import STRICT as CPP_STRICT
from support.cpp_harness import Harness, modbus_flags, tool
from support.cpp_harness import build as build_cpp
from support.run import assert_clean_error, cli, mdl_cmd, run_mdl

INT64_MIN, INT64_MAX, UINT64_MAX = -(2**63), 2**63 - 1, 2**64 - 1
# what gcc's -Wbidi-chars looks for, and the other characters that hide what a reader sees
BIDI = "\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069\u200e\u200f\u061c"
HIDDEN = BIDI + "\u200b\u200c\u200d\u2060\ufeff\u00ad\u2028\u2029\x85"
WISE = DATA / "wise" / "agent_datatypes.ini"
COMPILERS = {".cc": (("g++", "clang++"), CPP_STRICT), ".c": (("gcc", "clang"), C_STRICT)}


def xml_text(text: str) -> str:
    """Text for an element of a US-ASCII MDL document: character references for the rest."""
    return "".join(ch if 0x20 <= ord(ch) < 0x7F and ch not in "<>&'\"" else f"&#x{ord(ch):X};" for ch in text)


def document(functions: str, name: str = "Edge Device", description: str = "edges") -> str:
    return (
        f'<?xml version="1.0" encoding="US-ASCII"?>\n<device xmlns="{MDL_NS}" version="1.0">\n'
        f"  <name>{xml_text(name)}</name>\n  <description>{xml_text(description)}</description>\n"
        f"{functions}</device>\n"
    )


def expression_fn(name: str, expression: str, description: str = "", units: str = "") -> str:
    """An expression function: its text escaped for XML (labels in single quotes may hold anything)."""
    units_xml = f"    <units>{xml_text(units)}</units>\n" if units else ""
    return (
        f"  <function>\n    <name>{xml_text(name)}</name>\n"
        f"    <description>{xml_text(description or name)}</description>\n    <addresses></addresses>\n"
        f"{units_xml}    <expression>{xml_text(expression)}</expression>\n  </function>\n"
    )


def quoted(label: str) -> str:
    """A label as an expression's single-quoted text (which has no escapes: it cannot hold a quote)."""
    assert "'" not in label
    return f"'{label}'"


def enum(registers: str, mapping: dict[int, str]) -> str:
    return f"enum({registers} ; " + "; ".join(f"{k} -> {quoted(v)}" for k, v in mapping.items()) + ")"


def gen(source: Path, outdir: Path, *args: str):
    proc = cli("gen", source, "--lang", "all", "-o", outdir, *args)
    assert proc.returncode == 0, proc.stderr
    return proc


def compile_file(source: Path, compiler: str, flags: list[str], *extra: str) -> subprocess.CompletedProcess[str]:
    cflags, _ = modbus_flags()
    return subprocess.run(
        [tool(compiler), *flags, *cflags, *extra, "-c", str(source), "-o", os.devnull],
        capture_output=True,
        text=True,
        timeout=600,
    )


def assert_builds(outdir: Path, stem: str) -> None:
    """<stem>.cc and <stem>.c compile without a warning with both compilers of their language."""
    for suffix, (compilers, flags) in COMPILERS.items():
        for compiler in compilers:
            proc = compile_file(outdir / f"{stem}{suffix}", compiler, flags)
            assert proc.returncode == 0, f"{compiler}: {proc.stderr[:3000]}"


def assert_no_hidden_text(outdir: Path) -> None:
    for path in outdir.iterdir():
        text = path.read_text(encoding="utf-8")
        found = sorted({f"U+{ord(ch):04X}" for ch in text if ch in HIDDEN or (ord(ch) < 0x20 and ch != "\n")})
        assert not found, f"{path.name} holds {found}"


# ---- text that hides code: bidirectional controls and invisible characters ----


def test_hidden_characters_reach_no_generated_file_and_labels_keep_them(tmp_path, sim_factory):
    trojan = "ok \u202e }; evil(); /* \u2066x\u2069 \u200b\ufeff\u2028end\u00ad"
    source = tmp_path / "trojan.xml"
    source.write_text(
        document(
            fn_xml("Raw", "0", format="UINT16", units=xml_text("\u200f%")).replace(
                "<description>Raw</description>", f"<description>{xml_text(trojan)}</description>"
            )
            + expression_fn("Mode" + "\u202e", enum("hr:0", {1: "a\u202eb", 2: trojan}), trojan, "\u2067s"),
            name="Trojan\u202e Device",
            description=trojan,
        ),
        encoding="ascii",
    )
    out = tmp_path / "out"
    gen(source, out)
    stem = "trojan_device"
    assert_no_hidden_text(out)
    assert "<U+202E>" in (out / f"{stem}.h").read_text(encoding="utf-8")  # said, not dropped
    assert_builds(out, stem)
    subprocess.run([sys.executable, "-m", "py_compile", str(out / f"{stem}.py")], check=True)
    # the labels are values: every driver reads them as written
    device = load_device(source)
    sim = sim_factory(source, "--set", "Raw=1")
    exes = [build_cpp(device, _mkdir(tmp_path / "cpp")), build_c(device, _mkdir(tmp_path / "c"))]
    for exe in exes:
        with Harness(exe, sim.port) as h:
            assert h.values()["Mode\u202e"] == "a\u202eb"
    assert python_read_all(out / f"{stem}.py", "TrojanDevice", sim)["Mode\u202e"] == "a\u202eb"


def python_read_all(module_path: Path, class_name: str, sim) -> dict:
    """read_all() of the generated Python driver over a pymodbus client."""
    module = import_generated(module_path, f"{module_path.stem}_driver")
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        values: dict = getattr(module, class_name)(client, unit=1).read_all()
        return values
    finally:
        client.close()


def _mkdir(path: Path) -> Path:
    path.mkdir()
    return path


# ---- device names too long for a file name ----


def _wise_with_name(tmp_path: Path, name: str, file: str) -> Path:
    ini = tmp_path / f"{file}.ini"
    ini.write_text(WISE.read_text(encoding="utf-8").replace("Name=Datatype Meter", f"Name={name}"), encoding="utf-8")
    xml = tmp_path / f"{file}.xml"
    proc = cli("import", ini, "-o", xml)
    assert proc.returncode == 0, proc.stderr
    return xml


def test_a_301_character_wise_name_gets_a_short_unique_deterministic_stem(tmp_path):
    long_name = ("Very Long Platform Name " * 13)[:300] + "A"
    assert len(long_name) == 301
    first = _wise_with_name(tmp_path, long_name, "first")
    other = _wise_with_name(tmp_path, long_name[:-1] + "B", "other")
    out = tmp_path / "out"
    proc = gen(first, out)
    files = sorted(p.name for p in out.iterdir())
    stem = files[0].rsplit(".", 1)[0]
    assert len(stem) <= STEM_LIMIT and stem.startswith("very_long_platform_name_very")
    assert files == sorted(f"{stem}.{ext}" for ext in ("py", "h", "cc", "c"))
    assert re.search(
        rf"note: .*longer than {STEM_LIMIT} characters: the generated files are named {stem}\.\*", proc.stderr
    )
    again = gen(first, out)
    assert "wrote" not in again.stderr  # the same name, the same files, byte for byte
    gen(other, out)
    assert len(list(out.iterdir())) == 8, "two names that differ only at their end share a stem"
    assert_builds(out, stem)


# ---- half generations ----


def _stamps(outdir: Path, stem: str) -> dict[str, str]:
    found = {}
    for suffix in (".h", ".cc", ".c"):
        path = outdir / f"{stem}{suffix}"
        if path.exists():
            found[suffix] = re.findall(r"GENERATION (?:!= )?(0x[0-9a-f]+)", path.read_text(encoding="utf-8"))[0]
    return found


def _preprocess(outdir: Path, stem: str) -> dict[tuple[str, str], subprocess.CompletedProcess[str]]:
    """Each source preprocessed with each compiler of its language: where a mixed generation stops."""
    return {
        (suffix, compiler): compile_file(outdir / f"{stem}{suffix}", compiler, flags[:1], "-E")
        for suffix, (compilers, flags) in COMPILERS.items()
        for compiler in compilers
    }


def test_a_source_and_a_header_of_different_runs_refuse_to_build(tmp_path):
    source = tmp_path / "dev.xml"
    functions = fn_xml("a", "0", format="UINT16") + fn_xml("b", "1", format="INT32")
    old, new = tmp_path / "old", tmp_path / "new"
    source.write_text(document(functions, "Mixed", "first"), encoding="ascii")
    gen(source, old)
    source.write_text(document(functions, "Mixed", "second"), encoding="ascii")
    gen(source, new)
    assert _stamps(old, "mixed")[".h"] != _stamps(new, "mixed")[".h"]
    for header_from, source_from in ((new, old), (old, new)):
        mixed = _mkdir(tmp_path / f"mixed_{header_from.name}_h")
        (mixed / "mixed.h").write_bytes((header_from / "mixed.h").read_bytes())
        for suffix in (".cc", ".c"):
            (mixed / f"mixed{suffix}").write_bytes((source_from / f"mixed{suffix}").read_bytes())
        for (suffix, compiler), proc in _preprocess(mixed, "mixed").items():
            assert proc.returncode != 0, f"{compiler} built a mixed generation"
            assert f"mixed.h and mixed{suffix} come from different runs of mdl gen" in proc.stderr, proc.stderr
            assert "run mdl gen again" in proc.stderr
    assert_builds(new, "mixed")
    for lang, suffix in (("cpp", ".cc"), ("c", ".c")):  # one language alone has a stamp of its own
        alone = tmp_path / lang
        assert cli("gen", source, "--lang", lang, "-o", alone).returncode == 0
        assert _stamps(alone, "mixed")[".h"] == _stamps(alone, "mixed")[suffix] != _stamps(new, "mixed")[".h"]


def _big_document(description: str, functions: int = 1000) -> str:
    body = "".join(fn_xml(f"v{i}", str(i), format="UINT16") for i in range(functions))
    return document(body, "Big", description)


def _hidden(outdir: Path) -> list[str]:
    return sorted(name for name in os.listdir(outdir) if name.startswith("."))


def test_sigkill_during_gen_all_never_builds_a_mixed_generation(tmp_path):
    """Runs of `mdl gen --lang all` killed (SIGKILL) at several moments: before any file is written, while
    the temporary files are written, once the old files have second names, once the first file is
    renamed into place, at the end.
    Whatever state a kill leaves, every visible file is one generation's whole file, a source with a
    header of another generation does not build, and the next run cleans up and finishes the job."""
    old_src, new_src = tmp_path / "old.xml", tmp_path / "new.xml"
    old_src.write_text(_big_document("old"), encoding="ascii")
    new_src.write_text(_big_document("new"), encoding="ascii")
    refs = {}
    for src in (old_src, new_src):
        gen(src, tmp_path / f"ref_{src.stem}")
        refs[src.stem] = {p.name: p.read_bytes() for p in (tmp_path / f"ref_{src.stem}").iterdir()}
    moments = ["start", ".tmp", ".cc.", ".old", "renamed", "end"]
    seen_states = set()
    for moment in moments:
        out = tmp_path / f"kill_{moment.strip('.')}"
        gen(old_src, out)
        proc = subprocess.Popen(
            mdl_cmd("gen", new_src, "--lang", "all", "-o", out), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        first = (out / "big.py").stat().st_ino  # the first file the renames replace
        try:
            while moment != "start" and proc.poll() is None:
                if moment == "renamed" and (out / "big.py").stat().st_ino != first:
                    break
                if moment not in ("end", "renamed") and any(moment in name for name in _hidden(out)):
                    break
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
        files = {name: (out / name).read_bytes() for name in os.listdir(out) if not name.startswith(".")}
        state = []
        for name, data in sorted(files.items()):
            which = [gen_name for gen_name, ref in refs.items() if ref.get(name) == data]
            assert which, f"{name} is neither generation's whole file after a kill at {moment}"
            state.append(which[0])
        seen_states.add(tuple(state))
        stamps = _stamps(out, "big")
        for (suffix, compiler), result in _preprocess(out, "big").items():
            if stamps[suffix] == stamps[".h"]:
                assert result.returncode == 0, f"{compiler}: {result.stderr[:2000]}"
            else:
                assert "come from different runs of mdl gen" in result.stderr, f"{compiler}: {result.stderr[:2000]}"
        gen(new_src, out)  # the next run: every file new, and nothing hidden left
        assert _hidden(out) == []
        assert {p.name: p.read_bytes() for p in out.iterdir()} == refs["new"]
    assert ("old",) * 4 in seen_states  # killed at the start; the other moments depend on timing


def test_only_mdl_s_own_leftovers_are_removed_and_check_removes_none(tmp_path):
    source = tmp_path / "dev.xml"
    source.write_text(document(fn_xml("a", "0", format="UINT16"), "Left"), encoding="ascii")
    out = _mkdir(tmp_path / "out")
    ours = [".left.h.0123456789ab.tmp", ".left.cc.a1b2c3d4e5f6.old", ".left.py.ffffffffffff.tmp"]
    theirs = [
        ".left.h.0123456789ab.tmp.keep",
        ".left.h.xyz.tmp",
        ".other.h.0123456789ab.tmp",
        "left.h.0123456789ab.tmp",
        ".left.h.0123456789AB.tmp",
        ".left.hh.0123456789ab.tmp",
    ]
    for name in ours + theirs:
        (out / name).write_text("x")
    assert cli("gen", source, "--lang", "all", "-o", out, "--check").returncode == 1
    assert set(ours) <= set(os.listdir(out))  # --check writes nothing, removes nothing
    gen(source, out)
    left = set(os.listdir(out))
    assert not set(ours) & left and set(theirs) <= left


# ---- enumerations at the 64-bit edges, and texts longer than a literal may be ----

EDGE_KEYS = [INT64_MIN, INT64_MIN + 1, -1, 0, 1, INT64_MAX - 1, INT64_MAX]
LONG_LABELS = {  # bytes of UTF-8 around each language's string literal limit (templating.STRING_LIMIT)
    "c_limit": "L" * 4095,
    "c_over": "M" * 4096,
    "audit": "N" * 5003,
    "multibyte": "\u00e9" * 2500 + '"\\??/*/',
    "cpp_limit": "P" * 65536,
    "cpp_over": "Q" * 65537,
}


def _words(value: int) -> list[int]:
    raw = value & UINT64_MAX
    return [(raw >> shift) & 0xFFFF for shift in (48, 32, 16, 0)]


def _edge_document(tmp_path: Path) -> tuple[Path, dict[str, str], dict[str, int]]:
    """A document of enums over 4 registers each, one per edge key, each mapping every edge key (the
    labels long ones); and the raw registers (sim --registers) that make each read its own key."""
    labels = list(LONG_LABELS.values())
    mapping = {k: f"{labels[i % len(labels)]}#{k}" for i, k in enumerate(EDGE_KEYS)}
    functions, expected, holding = "", {}, {}
    for i, key in enumerate(EDGE_KEYS):
        regs = ", ".join(f"hr:{4 * i + j}" for j in range(4))
        functions += expression_fn(f"e{i}", enum(regs, mapping))
        expected[f"e{i}"] = mapping[key]
        holding.update({str(4 * i + j): w for j, w in enumerate(_words(key))})
    base = 4 * len(EDGE_KEYS)
    functions += expression_fn(
        "flag", f"boolean(c:0 ; {quoted(LONG_LABELS['audit'])} ; {quoted(LONG_LABELS['cpp_over'])})"
    )
    functions += expression_fn("text", f"concat({quoted(LONG_LABELS['c_over'])}, uint16(hr:{base + 1}))")
    functions += expression_fn(
        "bits",
        f"bitset(hr:{base + 2} ; 0 -> {quoted(LONG_LABELS['multibyte'])}; "
        f"{INT64_MIN} -> 'never'; {INT64_MAX} -> 'never')",
    )
    holding.update({str(base + 1): 7, str(base + 2): 1})
    expected.update(
        {"flag": LONG_LABELS["audit"], "text": LONG_LABELS["c_over"] + "7", "bits": [LONG_LABELS["multibyte"]]}
    )
    source = tmp_path / "edges.xml"
    source.write_text(document(functions, "Edges"), encoding="ascii")
    raw = tmp_path / "raw.json"
    raw.write_text(json.dumps({"holding": holding, "coil": {"0": 0}}))
    return source, expected, raw


def test_enum_keys_at_the_int64_edges_and_long_labels_build_and_read_in_every_target(tmp_path, sim_factory):
    source, expected, raw = _edge_document(tmp_path)
    out = tmp_path / "out"
    gen(source, out)
    assert_builds(out, "edges")
    cc = (out / "edges.cc").read_text(encoding="utf-8")
    assert "(-INT64_C(9223372036854775807) - 1)" in cc and "INT64_C(9223372036854775808)" not in cc
    assert "INT64_C(-9223372036854775808)" not in cc
    for suffix, limit in ((".cc", 65536), (".c", 4095), (".h", 4095)):
        longest = max(_literal_lengths((out / f"edges{suffix}").read_text(encoding="utf-8")), default=0)
        assert longest <= limit, f"a string literal of {longest} characters in edges{suffix}"
    device = load_device(source)
    sim = sim_factory(source, "--registers", raw)
    for exe in (build_cpp(device, _mkdir(tmp_path / "cpp")), build_c(device, _mkdir(tmp_path / "c"))):
        with Harness(exe, sim.port) as h:
            assert h.values() == expected
    assert python_read_all(out / "edges.py", "Edges", sim) == expected
    read = run_mdl("read", source, *sim.connection, "--format", "json")  # mdl's own runtime alike
    assert read.returncode == 0, read.stderr
    assert json.loads(read.stdout) == expected


@pytest.mark.parametrize(
    ("key", "hint"),
    [
        (INT64_MIN - 1, ""),
        (INT64_MAX + 1, ": as 64 bits, write -9223372036854775808"),
        (UINT64_MAX, ": as 64 bits, write -1"),
        ("0xFFFFFFFFFFFFFFFF", ": as 64 bits, write -1"),
        ("-0x8000000000000001", ""),
    ],
)
def test_validate_refuses_enum_keys_outside_int64_at_their_position(tmp_path, key, hint):
    source = tmp_path / "keys.xml"
    prefix = "enum(hr:0, hr:1, hr:2, hr:3 ; 1 -> 'one'; "
    source.write_text(document(expression_fn("e", f"{prefix}{key} -> 'x')")), encoding="ascii")
    lines = source.read_text().splitlines()
    line = next(i for i, text in enumerate(lines, 1) if "<expression>" in text)
    col = lines[line - 1].index("<expression>") + len("<expression>") + len(xml_text(prefix)) + 1
    value = int(str(key), 0)
    for command in ("validate", "gen"):
        proc = cli(command, source, *(["-o", tmp_path / "out"] if command == "gen" else []))
        assert_clean_error(
            proc,
            1,
            f"{source}:{line}:{col}: error: function 'e': expression: mapped value "
            f"{value} is outside int64 (-9223372036854775808..9223372036854775807){hint}",
        )
    assert not (tmp_path / "out").exists()


def test_toolkit_yaml_enum_key_below_int64_is_refused_at_its_position(tmp_path):
    source = tmp_path / "edge.yaml"
    source.write_text(
        "description: 'edges'\nblocks:\n  - id: 'S'\n    description: 'block'\n    fields:\n"
        "      - id: 'Mode'\n        description: 'mode'\n"
        "        expression: \"enum(hr:0 ; -9223372036854775809 -> 'x')\"\n",
        encoding="utf-8",
    )
    proc = cli("import", source, "-o", tmp_path / "edge.xml")
    assert_clean_error(
        proc, 1, f"{source}:8:34: error: field 'Mode' of block 'S': mapped value -9223372036854775809 is outside int64"
    )
    assert not (tmp_path / "edge.xml").exists()


# ---- fuzz: the integer edges and long or hostile labels, in every target ----
# budgets: MDL_FUZZ_GEN (documents generated, 60) and MDL_FUZZ_GEN_BUILDS (documents compiled, 2)
SLOW = [HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large]

EDGES = [INT64_MIN, INT64_MIN + 1, -1, 0, 1, INT64_MAX - 1, INT64_MAX]
OUTSIDE = [INT64_MIN - 1, INT64_MAX + 1, UINT64_MAX - 1, UINT64_MAX]
label_text = st.one_of(
    st.text(alphabet=st.sampled_from(list('ab"\\?*/ \t%\u00e9\u20ac\U0001f600' + HIDDEN)), max_size=12),
    st.builds(
        lambda ch, n: ch * n,
        st.sampled_from(["x", "\u00e9", "?", "\\", "\u202e"]),
        st.sampled_from([4094, 4095, 4096, 5003, 21846, 65536, 65537]),
    ),
)
enum_mapping = st.dictionaries(
    st.sampled_from(EDGES) | st.integers(INT64_MIN, INT64_MAX), label_text, min_size=1, max_size=8
)


def _literal_lengths(text: str) -> list[int]:
    """The length of every string literal in C or C++ code, in bytes, as the compiler counts them (an
    escape is one byte; a character constant such as '"' starts none)."""
    text = re.sub(r"'(?:[^'\\\n]|\\[0-7]{1,3}|\\.)'", "0", text)
    return [len(re.sub(r"\\(?:[0-7]{1,3}|.)", "x", m)) for m in re.findall(r'"((?:[^"\\\n]|\\.)*)"', text)]


@settings(max_examples=int(os.environ.get("MDL_FUZZ_GEN", "60")), deadline=None, suppress_health_check=SLOW)
@given(mappings=st.lists(enum_mapping, min_size=1, max_size=3), outside=st.sampled_from(OUTSIDE) | st.none())
def test_fuzz_enum_edges_generate_within_every_language_s_limits(tmp_path_factory, mappings, outside):
    """Keys inside int64 generate (every literal within its language's limit, nothing hidden); one
    outside is refused with its position, and nothing is written. Compiling is the next test's."""
    tmp = tmp_path_factory.mktemp("fuzz")
    functions = "".join(expression_fn(f"e{i}", enum("hr:0, hr:1, hr:2, hr:3", m)) for i, m in enumerate(mappings))
    if outside is not None:
        functions += expression_fn("bad", enum("hr:4", {outside: "x"}))
    source = tmp / "fuzz.xml"
    source.write_text(document(functions, "Fuzz"), encoding="ascii")
    out = tmp / "out"
    proc = cli("gen", source, "-o", out)
    if outside is not None:
        assert_clean_error(proc, 1, f"mapped value {outside} is outside int64")
        assert not out.exists()
        return
    assert proc.returncode == 0, proc.stderr
    assert_no_hidden_text(out)
    for suffix, limit in ((".cc", 65536), (".c", 4095), (".h", 4095)):
        assert max(_literal_lengths((out / f"fuzz{suffix}").read_text(encoding="utf-8")), default=0) <= limit
    compile((out / "fuzz.py").read_text(encoding="utf-8"), "fuzz.py", "exec")


@settings(max_examples=int(os.environ.get("MDL_FUZZ_GEN_BUILDS", "2")), deadline=None, suppress_health_check=SLOW)
@given(mappings=st.lists(enum_mapping, min_size=4, max_size=8))
def test_fuzz_enum_edges_compile_strictly_in_every_target(tmp_path_factory, mappings):
    """Many enums of fuzzed keys and labels in one document: one strict compile per compiler."""
    tmp = tmp_path_factory.mktemp("fuzzbuild")
    functions = "".join(expression_fn(f"e{i}", enum("hr:0, hr:1, hr:2, hr:3", m)) for i, m in enumerate(mappings))
    functions += expression_fn(
        "bits", "bitset(hr:4 ; " + "; ".join(f"{k} -> {quoted(v)}" for m in mappings[:1] for k, v in m.items()) + ")"
    )
    source = tmp / "fuzz.xml"
    source.write_text(document(functions, "Fuzz"), encoding="ascii")
    gen(source, tmp / "out")
    assert_builds(tmp / "out", "fuzz")
