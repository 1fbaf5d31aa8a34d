"""Issue 27: hostile text in a description never becomes configuration of the system an export configures.

A device name, function name, description, unit or enumeration label may hold line breaks of every kind
(\\n, \\r, NEL U+0085, U+2028, U+2029), quotes, backslashes, `]]`, `#`, `=`, `;`, `[`...: valid MDL, and
reachable from an imported XIF or Modbus.ini. Each export is read back with the format's own parser (tomllib,
yaml.safe_load, csv, json, configparser and mdl's own WISE reader) and must have the structure that was meant
(the same tables, keys, sections, rows) with every text back exactly, or changed with a warning naming the
function (CSV formula characters; the characters a Modbus.ini line cannot hold)."""

from __future__ import annotations

import csv

import pytest
import yaml

from mdl.formats.wise.read import read_wise
from support.common import MDL_NS
from support.hostile_exports import (
    FORMULA,
    HOSTILE,
    INJECTING_NAME,
    Fn,
    check_volttron,
    check_wise,
    export,
    only_newlines,
    run_all,
    tomllib,
    write_device,
)
from support.run import assert_clean_error, cli

# --- checks shared with the fuzz test (tests/fuzz/test_fuzz_exports.py) ---------------------------------------


# --- the tests --------------------------------------------------------------------------------------------------


def test_hostile_device_passes_validate(tmp_path):
    """A control: the hostile descriptions are valid MDL, so a user can hand them to export."""
    path = write_device(tmp_path / "d.xml", INJECTING_NAME, [Fn(text, text, text, {1: text}) for text in HOSTILE])
    proc = cli("validate", path)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_every_export_reads_back_as_meant(tmp_path):
    functions = [Fn(text, description=f"{text} d", units=text, values={1: text, 2: "ok"}) for text in HOSTILE]
    path = write_device(tmp_path / "d.xml", INJECTING_NAME, functions)
    run_all(path, tmp_path)


def test_device_name_adds_no_telegraf_output(tmp_path):
    path = write_device(tmp_path / "d.xml", INJECTING_NAME, [Fn("t")])
    proc = export(path, "telegraf")
    assert proc.returncode == 0, proc.stderr
    doc = tomllib.loads(proc.stdout)
    assert "outputs" not in doc and doc["inputs"]["modbus"][0]["name"] == INJECTING_NAME
    head = proc.stdout.split("\n")[0]  # the name in the header comment: escaped, on the comment's one line
    assert head.startswith("# Telegraf modbus input: Evil\\n[[outputs.exec]]\\n") and "\\x85# done" in head


def test_device_name_adds_no_home_assistant_key(tmp_path):
    path = write_device(tmp_path / "d.xml", INJECTING_NAME, [Fn("t")])
    proc = export(path, "homeassistant")
    assert proc.returncode == 0, proc.stderr
    assert [set(hub) for hub in yaml.safe_load(proc.stdout)] == [{"name", "type", "host", "port", "timeout", "sensors"}]
    assert proc.stdout.split("\n")[0].startswith("# Home Assistant modbus integration: Evil\\n[[outputs.exec]]")


def test_yaml_keeps_nel_and_separators_in_names(tmp_path):
    """PyYAML writes NEL, U+2028 and U+2029 raw in its plain and single-quoted styles, and reads them back as
    a folded line break: the name would come back as another name. They are double-quoted escapes."""
    names = ["a\x85b", "c\u2028d", "e\u2029f", "g\rh", " lead", "trail\t"]
    path = write_device(tmp_path / "d.xml", "Dev", [Fn(n, units=n) for n in names])
    proc = export(path, "homeassistant")
    assert proc.returncode == 0, proc.stderr
    sensors = yaml.safe_load(proc.stdout)[0]["sensors"]
    assert [(s["name"], s["unit_of_measurement"]) for s in sensors] == [(n, n) for n in names]
    assert '  - name: "a\\Nb"\n' in proc.stdout


def test_toml_escapes_what_tomllib_refuses_raw(tmp_path):
    """DEL and the C1 controls in a basic string: json.dumps leaves them raw, which TOML forbids (DEL) or a
    reader may take as a line break (NEL)."""
    path = write_device(tmp_path / "d.xml", "Dev\x7f\x85\u2028", [Fn("t", values={1: "x\x7fy\x9b", 2: '"]]'})])
    proc = export(path, "telegraf")
    assert proc.returncode == 0, proc.stderr
    assert '  name = "Dev\\u007F\\u0085\\u2028"\n' in proc.stdout
    doc = tomllib.loads(proc.stdout)
    assert doc["processors"]["enum"][0]["mapping"][0]["value_mappings"] == {"1": "x\x7fy\x9b", "2": '"]]'}


