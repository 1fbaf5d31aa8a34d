"""`mdl csv2xml` on the tables a second review tried (issue 12's findings): a function whose row was
skipped is left unmatched and said, never handed to an unrelated row; a match by similarity alone is
said (and refused by --strict); the INI's own synonyms outrank the function's name; a closing bracket
ends a clause; a scale-and-unit column with a unit alone is scale 1; VOLTTRON's struct types and
Mixed Endian column; widthless INT said; INI errors at their INI line.

Each table under tests/data/csv2xml/ names, in its first (comment) row, the reviewer's reproduction it
was trimmed from (/tmp/review2/...). Values are proven by serving the result with `mdl sim`."""

from __future__ import annotations

import csv
import json

import pytest

from support.common import DATA
from support.run import assert_clean_error, cli, run_mdl
from support.tables import functions

TABLES = DATA / "csv2xml"


def read_values(sim_factory, xml, registers: dict, folder) -> dict:
    raw = folder / "raw.json"
    raw.write_text(json.dumps(registers))
    sim = sim_factory(xml, "--registers", raw)
    proc = run_mdl("read", xml, *sim.connection, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


# ---- 1. a skipped row is never replaced by an unrelated one -------------------------------------


def test_a_function_whose_row_was_skipped_is_left_unmatched_and_said(tmp_path):
    """/tmp/review2/phr/f.csv: `22.x0` cannot be read (the reviewer's `22.b0`, bit 0 of register 22, is
    read since issue 36); output_voltage took "PV2 voltage" (fuzzy 0.72)
    with exit 0 and "0 unmatched". Now it is left unmatched, with a warning naming the skipped line."""
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", TABLES / "skipped_row.ini", "-o", out)
    assert proc.returncode == 0, proc.stderr
    path = TABLES / "skipped_row.csv"
    assert (
        f"{path}:6: warning: output_voltage: line 6 names it (exact 1.00: 'AC output voltage') but was skipped "
        "('22.x0' is not an address); left unmatched rather than given line 4 'PV2 voltage' (fuzzy 0.72)" in proc.stderr
    )
    fns = functions(out.read_text())
    assert "output_voltage" not in fns and fns["pv1_voltage"]["addresses"] == "1"
    assert "2 functions matched, 1 unmatched" in proc.stderr
    assert "no row reached the threshold" not in proc.stderr  # said once, by the warning that says why


def test_a_bundled_function_whose_row_was_skipped_is_a_note(tmp_path):
    """Without the INI's synonyms the user named no function: the row's own warning is the one said."""
    table = tmp_path / "map.csv"
    table.write_text("Address,Description,Format\n0,Room temperature,int99\n1,Humidity,UINT16\n")
    ini = tmp_path / "map.ini"  # a format column the INI names: its unreadable cell skips the row (SPEC 4.1)
    ini.write_text("[Column/Field Indices]\nformat = Format\n")
    proc = cli("csv2xml", table, "--ini", ini, "--all", "--fail-on-warning", "-o", tmp_path / "out.xml")
    assert_clean_error(
        proc,
        1,
        f"{table}:2: warning: row skipped: column 2 'Format' format cell 'int99': unknown format 'int99'",
        f"{table}:2: note: room_temperature: line 2 names it (exact 1.00: 'Room temperature') but was "
        "skipped (column 2 'Format' format cell 'int99': unknown format 'int99'); left unmatched",
        "1 warning and --fail-on-warning",
    )


def test_a_match_by_similarity_only_is_a_note_and_strict_refuses_it(tmp_path):
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", TABLES / "skipped_row.ini", "-o", out)
    path = TABLES / "skipped_row.csv"
    assert (
        f"{path}:5: note: battery_volts matched by similarity only: line 5 'Battery voltage' (score 0.89; none "
        "of its synonyms stands there as a phrase)" in proc.stderr
    )
    assert functions(out.read_text())["battery_volts"]["addresses"] == "3"
    out.unlink()
    proc = cli("csv2xml", TABLES / "skipped_row.ini", "-o", out, "--strict")
    assert_clean_error(
        proc,
        1,
        f"{path}:5: warning: battery_volts matched by similarity only",
        "--strict refuses it",
        "3 warnings and --strict: nothing written",
    )
    assert not out.exists()


def test_fail_on_warning_leaves_a_similarity_match_a_note(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Address,Description\n0,Battery voltage\n1,Grid power\n")
    ini = tmp_path / "t.ini"
    ini.write_text("[Function Name Search Synonyms]\nbattery_volts = Battery volt\ngrid = Grid power\n")
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", table, "--ini", ini, "-o", out, "--fail-on-warning")
    assert proc.returncode == 0, proc.stderr
    assert "note: battery_volts matched by similarity only" in proc.stderr
    assert "wrote" in proc.stderr and out.exists()


def test_explain_lists_a_skipped_row_and_why(tmp_path):
    proc = cli("csv2xml", TABLES / "skipped_row.ini", "--explain", "output_voltage")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[1] == "  chosen: no row (its best row, line 6, was skipped)"
    assert lines[2] == "   1. 1.00 exact  line 6: AC output voltage  (skipped: '22.x0' is not an address)"


@pytest.mark.commands  # serves or dials a device
def test_victron_table_read_access_brackets_and_units_alone(tmp_path, sim_factory):
    """/tmp/review2/victron: system_time took "Active input source" because its row (access `RD`) was
    skipped; soc took VE.Bus row 30 over the system row 843 the INI copied; `W` alone in the scale and
    unit column skipped its row."""
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", TABLES / "victron_system.ini", "-o", out)
    assert proc.returncode == 0, proc.stderr
    fns = functions(out.read_text())
    assert {name: f["addresses"] for name, f in fns.items()} == {
        "battery_voltage": "840",
        "soc": "843",
        "time_to_go": "846",
        "grid_l1": "820",
        "system_time": "830",
        "battery_temperature": "61",
    }
    assert fns["system_time"]["access"] == "read" and fns["system_time"]["units"] == "seconds"  # RD: read
    assert fns["grid_l1"]["units"] == "W" and "multiplier" not in fns["grid_l1"]
    assert (fns["battery_voltage"]["multiplier"], fns["battery_voltage"]["units"]) == ("0.1", "V DC")
    assert fns["battery_temperature"]["units"] == "Degrees celsius"
    path = TABLES / "victron_system.csv"
    assert (
        f"{path}: note: column 7 'unit' is both divisor and units: 'W' on line 4 (a unit with no number before "
        "it, and any like it) is read as scale 1 in that unit" in proc.stderr
    )
    assert f"{path}:3: warning: serial: line 3 names it (phrase 0.93:" in proc.stderr
    assert "unknown format 'ascii.6'" in proc.stderr and "similarity only" not in proc.stderr
    values = read_values(
        sim_factory,
        out,
        {"holding": {"840": 265, "843": 87, "846": 6000, "820": 0xFF38, "832": 0x6553, "833": 0xF100, "61": 215}},
        tmp_path,
    )
    # Victron's scale factor 0.01 divides too: its range column says 0 to 6553600 s
    assert values == {
        "battery_voltage": 26.5,
        "soc": 87,
        "time_to_go": 600000.0,
        "grid_l1": -200,
        "system_time": 1700000000,
        "battery_temperature": 21.5,
    }


def test_victron_write_letters_rd_and_wr(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Address,Description,Type,Access\n0,Status,uint16,RD\n1,Limit,uint16,RD/WR\n2,Mode,uint16,R/O\n")
    proc = cli("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    assert {n: f.get("access") for n, f in functions(proc.stdout).items()} == {
        "status": "read",
        "limit": None,
        "mode": "read",
    }


# ---- 2. scores ------------------------------------------------------------------------------------


def test_a_closing_bracket_ends_the_clause(tmp_path):
    """ "Battery State of Charge (System)" ends at its bracket: no "another word follows" penalty, so the
    row that says it with only a prefix beats one that goes on to say "estimate"."""
    table = tmp_path / "t.csv"
    table.write_text(
        "addr,desc\n1,Battery State of Charge (System) estimate\n"
        "2,com.victronenergy.system-Battery State of Charge (System)\n"
    )
    ini = tmp_path / "t.ini"
    ini.write_text("[Function Name Search Synonyms]\nsoc_system = Battery State of Charge (System)\n")
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    assert functions(proc.stdout)["soc_system"]["addresses"] == "2"
    proc = cli("csv2xml", table, "--ini", ini, "--explain", "soc_system")
    assert "   1. 0.95 phrase line 3: com.victronenergy.system-Battery State of Charge (System)" in proc.stdout
    assert "its clause ends there" in proc.stdout.splitlines()[3]


def test_the_ini_synonyms_outrank_the_function_name(tmp_path):
    """The function's own name `soc`, the whole of a short name cell, no longer beats the INI's synonym
    copied word for word from the table."""
    table = tmp_path / "t.csv"
    table.write_text(
        "register,name,description\n30,SOC,VE.Bus state of charge\n"
        "843,system/Dc/Battery/Soc,com.victronenergy.system-Battery State of Charge (System)\n"
    )
    ini = tmp_path / "t.ini"
    ini.write_text(
        "[Column/Field Indices]\nname = name\n[Function Name Search Synonyms]\nsoc = Battery State of Charge (System)\n"
    )
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    assert functions(proc.stdout)["soc"]["addresses"] == "843"
    proc = cli("csv2xml", table, "--ini", ini, "--explain", "soc")
    out = proc.stdout
    assert "synonyms 'Battery State of Charge (System)', 'soc' (its name)" in out
    assert "   2. 1.00 name   line 2: VE.Bus state of charge" in out
    assert "the text is the function's own name 'soc' (ranked below the synonyms' exact and phrase matches)" in out


def test_the_function_name_still_finds_a_row_no_synonym_does(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Address,Description\n0,Frequency\n1,Voltage L1\n")
    ini = tmp_path / "t.ini"
    ini.write_text("[Function Name Search Synonyms]\nfrequency = grid freq hz\nvoltage = Voltage L1\n")
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    assert functions(proc.stdout)["frequency"]["addresses"] == "0"
    assert "similarity only" not in proc.stderr


# ---- 3. a unit alone in a scale-and-unit column; placeholder units ---------------------------------

UNIT_ALONE = [
    ("10V DC", "0.1", "V DC"),
    ("W", None, "W"),
    ("0.01s", "100", "s"),
    ("-10Ah", "-0.1", "Ah"),
    ("%", None, "%"),
    ("None", None, None),
    ("-", None, None),
]


@pytest.mark.parametrize("cell, multiplier, units", UNIT_ALONE, ids=[c[0] for c in UNIT_ALONE])
def test_a_unit_alone_in_a_divisor_and_units_column_is_scale_one(tmp_path, cell, multiplier, units):
    """/tmp/review2/phr/u.csv: `divisor = unit` and `units = unit`; `W` skipped its row."""
    table = tmp_path / "u.csv"
    table.write_text(f"register,description,unit\n820,Grid L1 power,{cell}\n")
    ini = tmp_path / "u.ini"
    ini.write_text(
        "[Column/Field Indices]\naddresses = register\ndescription = description\ndivisor = unit\n"
        "units = unit\n[Function Name Search Synonyms]\ngrid_l1 = Grid L1 power\n"
    )
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    fn = functions(proc.stdout)["grid_l1"]
    assert (fn.get("multiplier"), fn.get("units")) == (multiplier, units)
    assert ("is read as scale 1 in that unit" in proc.stderr) == (cell in ("W", "%"))


@pytest.mark.parametrize("cell", ["10=idle;1=charging", "1=VE.Bus reset", "mod10k(True)"])
def test_other_cells_in_a_scale_and_unit_column_are_still_reported(tmp_path, cell):
    table = tmp_path / "u.csv"
    table.write_text(f"register,description,unit\n820,Grid L1 power,W\n844,Battery state,{cell}\n")
    ini = tmp_path / "u.ini"
    ini.write_text(
        "[Column/Field Indices]\ndivisor = unit\nunits = unit\n"
        "[Function Name Search Synonyms]\ngrid_l1 = Grid L1 power\n"
    )
    proc = cli("csv2xml", table, "--ini", ini)
    assert proc.returncode == 0, proc.stderr
    assert f"{table}:3: warning: column 2 'unit' divisor cell '{cell}': divisor '{cell}' is not a scale" in proc.stderr


@pytest.mark.parametrize("cell", ["None", "-", "n/a"])
def test_placeholder_units_are_empty(tmp_path, cell):
    table = tmp_path / "t.csv"
    table.write_text(f"Address,Description,Type,Units\n0,Room temperature,int16,{cell}\n1,Humidity,uint16,%\n")
    proc = cli("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    assert "units" not in fns["room_temperature"] and fns["humidity"]["units"] == "%"


# ---- 4. VOLTTRON struct types and Mixed Endian ----------------------------------------------------

# every byte differs: a value read from the wrong byte or word cannot pass
VOLTTRON_RAW = {
    "holding": {
        "0": 0x1234,
        "1": 0x5678,
        "2": 0x1234,
        "7": 0xFF38,
        "8": 0x38FF,
        "10": 0x0FDB,
        "11": 0x4049,
        "20": 0x7856,
        "21": 0x3412,
        "22": 0x3412,
        "23": 0x7856,
        "24": 0x1234,
        "25": 0x5678,
        "30": 0x1234,
        "31": 0x1234,
        "32": 0x3FF8,
    }
}
VOLTTRON_VALUES = {
    "unsigned_short": 0x1234,
    "unsigned_int": 0x12345678,
    "sample_short": -200,
    "little_short": -200,
    "little_int": 0x12345678,
    "swapped_little_int": 0x12345678,
    "plain_int": 0x12345678,
    "low_byte": 0x34,
    "high_byte": 0x12,
    "big_double": 1.5,
}


def volttron_types(tmp_path):
    out = tmp_path / "out.xml"
    proc = cli("csv2xml", TABLES / "volttron_types.csv", "--all", "-o", out)
    assert proc.returncode == 0, proc.stderr
    return proc, out


@pytest.mark.commands  # serves or dials a device
def test_volttron_struct_types_and_mixed_endian(tmp_path, sim_factory):
    """/tmp/review2/volt/tk.csv: `>I`, `>h`, `>f` were refused (`unknown format '>I'`) and the Mixed
    Endian column ignored. Struct codes give the format and, by `<` or `>`, the byte and word order;
    Mixed Endian TRUE reverses the registers from that order."""
    proc, out = volttron_types(tmp_path)
    fns = functions(out.read_text())
    orders = {n: (f["format"], f.get("byte_order"), f.get("word_order"), f.get("length")) for n, f in fns.items()}
    assert orders == {
        "unsigned_short": ("UINT16", None, None, None),
        "unsigned_int": ("UINT32", None, "little", None),
        "sample_short": ("INT16", None, None, None),
        "little_short": ("INT16", "little", None, None),
        "sample_float": ("FLOAT32", None, "little", None),
        "little_int": ("UINT32", "little", "little", None),
        "swapped_little_int": ("UINT32", "little", None, None),
        "plain_int": ("UINT32", None, None, None),
        "low_byte": ("UINT8", None, None, "Lower byte"),
        "high_byte": ("UINT8", None, None, "Upper byte"),
        "big_double": ("FLOAT64", None, None, None),
    }
    assert not any("units" in f for f in fns.values())  # None and - are no units
    assert "note: column 6 'Mixed Endian' gives each row's word order: TRUE reverses the registers" in proc.stderr
    values = read_values(sim_factory, out, VOLTTRON_RAW, tmp_path)
    assert values.pop("sample_float") == pytest.approx(3.14159274)
    assert values == VOLTTRON_VALUES


@pytest.mark.engines
def test_volttron_reads_the_map_as_csv2xml_does(tmp_path, sim_factory):
    """VOLTTRON's own driver on the same map, polling `mdl sim` serving csv2xml's result: every value alike."""
    from support.volttron import through_volttron

    _, out = volttron_types(tmp_path)
    raw = tmp_path / "raw.json"
    raw.write_text(json.dumps(VOLTTRON_RAW))
    sim = sim_factory(out, "--registers", raw)
    folder = tmp_path / "volttron"
    folder.mkdir()
    rows = [line for line in (TABLES / "volttron_types.csv").read_text().splitlines() if not line.startswith("#")]
    (folder / "types_map.csv").write_text("\n".join(rows) + "\n")
    names = [row["Register Name"] for row in csv.DictReader(rows)]
    (folder / "types.csv").write_text("Volttron Point Name,Register Name\n" + "".join(f"{n},{n}\n" for n in names))
    (folder / "types.config").write_text(
        json.dumps(
            {
                "driver_config": {
                    "name": "types",
                    "device_address": sim.host,
                    "port": sim.port,
                    "slave_id": 1,
                    "addressing": "offset",
                    "endian": "big",
                    "register_map": "config://types_map.csv",
                },
                "driver_type": "modbus_tk",
                "registry_config": "config://types.csv",
                "interval": 60,
            }
        )
    )
    got = through_volttron(folder, "types")["before"]
    mine = json.loads(run_mdl("read", out, *sim.connection, "--format", "json").stdout)
    assert got == pytest.approx(mine) and set(got) == set(names)


@pytest.mark.commands  # serves or dials a device
def test_a_volttron_export_reads_back_the_same(tmp_path, sim_factory):
    """`mdl export --to volttron` writes struct types and Mixed Endian; csv2xml reads its map back to
    functions that read the same registers as the original."""
    original = DATA / "all_tables.xml"
    proc = run_mdl("export", original, "--to", "volttron", "-o", tmp_path / "vt", "--host", "127.0.0.1")
    assert proc.returncode == 0, proc.stderr
    back = tmp_path / "back.xml"
    ini = tmp_path / "back.ini"  # no function to match (not the bundled list): every row under its own name
    ini.write_text("[Function Name Search Synonyms]\nnothing = zzzz\n")
    proc = cli("csv2xml", tmp_path / "vt" / "all_tables_map.csv", "--ini", ini, "--all", "-o", back)
    assert proc.returncode == 0, proc.stderr
    raw = {
        "input": {"0": 0x5678, "1": 0x1234, "2": 0x4049, "3": 0x0FDB, "10": 2301},
        "holding": {
            "100": 0xFF38,
            "101": 2,
            "200": 0xFFFF,
            "201": 0xFFFE,
            "202": 0x1234,
            "203": 0x5678,
            "400": 0x1122,
            "401": 0x3344,
            "402": 0x7F85,
            "403": 0xC812,
        },
    }
    first = read_values(sim_factory, original, raw, tmp_path)
    again = read_values(sim_factory, back, raw, tmp_path)
    shared = (set(first) & set(again)) - {"mode"}  # VOLTTRON's map has no enumeration: 2, not 'Cool'
    assert len(shared) >= 14, sorted(shared)
    assert {"energy", "power", "serial", "low_byte", "high_byte", "big"} <= shared
    assert {n: again[n] for n in shared} == {n: first[n] for n in shared}


@pytest.mark.parametrize(
    "cell, message",
    [
        (">B", "struct type '>B' is one byte: it needs one pad byte"),
        (">Ix", "struct type '>Ix': a pad byte (x) beside a value of 4 bytes"),
        (">e", "unknown format '>e'"),
    ],
)
def test_struct_types_that_fill_no_register_are_reported(tmp_path, cell, message):
    table = tmp_path / "t.csv"
    table.write_text(f"Register Name,Address,Type\nbad,0,{cell}\ngood,1,>H\n")
    proc = cli("csv2xml", table, "--all")
    assert proc.returncode == 0, proc.stderr
    # a format column found by its header never costs a row (SPEC 4.1): kept at the default format
    assert f"{table}:2: warning: column 2 'Type' format cell '{cell}': {message}" in proc.stderr
    assert list(functions(proc.stdout)) == ["bad", "good"]


def test_word_order_cells_name_the_order_and_native_is_said(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text(
        "Name,Address,Type,Word Order\na,0,float32,CDAB\nb,2,float32,little\nc,4,uint32,BADC\n"
        "d,6,=i,\ne,8,uint16,little\n"
    )
    proc = cli("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    assert {n: (f.get("byte_order"), f.get("word_order")) for n, f in fns.items()} == {
        "a": (None, "little"),
        "b": (None, "little"),
        "c": ("little", None),
        "d": ("little", "little"),
        "e": (None, None),
    }
    assert "struct type '=i' on line 5 (and any like it) has the byte order of the host" in proc.stderr
    table.write_text("Name,Address,Type,Word Order\na,0,float32,sideways\n")
    proc = cli("csv2xml", table, "--all")
    assert "column 3 'Word Order' has a header like word_order but its cells are not" in proc.stderr


def test_a_word_order_column_can_be_ignored_from_the_ini(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Name,Address,Type,Mixed Endian\na,0,float32,TRUE\n")
    ini = tmp_path / "t.ini"
    ini.write_text(
        "[Modbus Device]\nword_order = big\n[Column/Field Indices]\nword_order =\n"
        "[Function Name Search Synonyms]\na = a\n"
    )
    proc = cli("csv2xml", table, "--ini", ini, "--all")
    assert proc.returncode == 0, proc.stderr
    assert "word_order" not in functions(proc.stdout)["a"] and "Mixed Endian" not in proc.stderr


# ---- 5. widthless INT -----------------------------------------------------------------------------


def test_a_widthless_int_is_one_register_and_said(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("Address,Description,Type,Count\n0,Power,INT,\n1,Energy,INT,2\n3,Mode,UINT,1\n")
    proc = cli("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    fns = functions(proc.stdout)
    # a count of 2 gives the widthless INT its width (issue 36: two INT16 registers read a wrong value)
    assert (fns["power"]["format"], fns["energy"]["format"], fns["energy"]["count"]) == ("INT16", "INT32", "2")
    assert "format 'INT' on line 3 (and any like it) says no width and the row is 2 registers: read as INT32" in (
        proc.stderr
    )
    assert (
        "note: format 'INT' on line 2 (and any like it) gives no width: read as one register (16 bits); "
        "if the table means 32 bits, write INT32/UINT32 there or give the row a count of 2"
    ) in proc.stderr
    table.write_text("Address,Description,Type\n0,Power,INT16\n")
    assert "gives no width" not in cli("csv2xml", table, "--all").stderr


def test_widthless_ints_are_no_evidence_of_counted_bytes(tmp_path):
    """Two `INT` rows counted 2 once made the count column bytes (2 bytes: an INT16)."""
    table = tmp_path / "t.csv"
    table.write_text("Address,Description,Type,Count\n0,Power,INT,2\n2,Energy,INT,2\n")
    proc = cli("csv2xml", table, "--all", "--threshold", "1")
    assert proc.returncode == 0, proc.stderr
    assert {f["count"] for f in functions(proc.stdout).values()} == {"2"}
    assert "counts in column 3 'Count' read as registers (words): the usual unit" in proc.stderr


# ---- 6. INI errors at their INI line; 7. the count in "wrote" -------------------------------------


def test_a_column_the_header_lacks_is_an_error_at_its_ini_line(tmp_path):
    """/tmp/review2/growatt/bad3.ini: `format = datatype_typo`."""
    table = tmp_path / "g.csv"
    table.write_text("register,description,data type\n1,PV1 voltage,uint16\n")
    ini = tmp_path / "g.ini"
    ini.write_text(
        "[Input/Output]\naddress_map_csv_file = g.csv\n\n[Column/Field Indices]\naddresses = register\n"
        "format = datatype_typo\nunits = unitz\n"
    )
    assert_clean_error(
        cli("csv2xml", ini),
        1,
        f"{ini}:6: error: [Column/Field Indices] format = datatype_typo: no such column in the header "
        f"row (line 1) of {table}",
        f"{ini}:7: error: [Column/Field Indices] units = unitz",
    )


def test_a_column_index_no_row_reaches_is_an_error_at_its_ini_line(tmp_path):
    """It would read every cell of it as empty: a table's formats silently UINT16."""
    table = tmp_path / "g.csv"
    table.write_text("register,description,data type\n1,PV1 voltage,int32\n")
    ini = tmp_path / "g.ini"
    ini.write_text("[Column/Field Indices]\naddresses = 0\nformat = 9\n")
    assert_clean_error(
        cli("csv2xml", table, "--ini", ini),
        1,
        f"{ini}:3: error: [Column/Field Indices] format = 9: no row of {table} has a column 9 "
        "(columns count from 0; the widest row has 3)",
    )


def test_a_missing_csv_named_in_the_ini_is_an_error_at_its_ini_line(tmp_path):
    """/tmp/review2/growatt/bad4.ini."""
    ini = tmp_path / "g.ini"
    ini.write_text("[Modbus Device]\ndevice_name=x\n[Input/Output]\naddress_map_csv_file=nothere.csv\n")
    assert_clean_error(
        cli("csv2xml", ini), 1, f"{ini}:4: error: address_map_csv_file names {tmp_path / 'nothere.csv'}: no such file"
    )


def test_multiplier_and_divisor_naming_one_column_is_an_error_at_its_line(tmp_path):
    ini = tmp_path / "d.ini"
    ini.write_text("[Column/Field Indices]\nmultiplier = Scalefactor\ndivisor = Scalefactor\n")
    assert_clean_error(
        cli("csv2xml", TABLES / "victron_gx.csv", "--ini", ini),
        1,
        f"{ini}:3: error: [Column/Field Indices] multiplier and divisor name the same column",
    )


def test_wrote_counts_one_function(tmp_path):
    """/tmp/review2/phr/u.csv printed `wrote u.xml: 1 functions`."""
    table = tmp_path / "u.csv"
    table.write_text("register,description\n840,Battery Voltage\n")
    ini = tmp_path / "u.ini"
    ini.write_text("[Function Name Search Synonyms]\nvoltage = Battery Voltage\n")
    proc = cli("csv2xml", table, "--ini", ini, "-o", tmp_path / "u.xml")
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {tmp_path / 'u.xml'}: 1 function, MDL 0.9b" in proc.stderr
