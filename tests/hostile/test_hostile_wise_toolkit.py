"""Hostile input to the WISE-Agent Modbus.ini and Modbus Schema Toolkit YAML readers (issues 27, 28).

Issue 28: a WISE entry is read as the agent reads it, split at every comma (quotes are not special), so a
name holding `"` no longer swallows the line and silently turns a FLOAT32 into a UINT16; where the agent's
C strtok would read fields in other columns than mdl (an empty field, a Lua column cut at a comma), the
line is refused with its position. Issue 27: time and memory are bounded (a file-size limit, a limit on
entries, one Evaluator for all of a file's scenarios, dependency errors found in linear time) and
repeated diagnostics are summed up, never a traceback. Every case runs through the CLI."""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import struct
import subprocess
from pathlib import Path

import pytest

from mdl.exchange.yamlnodes import MAX_FILE_BYTES as YAML_LIMIT
from mdl.formats.wise.read import MAX_ENTRIES, MAX_FILE_BYTES, SHOWN_PER_KIND
from support.run import assert_clean_error, cli, mdl_cmd

MEMORY_CAP = 1 << 30
HANG_GUARD = 120  # seconds: only stops a hang from eating the machine; no test asserts a speed


def run_capped(*args: object, input: bytes | None = None) -> subprocess.CompletedProcess[str]:
    """`mdl ARGS` as a user runs it, with 1 GB of address space (a regression to unbounded memory fails)."""

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))

    proc = subprocess.run(
        mdl_cmd(*args),
        input=input,
        capture_output=True,
        timeout=HANG_GUARD,
        preexec_fn=cap,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
    return subprocess.CompletedProcess(proc.args, proc.returncode, proc.stdout.decode(), proc.stderr.decode())


def wise(tmp_path: Path, body: str, name: str = "Modbus.ini") -> Path:
    """A Modbus.ini whose body starts on line 3."""
    ini = tmp_path / name
    ini.write_text("[Platform]\nName=Hostile\n" + body)
    return ini


def raw_file(tmp_path: Path, tables: dict) -> Path:
    path = tmp_path / "raw.json"
    path.write_text(json.dumps({t: {str(a): v for a, v in regs.items()} for t, regs in tables.items()}))
    return path


# --- issue 28: the agent's comma split ---------------------------------------------------------------------


def test_a_quote_in_a_name_reads_the_columns_the_agent_reads(tmp_path, sim_factory):
    """`R0=0,Temp "a,0,100,0.1,C,1`: the agent's strtok gives the name `Temp "a` and a FLOAT32 (datatype 1)
    scaled by 0.1 in C, 0..100; mdl reads the same registers the same way."""
    ini = wise(tmp_path, '[Holding Registers]\nnumberOfR=1\nR0=0,Temp "a,0,100,0.1,C,1\n')
    out = tmp_path / "q.xml"
    proc = cli("import", ini, "-o", out)
    assert proc.returncode == 0, proc.stderr
    text = out.read_text()
    assert re.search(r"<name>Temp &quot;a</name>|<name>Temp \"a</name>", text), text
    for element in (
        "<format>FLOAT32</format>",
        "<multiplier>0.1</multiplier>",
        "<units>C</units>",
        "<minimum>0</minimum>",
        "<maximum>100</maximum>",
    ):
        assert element in text, (element, text)
    regs = struct.unpack(">HH", struct.pack(">f", 512.0))
    sim = sim_factory(ini, "--registers", raw_file(tmp_path, {"holding": {0: regs[0], 1: regs[1]}}))
    proc = cli("read", ini, *sim.connection, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {'Temp "a': pytest.approx(51.2)}


def test_a_name_with_quotes_generates_drivers(tmp_path):
    """A name holding `"`, a backslash and a comment's end becomes an identifier by SPEC 3 (`temp_a_b_x`); the
    Python driver compiles, and so do the C and C++ sources, which hold the name in comments."""
    ini = wise(tmp_path, '[Holding Registers]\nnumberOfR=1\nR0=0,Temp "a\\b */ x,0,100,0.1,C,1\n')
    gen = tmp_path / "gen"
    proc = cli("gen", ini, "--lang", "all", "-o", gen)
    assert proc.returncode == 0, proc.stderr
    py = next(gen.glob("*.py"))
    compile(py.read_text(), str(py), "exec")
    assert "temp_a_b_x" in py.read_text()
    if shutil.which("pkg-config") is None or shutil.which("g++") is None or shutil.which("gcc") is None:
        pytest.skip("no C/C++ compiler or pkg-config")
    flags = subprocess.run(["pkg-config", "--cflags", "libmodbus"], capture_output=True, text=True).stdout.split()
    for compiler, source in (("g++", "*.cc"), ("gcc", "*.c")):
        done = subprocess.run(
            [compiler, "-fsyntax-only", *flags, str(next(gen.glob(source)))],
            capture_output=True,
            text=True,
            timeout=HANG_GUARD,
        )
        assert done.returncode == 0, done.stderr


@pytest.mark.parametrize(
    "line, col, fragment",
    [
        ("R0=0,T,,,0.1,C,1", 8, "R0: the min field is empty: the agent (C strtok) skips an empty field"),
        ("R0=0,T,0,100,,C,1", 14, "R0: the precision field is empty"),
        ("R0=,T,0,100,1,C,1", 4, "R0: the offset field is empty"),
        ('R0=0,T,0,100,1,V,,"modbus_val*2"', 18, "R0: the datatype field is empty"),
        (
            'R0=0,T,0,9,1,V,0,"modbus_val*2,5"',
            18,
            "R0: the agent runs 'modbus_val*2' as this line's Lua conversion (the column up to its first comma",
        ),
        ('R0=0,T,0,9,1,V,0,""modbus_val*2"', 18, "R0: the agent runs 'modbus_val*2'"),
        ('R0=0,T,0,9,1,V,0,"""', 18, 'R0: the Lua column \'"""\' has nothing between quotes for the agent'),
        ('R0=0,T,0,9,1,V,0," "', 18, "R0: the Lua column is only spaces"),
        ('R0=0,"Temp, inside",0,100,0.1,C,1', 13, "R0: min must be a number, not 'inside\"'"),
    ],
)
def test_lines_the_agent_reads_otherwise_are_refused_with_their_position(tmp_path, line, col, fragment):
    ini = wise(tmp_path, f"[Holding Registers]\nnumberOfR=1\n{line}\n")
    assert_clean_error(cli("import", ini), 1, f"{ini}:5:{col}: error: {fragment}")


def test_bit_lines_and_trailing_commas_are_as_before(tmp_path):
    """Empty fields at the end (Excel's trailing commas) are what strtok finds nothing in: read as absent.
    Past a bit line's name the agent reads nothing, so empty fields there do not matter."""
    ini = wise(tmp_path, "[Coils]\nnumberOfB=1\nB0=3,Led,,\n[Holding Registers]\nnumberOfR=1\nR0=0,T,0,10,0.5,,,\n")
    proc = cli("import", ini)
    assert proc.returncode == 0, proc.stderr
    assert "<multiplier>0.5</multiplier>" in proc.stdout and "<units>" not in proc.stdout


def test_a_lua_column_with_a_comma_that_is_not_arithmetic_is_kept_and_says_so(tmp_path):
    ini = wise(tmp_path, '[Input Registers]\nnumberOfIR=1\nIR0=0,R,0,5,1,V,0,"math.pow(modbus_val,1/2)"\n')
    proc = cli("import", ini)
    assert proc.returncode == 0, proc.stderr
    assert (
        f"{ini}:5:19: warning: IR0 'R': the Lua column 'math.pow(modbus_val,1/2)' is not plain arithmetic "
        "on modbus_val: kept in the description (export writes it back), not applied; the agent reads the "
        "column only up to its first comma"
    ) in proc.stderr


# --- issue 27: bounded time and memory, summed-up diagnostics -----------------------------------------------


def test_a_wise_file_over_the_size_limit_is_refused_before_reading(tmp_path):
    ini = tmp_path / "big.ini"
    with ini.open("w") as f:
        f.write("[Platform]\nName=Big\n")
        line = "; " + "x" * 1000 + "\n"
        f.write(line * (MAX_FILE_BYTES // len(line) + 1))
    proc = run_capped("import", ini, "-o", tmp_path / "out.xml")
    assert_clean_error(proc, 1, f"{ini}: error: larger than {MAX_FILE_BYTES:,} bytes")
    assert not (tmp_path / "out.xml").exists()


def test_a_wise_file_on_stdin_over_the_size_limit_is_refused(tmp_path):
    data = b"[Platform]\nName=Big\n" + b"#" * (MAX_FILE_BYTES + 10)
    proc = run_capped("import", "-", "--from", "wise", input=data)
    assert_clean_error(proc, 1, "<stdin>: error: larger than")


def test_too_many_wise_entries_are_refused_with_the_first_one_past_the_limit(tmp_path):
    half = MAX_ENTRIES // 2 + 1  # two bit sections: MAX_ENTRIES + 2 entries, each table within its addresses
    lines = ["[Platform]", "Name=Many", "[Coils]", f"numberOfB={half}"]
    lines += [f"B{i}={i},c{i}" for i in range(half)]
    lines += ["[Discrete Inputs]", f"numberOfIB={half}"] + [f"IB{i}={i},d{i}" for i in range(half)]
    ini = tmp_path / "many.ini"
    ini.write_text("\n".join(lines) + "\n")
    proc = run_capped("import", ini, "-o", tmp_path / "out.xml")
    first_past = 4 + half + 2 + (MAX_ENTRIES - half) + 1  # the line of entry number MAX_ENTRIES + 1
    assert_clean_error(
        proc, 1, f"{ini}:{first_past}:1: error: IB{MAX_ENTRIES - half}: more than {MAX_ENTRIES:,} entries in the file"
    )
    assert not (tmp_path / "out.xml").exists()


def test_repeated_wise_errors_are_summed_up_by_kind(tmp_path):
    """20,000 entries on 10 offsets: the clash is shown SHOWN_PER_KIND times in full, then once with a count
    and the next lines; the other kinds of error are shown too."""
    n = 20000
    body = f"[Holding Registers]\nnumberOfR={n}\n" + "".join(f"R{i}={i % 10},N{i},0,1,1,V\n" for i in range(n))
    body += "R20000=x,bad\n"
    ini = wise(tmp_path, body)
    proc = run_capped("import", ini)
    assert_clean_error(
        proc,
        1,
        f"{ini}:15:5: error: R10: offset 0 of the holding table is already R0's (line 5)",
        f"{ini}:20:5: error: R15: offset 5 of the holding table is already R5's (line 10); and "
        f"{n - 10 - SHOWN_PER_KIND - 1:,} more like it (lines 21, 22, 23, 24, 25, ...)",
        f"{ini}:20005:1: error: R20000 is beyond numberOfR={n}",
    )
    assert len(proc.stderr.splitlines()) <= 3 * (SHOWN_PER_KIND + 1)


def test_repeated_wise_warnings_are_summed_up_too(tmp_path):
    """The same name 3,000 times in one section: a warning each, summed up; the import goes on."""
    n = 3000
    body = f"[Coils]\nnumberOfB={n}\n" + "".join(f"B{i}={i},Same\n" for i in range(n))
    proc = run_capped("import", wise(tmp_path, body))
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stderr.splitlines()) == SHOWN_PER_KIND + 1
    assert f"and {n - 1 - SHOWN_PER_KIND - 1:,} more like it" in proc.stderr
    assert "<name>Same_3000</name>" in proc.stdout


def _toolkit(fields: int, tests: int) -> str:
    out = ["description: 'big'", "blocks:", "  - id: 'Main'", "    fields:"]
    for i in range(fields):
        out += [f"      - id: 'F{i}'", f"        expression: 'int16(hr:{i})'"]
    out.append("tests:")
    for t in range(tests):
        out += [
            f"  - id: 'T{t}'",
            "    input:",
            "      - firstRegisterAddress: 'hr:0'",
            f"        registers: '{t % 2:04x}'",
            "    blocks:",
            "      - id: 'Main'",
            "        expected:",
            "          F0: 1",
        ]
    return "\n".join(out) + "\n"


def test_a_toolkit_file_over_the_size_limit_is_refused(tmp_path):
    """Parsed up to the limit only: nothing wrong there, so the size is the error."""
    path = tmp_path / "big.yaml"
    path.write_text("description: 'x'\n" + "# " + "x" * YAML_LIMIT + "\n")
    for args in (("import", path, "-o", tmp_path / "out.xml"), ("test", path)):
        assert_clean_error(run_capped(*args), 1, f"{path}: error: larger than {YAML_LIMIT:,} bytes")
    assert not (tmp_path / "out.xml").exists()


def test_an_error_before_the_size_limit_is_reported_where_it_is(tmp_path):
    """A file larger than the limit with an alias on line 2: the alias is the error (with its position), as in
    a small file, rather than the size."""
    path = tmp_path / "big.yaml"
    path.write_text("description: &d 'x'\nblocks: *d\n" + "# " + "x" * YAML_LIMIT + "\n")
    assert_clean_error(run_capped("import", path), 1, f"{path}:2:9: error: YAML aliases are not supported")


def test_mdl_test_compiles_a_device_once_for_all_its_scenarios(tmp_path, monkeypatch):
    """Each scenario costs what it names, not the device's size: the codecs are compiled once per function
    (before, once per function per scenario: 8,000 scenarios over 2,000 fields ran for minutes)."""
    import mdl.device.evaluate as evaluate

    calls = []
    original = evaluate.compile_codec

    def counting(*args, **kwargs):
        calls.append(args[0])
        return original(*args, **kwargs)

    monkeypatch.setattr(evaluate, "compile_codec", counting)
    path = tmp_path / "many.yaml"
    path.write_text(_toolkit(fields=50, tests=40))
    proc = cli("test", path)
    assert proc.stdout.endswith("20 passed, 20 failed\n"), proc.stdout
    assert proc.returncode == 1
    assert len(calls) == 50


def test_a_long_chain_of_fields_is_refused_in_linear_time(tmp_path):
    """3,000 fields each naming the one before: the chain is refused past the depth limit, each field once or
    twice, with its position (the check of which fields already had an error was quadratic: 90 s here)."""
    lines = [
        "description: 'chain'",
        "blocks:",
        "  - id: 'Main'",
        "    fields:",
        "      - id: 'F0'",
        "        expression: 'int16(hr:0)'",
    ]
    for i in range(1, 3000):
        lines += [f"      - id: 'F{i}'", f"        expression: 'F{i - 1} + 1'"]
    path = tmp_path / "chain.yaml"
    path.write_text("\n".join(lines) + "\n")
    proc = run_capped("import", path)
    assert_clean_error(
        proc, 1, f"{path}:134:22: error: field 'F64' of block 'Main': fields refer to each other more than 64 deep"
    )
    assert len(proc.stderr.splitlines()) < 2 * 3000


@pytest.mark.parametrize(
    "yaml_text, fragment",
    [
        ("description: &a 'x'\nblocks: *a\n", ":2:9: error: YAML aliases are not supported"),
        ("description: 'x'\nblocks: " + "[" * 5000 + "]" * 5000 + "\n", "error: YAML nested more than 32 levels deep"),
        (
            "description: 'x'\nblocks:\n  - id: 'M'\n    fields:\n      - id: 'F'\n        expression: '"
            + " + ".join(["int16(hr:0)"] * 20000)
            + "'\n",
            "error: field 'F' of block 'M': the expression nests more than",
        ),
    ],
)
def test_toolkit_bombs_are_refused_with_a_position(tmp_path, yaml_text, fragment):
    path = tmp_path / "bomb.yaml"
    path.write_text(yaml_text)
    for args in (("import", path), ("test", path)):
        assert_clean_error(run_capped(*args), 1, fragment)


def test_a_huge_scalar_within_the_limit_imports(tmp_path):
    """A 1.5 MB description is just text: imported, not refused, in bounded memory."""
    path = tmp_path / "desc.yaml"
    path.write_text(
        "description: '" + "d" * 1_500_000 + "'\nblocks:\n  - id: 'M'\n    fields:\n"
        "      - id: 'F'\n        expression: 'int16(hr:0)'\n"
    )
    proc = run_capped("import", path, "-o", tmp_path / "out.xml")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out.xml").stat().st_size > 1_500_000