@pytest.mark.parametrize("start", FORMULA)
def test_volttron_neutralises_formulas(tmp_path, start):
    name = f"{start}cmd|' /C calc'!A0"
    path = write_device(
        tmp_path / "d.xml",
        "Dev",
        [Fn(name, description=f"{start}SUM(A1)", units=f"{start}V"), Fn("plain", description="a = b", units="V")],
    )
    folder = tmp_path / "out"
    proc = export(path, "volttron", "-o", folder)
    assert proc.returncode == 0, proc.stderr
    check_volttron(path, folder, proc.stderr)
    assert proc.stderr.count("which a spreadsheet runs as a formula") == (2 if start in "\t\r" else 3)
    # (the description's whitespace is collapsed to one line, so a tab or CR cannot start that cell)
    with open(folder / "dev.csv", newline="", encoding="utf-8") as handle:
        assert list(csv.reader(handle))[1:] == [["'" + name, "cmd_c_calc_a0"], ["plain", "plain"]]


def test_wise_names_cannot_add_keys_or_sections(tmp_path):
    names = [
        "a\nR9=0,evil",
        "b\r[Coils]",
        "c\x85numberOfR=9",
        "d\u2028e",
        "f=g",
        "[Coils]",
        "; not",
        "# not",
        "x,1,2,3,4,5,6",
        'q"uote',
        " pad ",
    ]
    path = write_device(tmp_path / "d.xml", "Dev\n[Coils]\nB0=0,x", [Fn(n, units=n) for n in names])
    out = tmp_path / "Modbus.ini"
    proc = export(path, "wise", "-o", out)
    assert proc.returncode == 0, proc.stderr
    check_wise(path, out, proc.stderr)
    names_back = [fn.name for fn in read_wise(out).functions]
    assert names_back[4:8] == ["f=g", "[Coils]", "; not", "# not"]  # harmless inside a value: kept exactly
    assert "Name=Dev [Coils] B0=0,x\n" in out.read_text(encoding="utf-8")


def test_wise_lua_column_cannot_break_its_line(tmp_path):
    """A Lua conversion kept in a description is written back only when it fits its quoted column."""
    lua = "math.floor(modbus_val)\u2028[Coils]"
    kept = Fn("t", description=f"t (WISE Lua conversion, not applied: {lua})")
    path = write_device(tmp_path / "d.xml", "Dev", [kept])
    out = tmp_path / "Modbus.ini"
    proc = export(path, "wise", "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert (
        "function 't' (" in proc.stderr
        and "): written, losing the Lua conversion its description keeps (quotes and control characters" in proc.stderr
    )
    check_wise(path, out, proc.stderr)


def test_file_name_cannot_end_the_header_comment(tmp_path):
    path = write_device(tmp_path / "x\n[[outputs.exec]]\u2028.xml", "Dev", [Fn("t")])
    for fmt in ("telegraf", "homeassistant"):
        proc = export(path, fmt)
        assert proc.returncode == 0, proc.stderr
        only_newlines(proc.stdout)
        assert "from x\\n[[outputs.exec]]\\u2028.xml by mdl export" in proc.stdout.split("\n")[0]


def test_nothing_exportable_is_a_clean_error(tmp_path):
    """A control for the fuzz test's refusal: an export that can hold nothing exits 1, naming the file."""
    path = tmp_path / "d.xml"
    path.write_text(
        f'<?xml version="1.0"?>\n<device xmlns="{MDL_NS}" version="1.0"><name>a\u2028</name>'
        "<description>d</description></device>\n",
        encoding="utf-8",
    )
    assert_clean_error(export(path, "telegraf"), 1, "Telegraf can hold none of this description's functions")


def test_output_is_unchanged_for_ordinary_text(tmp_path):
    """Printable text (accents, degree signs, spaces) is written as it is, not escaped."""
    path = write_device(tmp_path / "d.xml", "Heizung Küche", [Fn("Température", units="°C", values={1: "Zu"})])
    assert '  name = "Heizung Küche"\n' in export(path, "telegraf").stdout
    assert "  - name: Température\n" in export(path, "homeassistant").stdout
    assert '"n": "Température",\n        "u": "°C"' in export(path, "senml").stdout
