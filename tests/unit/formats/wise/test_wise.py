"""WISE-Agent Modbus.ini (SPEC 7): the guide's WISE-4012E example and files shaped like the shipped agent's
samples import and read from `mdl sim` as the agent reads them; bad files are refused with every line;
`mdl export --to wise` writes the agent's form, and MDL -> WISE -> MDL reads the same values for every
function WISE can express (the others are warnings naming them)."""

from __future__ import annotations

import json
import random
import re
import struct
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mdl.diagnostics import MdlError
from mdl.formats.wise.read import read_wise
from support.common import DATA, ROOT, fn_xml
from support.export_warnings import said
from support.run import assert_clean_error, cli

WISE = DATA / "wise"
SEED = ROOT / "examples" / "wise_4012e" / "Modbus.ini"
HANDLER = WISE / "agent_handler.ini"
DATATYPES = WISE / "agent_datatypes.ini"


def read_json(path, sim, *names) -> dict:
    proc = cli("read", path, *sim.connection, *names, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def raw_file(tmp_path, tables: dict) -> Path:
    path = tmp_path / f"raw{len(list(tmp_path.glob('raw*.json')))}.json"
    path.write_text(json.dumps({t: {str(a): v for a, v in regs.items()} for t, regs in tables.items()}))
    return path


# --- the guide's example ----------------------------------------------------------------------------------


def test_seed_example_imports_to_mdl(tmp_path):
    out = tmp_path / "wise.xml"
    proc = cli("import", SEED, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert "error" not in proc.stderr and "warning" not in proc.stderr
    assert cli("validate", out).stdout.startswith(f"{out}: valid MDL 1.0")
    text = out.read_text()
    assert "<name>WISE-4012E</name>" in text
    assert re.search(
        r"<name>Voltage0</name>.*?<addresses>0</addresses>.*?<format>UINT16</format>.*?"
        r"<block_label>Analog Input</block_label>.*?<multiplier>0.001</multiplier>.*?<units>V</units>.*?"
        r"<register_type>input</register_type>.*?<minimum>0</minimum>.*?<maximum>5</maximum>",
        text,
        re.S,
    )
    assert re.search(
        r"<name>LED1</name>.*?<addresses>17</addresses>.*?<format>BIT</format>.*?"
        r"<register_type>coil</register_type>",
        text,
        re.S,
    )


@pytest.mark.commands  # serves or dials a device
def test_seed_example_reads_volts_from_millivolts(sim_factory, tmp_path):
    """The guide's values: 4645 mV and 4659 mV read 4.645 V and 4.659 V; the switches and LEDs as bits."""
    raw = raw_file(tmp_path, {"input": {0: 4645, 1: 4659}, "discrete": {0: 1}, "coil": {16: 1, 17: 1}})
    sim = sim_factory(SEED, "--registers", raw)
    assert read_json(SEED, sim) == {
        "Switch0": True,
        "Switch1": False,
        "LED0": True,
        "LED1": True,
        "Voltage0": 4.645,
        "Voltage1": 4.659,
    }
    proc = cli("read", SEED, *sim.connection, "--format", "senml")
    assert json.loads(proc.stdout) == {
        "Digital Input": {
            "bn": "Digital Input",
            "e": [{"n": "Switch0", "bv": True, "asm": "r"}, {"n": "Switch1", "bv": False, "asm": "r"}],
        },
        "Digital Output": {
            "bn": "Digital Output",
            "e": [{"n": "LED0", "bv": True, "asm": "rw"}, {"n": "LED1", "bv": True, "asm": "rw"}],
        },
        "Analog Input": {
            "bn": "Analog Input",
            "e": [
                {"n": "Voltage0", "v": 4.645, "u": "V", "min": 0, "max": 5, "asm": "r"},
                {"n": "Voltage1", "v": 4.659, "u": "V", "min": 0, "max": 5, "asm": "r"},
            ],
        },
    }
    assert '"max": 5,' in proc.stdout  # the guide's numbers: 5, not 5.0
    # the imported MDL reads the same; writing an LED and a value past the range
    xml = tmp_path / "wise.xml"
    assert cli("import", SEED, "-o", xml).returncode == 0
    assert cli("write", xml, *sim.connection, "LED0=false").returncode == 0
    assert read_json(xml, sim, "LED0", "Voltage1") == {"LED0": False, "Voltage1": 4.659}


# --- the shipped agent's form -------------------------------------------------------------------------------


@pytest.mark.commands  # serves or dials a device
def test_agent_sample_form_and_a_name_in_two_sections(sim_factory, tmp_path):
    proc = cli("import", HANDLER)
    assert proc.returncode == 0, proc.stderr
    names = re.findall(r"<name>(.*?)</name>", proc.stdout)
    assert names == [
        "WISE-4012E",
        "Switch0",
        "Switch1",
        "Switch2",
        "LED0",
        "LED1",
        "LED2",
        "Data0",
        "Data1",
        "Data2",
        "Data0_2",
        "Data1_2",
        "Data2_2",
    ]
    assert "'Data0' is also the name of line 32 ([Input Registers]): this one is named 'Data0_2'" in proc.stderr
    assert "agent_handler.ini:38: note:" in proc.stderr and "warning" not in proc.stderr
    raw = raw_file(tmp_path, {"input": {0: 7, 2: 65535}, "holding": {0: 8, 1: 9}, "coil": {2: 1}, "discrete": {1: 1}})
    sim = sim_factory(HANDLER, "--registers", raw)
    assert read_json(HANDLER, sim) == {
        "Switch0": False,
        "Switch1": True,
        "Switch2": False,
        "LED0": False,
        "LED1": False,
        "LED2": True,
        "Data0": 7,
        "Data1": 0,
        "Data2": 65535,
        "Data0_2": 8,
        "Data1_2": 9,
        "Data2_2": 0,
    }
    senml = json.loads(cli("read", HANDLER, *sim.connection, "--format", "senml").stdout)
    assert list(senml) == ["Discrete Inputs", "Coils", "Input Registers", "Holding Registers"]
    assert senml["Holding Registers"]["e"][0] == {
        "n": "Data0_2",
        "v": 8,
        "u": "V",
        "min": -1000000,
        "max": 1000000,
        "asm": "rw",
    }


def _float_regs(value: float, letters: str) -> list[int]:
    """Two registers holding the float in the byte order `letters` (A the most significant byte)."""
    abcd = dict(zip("ABCD", struct.pack(">f", value), strict=True))
    data = bytes(abcd[c] for c in letters)
    return [data[0] << 8 | data[1], data[2] << 8 | data[3]]


@pytest.mark.commands  # serves or dials a device
def test_every_datatype_and_the_lua_column(sim_factory, tmp_path):
    """Datatypes 0-8 in their byte orders (1 ABCD, 2 DCBA, 3 BADC, 4 CDAB; 5-8 ints plain and word-swapped),
    precision as a multiplier, plain Lua arithmetic as scaling, other Lua kept as a comment."""
    proc = cli("import", DATATYPES)
    assert proc.returncode == 0, proc.stderr
    assert (
        "agent_datatypes.ini:30:27: warning: R1 'Rooted': the Lua column 'math.pow(modbus_val,1/2)+10-2.5' is "
        "not plain arithmetic on modbus_val"
    ) in proc.stderr
    assert "<description>Rooted (WISE Lua conversion, not applied: math.pow(modbus_val,1/2)+10-2.5)" in proc.stdout
    regs: dict[int, int] = {0: 54321}
    for address, letters in ((2, "ABCD"), (4, "DCBA"), (6, "BADC"), (8, "CDAB")):
        regs[address], regs[address + 1] = _float_regs(-12.25, letters)
    regs[10], regs[11] = 0x0001, 0xE240  # 123456 -> 123.456 kWh
    regs[12], regs[13] = 0xE240, 0x0001
    regs[14], regs[15] = 0xFFFF, 0xFF85  # -123 -> -1.23 A
    regs[16], regs[17] = 0xFF85, 0xFFFF
    raw = raw_file(tmp_path, {"input": regs, "holding": {0: 100, 1: 25, 2: 40000}})
    sim = sim_factory(DATATYPES, "--registers", raw)
    assert read_json(DATATYPES, sim) == {
        "U16": 54321,
        "F_ABCD": -12.25,
        "F_DCBA": -12.25,
        "F_BADC": -12.25,
        "F_CDAB": -12.25,
        "U32_ABCD": 123.456,
        "U32_CDAB": 123.456,
        "I32_ABCD": -1.23,
        "I32_CDAB": -1.23,
        "Scaled": 95.0,  # ("modbus_val*2-10") * 0.5, as the agent runs the Lua before the precision
        "Rooted": 0.025,
        "U16_2": 40000,
    }  # precision 0 means 1


@pytest.mark.commands  # serves or dials a device
@pytest.mark.parametrize(
    "text, value",
    [
        ('0,x,0,100,0.1,V,0,"(modbus_val+40)/2"', 12.0),  # (200 + 40) / 2 * 0.1
        ("0,x,0,100,1,V,0,modbus_val-4", 196.0),  # an offset makes a float (SPEC 2.3)
        ('0,x,0,100,2,V,0,"modbus_val - -1"', 402.0),
        ('0,x,0,100,1,V,0,""', 200),
        ('0,x,0,100,1,V,0,"modbus_val--1"', 200),  # `--` starts a Lua comment: kept as text, not applied
    ],
)
def test_lua_arithmetic(sim_factory, tmp_path, text, value):
    ini = tmp_path / "Modbus.ini"
    ini.write_text(f"[Platform]\nName=L\n[Holding Registers]\nnumberOfR=1\nR0={text}\n")
    sim = sim_factory(ini, "--registers", raw_file(tmp_path, {"holding": {0: 200}}))
    got = read_json(ini, sim)["x"]
    assert got == value and type(got) is type(value)


def test_bad_input_reports_every_line():
    proc = cli("import", WISE / "bad.ini")
    assert_clean_error(proc, 1)
    errors = [line for line in proc.stderr.splitlines() if ": error: " in line]
    assert [e.split(": error: ")[0] for e in errors] == [
        f"{WISE / 'bad.ini'}:{where}" for where in ("5:12", "12:1", "16:22", "17:5", "18:13", "21:1")
    ]
    for fragment in (
        "numberOfDI=3 but [Digital Input] has no DI2",
        "B1 is beyond numberOfB=1",
        "datatype '9' is outside 0-8",
        "IR1: offset 0 of the input table is already IR0's (line 16)",
        "min must be a number, not 'zero'",
        "[Holding Registers] has no numberOfR",
    ):
        assert fragment in proc.stderr
    assert proc.stdout == ""


@pytest.mark.parametrize(
    "body, message",
    [  # the body starts on line 3, after [Platform] and Name
        ("[Coils]\nnumberOfB=x\nB0=0,a\n", ":4:11: error: numberOfB must be a whole number, not 'x'"),
        ("[Coils]\nnumberOfB=1\nB0=0,a\nB0=1,b\n", ":6:1: error: B0 appears twice (first on line 5)"),
        (
            "[Coils]\nnumberOfB=1\nB0=70000,a\n",
            ":5:4: error: B0: the offset must be a wire address 0..65535, not '70000'",
        ),
        ("[Coils]\nnumberOfB=1\nB0=1\n", ":5:4: error: B0: no name"),
        ("[Coils]\nnumberOfB=1\nB0=0,a\n[Coils]\n", ":6:1: error: section [Coils] appears twice (first on line 3)"),
        (
            "[Coils]\nnumberOfB=1\nB0=0,a\n[Digital Output]\nnumberOfDO=1\nDO0=0,b\n",
            ":8:5: error: DO0: offset 0 of the coil table is already B0's (line 5)",
        ),
        ("[Input Registers]\nnumberOfIR=1\nIR0=0,a,0,1e999,1,V,0\n", ":5:11: error: IR0: max 1e999 is too large"),
        ("[Input Registers]\nnumberOfIR=1\nIR0=0,a,0,1,1,V,-1\n", ":5:17: error: IR0: datatype '-1' is outside 0-8"),
        (
            "[Input Registers]\nnumberOfIR=999999\nIR0=0,a\n",
            ":4:12: error: numberOfIR=999999 but [Input Registers] has 1",
        ),
        (
            "[Input Registers]\nnumberOfIR=4\nIR1=0,a\n",
            ":4:12: error: numberOfIR=4 but [Input Registers] has no IR0, IR2..IR3",
        ),
        ("garbage\n", ":3:1: error: not a [section], a key=value line or a comment"),
        # every register of a 32-bit datatype counts, not only its offset
        (
            "[Holding Registers]\nnumberOfR=3\nR0=0,A,0,0,1,V,1\nR1=1,B,0,0,1,V,0\nR2=3,C,,,,,5\n",
            ":6:4: error: R1: reads register 1 of the holding table; register 1 is already read by R0 (line 5: "
            "registers 0-1)",
        ),
        (
            "[Holding Registers]\nnumberOfR=2\nR0=1,A,0,0,1,V,0\nR1=0,B,0,0,1,V,7\n",
            ":6:4: error: R1: reads registers 0-1 of the holding table; register 1 is already read by R0 (line 5: "
            "register 1)",
        ),
        (
            "[Analog Output]\nnumberOfAO=1\nAO0=10,A,0,0,1,V,8\n[Holding Registers]\nnumberOfR=1\nR0=11,B,0,0,1,V,2\n",
            ":8:4: error: R0: reads registers 11-12 of the holding table; register 11 is already read by AO0 (line 5: "
            "registers 10-11)",
        ),
        (
            "[Input Registers]\nnumberOfIR=1\nIR0=65535,a,0,1,1,V,5\n",
            ":5:5: error: IR0: datatype 5 reads two registers, and offset 65535 is the table's last (65535)",
        ),
    ],
)
def test_bad_lines(tmp_path, body, message):
    ini = tmp_path / "Modbus.ini"
    ini.write_text("[Platform]\nName=x\n" + body)
    assert_clean_error(cli("import", ini, "--from", "wise"), 1, str(ini) + message)


def test_warnings_and_notes(tmp_path):
    ini = tmp_path / "dev.ini"
    ini.write_bytes(
        "[Platform]\nSlaveIP=10.0.0.1\n[Misc]\nx=1\n[Input Registers]\nnumberOfIR=2\nIR0=0,t,9,1,1,\xb0C\n"
        "IR1=1,z,0,0,1,V\nfoo=3\n[Coils]\nnumberOfB=1\nB0=0,a,extra\n".encode("cp1252")
    )
    proc = cli("import", ini, "--from", "wise")
    assert proc.returncode == 0, proc.stderr
    for fragment in (
        "note: not UTF-8: read as cp1252",
        "dev.ini:2: note: [Platform] SlaveIP=10.0.0.1",
        "dev.ini:1: note: no [Platform] Name: the device is named 'dev'",
        "dev.ini:3:1: warning: unknown section [Misc]",
        "dev.ini:7:9: warning: IR0 't': min 9 is above max 1",
        "dev.ini:8:9: note: IR1 'z': min and max are both 0: read as no range",
        "dev.ini:9:1: warning: [Input Registers] has no key 'foo'",
        "dev.ini:12:8: warning: B0: a bit line is offset,name",
    ):
        assert fragment in proc.stderr
    assert "<units>&#176;C</units>" in proc.stdout and "<minimum>1</minimum>" in proc.stdout
    assert "<maximum>9</maximum>" in proc.stdout
    assert_clean_error(cli("import", ini, "--from", "wise", "--fail-on-warning"), 1, "warnings and --fail-on-warning")


def test_standard_input():
    proc = cli("import", "-", "--from", "wise", input=SEED.read_text())
    assert proc.returncode == 0, proc.stderr
    assert "<name>WISE-4012E</name>" in proc.stdout
    assert_clean_error(
        cli("import", "-", "--from", "wise", input="[Coils]\nnumberOfB=2\n"),
        1,
        "<stdin>:2:11: error: numberOfB=2 but [Coils] has no B0..B1",
    )


# --- export ------------------------------------------------------------------------------------------------


def test_export_writes_the_agent_form(tmp_path):
    ALL = DATA / "all_tables.xml"
    proc = cli(
        "export", ALL, "--to", "wise", "--host", "192.0.2.10", "--port", "1502", "--unit", "3", "--interval", "5"
    )
    assert proc.returncode == 0, proc.stderr
    text = proc.stdout
    assert (
        "[Platform]\nName=All Tables\nProtocol=Modbus_TCP\nClientIP=192.0.2.10\nClientPort=1502\nUnitID=3\n"
        "Interval=5\nLog=0\n" in text
    )
    assert "[Coils]\nnumberOfB=3\nB0=0,pump\nB1=1,fan\nB2=5,alarm_reset\n" in text
    assert "IR0=0,energy,0,4294967.295,0.001,kWh,6\n" in text
    assert 'R4=300,temp_offset,-40,32727.5,1, ,0,"modbus_val*0.5-40"\n' in text
    assert "R2=100,setpoint,5,35,0.1,°C,0\n" in text
    warned: dict[str, str] = {}  # each function's warnings: one per kind, naming all its functions (issue 20)
    for d in said(proc.stderr):
        for name in d["names"]:
            warned[name] = warned.get(name, "") + f"{d['subject']}: {d['kind']}\n"
    for name, why in (
        ("label", "not written: text"),
        ("flow", "not written: read by a C fragment"),
        ("big", "(64 bits): not written: a value of neither 16 nor 32 bits"),
        ("serial", "(UINT32 with byte order little and word order big): not written"),
        ("low_byte", "(lower), 'high_byte' (upper): not written: a byte of a register"),
        ("mode", "written, losing its enumeration"),
        ("voltage", "(0xFFFF): written, losing its not_implemented"),
        ("setpoint", "(INT16): written, losing a signed format"),
        ("alarm_reset", "(write, coil): written, losing its access"),
    ):
        assert why in warned[name], (name, warned[name])
    # each function's warning names its line in the description, as the engine exports do
    assert f"{ALL}:98: warning: function 'label': not written: text" in proc.stderr
    assert f"{ALL}:91: warning: function 'mode': written, losing its enumeration" in proc.stderr
    assert f"{ALL}:81: warning: functions 'setpoint', 'temp_offset' (INT16): written, losing a signed" in proc.stderr
    assert f"{ALL}: note: " not in proc.stderr and "written without the device's" not in proc.stderr
    assert (
        cli(
            "export", ALL, "--to", "wise", "--host", "192.0.2.10", "--port", "1502", "--unit", "3", "--interval", "5"
        ).stdout
        == text
    )  # deterministic
    out = tmp_path / "Modbus.ini"
    assert cli("export", ALL, "--to", "wise", "-o", out).returncode == 0
    assert "ClientIP=127.0.0.1\nClientPort=502\nUnitID=1\nInterval=60\n" in out.read_text()
    assert_clean_error(cli("export", ALL, "--to", "wise", "--fail-on-warning", "-o", tmp_path / "no.ini"), 1)
    assert not (tmp_path / "no.ini").exists()


def test_export_serial_and_odd_settings():
    proc = cli(
        "export",
        SEED,
        "--to",
        "wise",
        "--serial",
        "/dev/ttyUSB0",
        "--baud",
        "9600",
        "--parity",
        "E",
        "--unit",
        "7",
        "--interval",
        "0.4",
    )
    assert proc.returncode == 0, proc.stderr
    assert (
        "Protocol=Modbus_RTU\nSlavePort=/dev/ttyUSB0\nBaud=9600\nParity=Even\nDataBits=8\nStopBits=1\nSlaveID=7\n"
        "Interval=1\n"
    ) in proc.stdout
    assert "Interval=1 for --interval 0.4" in proc.stderr
    assert "block labels 'Analog Input', 'Digital Input', 'Digital Output' are not kept" in proc.stderr
    proc = cli("export", SEED, "--to", "wise", "--host", "10.0.0.2", "--framer", "rtu")
    assert "not RTU frames over TCP: written as Protocol=Modbus_TCP" in proc.stderr
    assert "[Discrete Inputs]\nnumberOfIB=2\nIB0=0,Switch0\nIB1=1,Switch1\n" in proc.stdout
    assert "IR0=0,Voltage0,0,5,0.001,V,0\n" in proc.stdout


def test_export_names_and_clashes(write_device):
    path = write_device(
        fn_xml('a, "b"', "0", format="UINT16")
        + fn_xml("a_ _b_", "1", format="UINT16")
        + fn_xml("again", "0", format="INT16", register_type="holding")
        + fn_xml("pair", "10 11", format="FLOAT32")
        + fn_xml("reversed", "21 20", format="UINT32")
        + fn_xml("apart", "30 32", format="UINT32")
        + fn_xml("shown", "40", format="UINT16", precision="2", units="a,b")
    )
    proc = cli("export", path, "--to", "wise")
    assert proc.returncode == 0, proc.stderr
    assert "R0=0,a_ _b_,0,65535,1, ,0\nR1=1,a_ _b__2,0,65535,1, ,0\nR2=10,pair," in proc.stdout
    assert "R3=20,reversed,0,4294967295,1, ,6\nR4=40,shown,0,65535,1,a_b,0\n" in proc.stdout
    assert (
        f"{path}:5: warning: functions 'a, \"b\"' (as 'a_ _b_'), 'a_ _b_' (as 'a_ _b__2'): written under "
        "another name" in proc.stderr
    )  # one warning for the kind, at its first function's line
    for fragment in (
        "function 'again' (holding 0: 'a, \"b\"'): not written: its offset is taken",
        "function 'apart' (registers 30 and 32): not written: registers not next to each other",
        "function 'shown' (precision): written, losing fields a Modbus.ini line has not",
        "function 'shown' ('a,b'): written, losing the commas, quotes and control characters of its unit",
    ):
        assert fragment in proc.stderr, fragment


# --- round trips -------------------------------------------------------------------------------------------


def _descriptions(tmp_path) -> list[Path]:
    files = sorted(ROOT.glob("examples/**/*.xml")) + sorted(DATA.glob("*.xml"))
    heat_pump = tmp_path / "heat_pump.xml"
    proc = cli("import", ROOT / "examples" / "toolkit_heat_pump" / "heat_pump.yaml", "-o", heat_pump)
    assert proc.returncode == 0, proc.stderr
    return [*files, heat_pump]


def _random_registers(path: Path, rng: random.Random) -> dict:
    from mdl.formats.loading import load_resolved

    tables: dict[str, dict[int, int]] = {}
    for rf in load_resolved(path).functions:
        for address in rf.layout.addresses:
            bit = rf.layout.table in ("coil", "discrete")
            tables.setdefault(rf.layout.table, {})[address] = rng.randrange(2) if bit else rng.randrange(0x10000)
    return tables


@pytest.mark.commands  # serves or dials a device
def test_round_trips_read_the_same_values(sim_factory, tmp_path):
    """MDL -> WISE -> MDL: every function written without a warning reads the same value from the same
    simulated device; every other function is named by a warning."""
    rng = random.Random(20240610)
    checked = 0
    for path in _descriptions(tmp_path):
        ini = tmp_path / f"{path.stem}.ini"
        proc = cli("export", path, "--to", "wise", "-o", ini)
        assert proc.returncode == 0, (path, proc.stderr)
        warned = {name for d in said(proc.stderr) if d["severity"] == "warning" for name in d["names"]}
        back = tmp_path / f"{path.stem}.wise.xml"
        proc = cli("import", ini, "-o", back)
        assert proc.returncode == 0, (path, proc.stderr)
        sim = sim_factory(path, "--registers", raw_file(tmp_path, _random_registers(path, rng)))
        original = read_json(path, sim)
        again = read_json(back, sim)
        readable = set(original)
        assert set(again) <= readable | warned, path  # a write-only coil reads in WISE: a warning says so
        differ = {n for n in again if n in readable and again[n] != original[n]}
        assert differ <= warned, (path, {n: (original[n], again[n]) for n in differ - warned})
        assert readable - set(again) <= warned, path  # left out: a warning says so
        checked += len(set(again) & readable - differ)
    assert checked >= 15


def test_32_bit_entries_side_by_side_and_every_clash_reported(tmp_path):
    """32-bit entries next to each other import; every entry reading another's register is an error, all
    reported at once (a bit table's entries read one bit each)."""
    ini = tmp_path / "Modbus.ini"
    ini.write_text(
        "[Platform]\nName=x\n[Coils]\nnumberOfB=2\nB0=0,c0,0,0,1,V,1\nB1=1,c1\n"
        "[Input Registers]\nnumberOfIR=3\nIR0=0,a,0,1,1,V,1\nIR1=2,b,0,1,1,V,8\nIR2=4,c,0,1,1,V,0\n"
    )
    assert cli("import", ini).returncode == 0  # c0's text after its name is ignored: no datatype on a bit line
    text = ini.read_text().replace("IR2=4", "IR2=3") + "[Holding Registers]\nnumberOfR=2\nR0=0,d\nR1=0,e\n"
    ini.write_text(text)
    proc = cli("import", ini)
    assert_clean_error(
        proc,
        1,
        f"{ini}:11:5: error: IR2: reads register 3 of the input table; register 3 is "
        "already read by IR1 (line 10: registers 2-3)",
        f"{ini}:15:4: error: R1: offset 0 of the holding table is already R0's (line 14)",
    )


LUA = WISE / "lua.ini"
LUA_NOTE = "(WISE Lua conversion, not applied: "


def _kept_description(xml: str) -> list[str]:
    return re.findall(r"<description>(.*?)</description>", xml)[1:]


def test_lua_kept_in_the_description_goes_back_into_the_lua_column(tmp_path):
    """WISE -> MDL -> WISE: a Lua column MDL cannot apply is kept at the end of the description and written
    back into the Lua column as it was; a warning says so each way, with the line."""
    xml = tmp_path / "lua.xml"
    proc = cli("import", LUA, "-o", xml)
    assert proc.returncode == 0, proc.stderr
    assert (
        f"{LUA}:5:23: warning: R0 'Temp': the Lua column 'math.floor(modbus_val/10)' is not plain arithmetic on "
        "modbus_val: kept in the description (export writes it back), not applied"
    ) in proc.stderr
    assert _kept_description(xml.read_text()) == [f"Temp {LUA_NOTE}math.floor(modbus_val/10))"]
    back = tmp_path / "back.ini"
    proc = cli("export", xml, "--to", "wise", "-o", back)
    assert proc.returncode == 0, proc.stderr
    assert 'R0=0,Temp,0,100,1,C,0,"math.floor(modbus_val/10)"\n' in back.read_text()
    assert (
        f"{xml}:5: warning: function 'Temp' ('math.floor(modbus_val/10)'): written with the Lua conversion its "
        "description keeps: the agent applies it, mdl does not"
    ) in proc.stderr
    again = cli("import", back)
    assert again.returncode == 0, again.stderr
    assert _kept_description(again.stdout) == _kept_description(xml.read_text())


@pytest.mark.parametrize(
    "name, column, lua",
    [
        ("Rooted", '"math.pow(modbus_val,1/2)+10-2.5"', "math.pow(modbus_val,1/2)+10-2.5"),  # a comma inside quotes
        ("T (x)", '"modbus_val > 100 and (1) or (0)"', "modbus_val > 100 and (1) or (0)"),  # parentheses everywhere
        ("On", "modbus_val..'V'", "modbus_val..'V'"),  # unquoted
        ("Commented", '"math.floor(modbus_val) -- rounds down"', "math.floor(modbus_val) -- rounds down"),
    ],
)
def test_lua_round_trips_exactly(tmp_path, name, column, lua):
    ini = tmp_path / "Modbus.ini"
    ini.write_text(f"[Platform]\nName=L\n[Input Registers]\nnumberOfIR=1\nIR0=7,{name},0,10,0.1,V,1,{column}\n")
    xml = tmp_path / "l.xml"
    assert cli("import", ini, "-o", xml).returncode == 0
    proc = cli("export", xml, "--to", "wise")
    assert proc.returncode == 0, proc.stderr
    assert re.findall(r"^IR0=(.*)$", proc.stdout, re.M) == [f'7,{name},0,10,0.1,V,1,"{lua}"']
    assert f"function '{name}' ('{lua}'): written with the Lua conversion its description keeps" in proc.stderr


def test_lua_in_a_description_with_an_offset_a_bit_or_a_quote(write_device):
    """The Lua column holds both the kept conversion and the offset (the agent runs the Lua on the raw
    value, then multiplies by the precision); what cannot be written is a warning naming the function."""

    def kept(xml: str, name: str, lua: str) -> str:
        return xml.replace(f"<description>{name}</description>", f"<description>{name} {LUA_NOTE}{lua})</description>")

    functions = (
        kept(
            fn_xml("scaled", "0", format="UINT16", multiplier="0.5", offset="3"), "scaled", "math.floor(modbus_val/10)"
        )
        + kept(fn_xml("neg", "1", format="UINT16", offset="-2"), "neg", "math.abs(modbus_val)")
        + kept(fn_xml("switch", "0", format="BIT", register_type="coil"), "switch", "modbus_val")
        + kept(fn_xml("quoted", "2", format="UINT16"), "quoted", "modbus_val..&quot;V&quot;")
        + kept(fn_xml("comment", "3", format="UINT16", offset="1"), "comment", "f(modbus_val) -- x")
        + fn_xml("plain", "4", format="UINT16").replace("<description>plain", "<description>plain (note)")
    )
    path = write_device(functions)
    proc = cli("export", path, "--to", "wise")
    assert proc.returncode == 0, proc.stderr
    assert 'R0=0,scaled,3,32770.5,1, ,0,"(math.floor(modbus_val/10))*0.5+3"\n' in proc.stdout
    assert 'R1=1,neg,-2,65533,1, ,0,"(math.abs(modbus_val))-2"\n' in proc.stdout
    assert "B0=0,switch\n" in proc.stdout
    assert "R2=2,quoted,0,65535,1, ,0\n" in proc.stdout
    assert 'R3=3,comment,1,65536,1, ,0,"modbus_val+1"\n' in proc.stdout
    assert "R4=4,plain,0,65535,1, ,0\n" in proc.stdout
    for fragment in (
        "functions 'scaled' ('math.floor(modbus_val/10)'), 'neg' ('math.abs(modbus_val)'): written "
        "with the Lua conversion its description keeps",
        "function 'switch' ('modbus_val'): written, losing the Lua conversion its description keeps "
        "(a bit line has no Lua column)",
        "function 'quoted' ('modbus_val..\"V\"'): written, losing the Lua conversion its description "
        "keeps (quotes and control characters",
        "function 'comment' ('f(modbus_val) -- x'): written, losing the Lua conversion its description "
        "keeps (its `--` comment",
    ):
        assert fragment in proc.stderr, fragment
    assert "'plain'" not in proc.stderr


def test_lua_holding_the_note_itself_is_not_guessed(tmp_path):
    """A name or Lua text holding the note's own opening: where the Lua starts is not clear, so it is not
    written back, and a warning says so (rather than writing a piece of it)."""
    ini = tmp_path / "Modbus.ini"
    ini.write_text(
        f'[Platform]\nName=L\n[Holding Registers]\nnumberOfR=1\nR0=0,a,0,1,1,V,0,"f(modbus_val) {LUA_NOTE}x)"\n'
    )  # a name cannot hold it: it has a comma
    xml = tmp_path / "l.xml"
    assert cli("import", ini, "-o", xml).returncode == 0
    proc = cli("export", xml, "--to", "wise")
    assert proc.returncode == 0, proc.stderr
    assert "R0=0,a,0,1,1,V,0\n" in proc.stdout
    assert (
        f"{xml}:5: warning: function 'a': written, losing the Lua conversion its description keeps (it holds "
        f"'{LUA_NOTE}' twice" in proc.stderr
    )


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=40), st.text(min_size=1, max_size=60), st.sampled_from(["", LUA_NOTE, ")"]))
def test_fuzz_kept_lua(name, lua, extra):
    """The Lua text kept in a description comes back exactly unless the note's opening is there twice (then
    none is taken); any description gives a text, None or 'twice', never another exception."""
    from mdl.formats.wise.lua import kept_in_description, kept_lua, kept_twice

    description = kept_in_description(name + extra, lua)
    if kept_twice(description):
        assert LUA_NOTE in name + extra + lua
    else:
        assert kept_lua(description) == lua
    for text in (name, name + extra + lua):
        got = kept_lua(text)
        assert got is None or (isinstance(got, str) and got)


def test_wise_round_trip_keeps_the_file(tmp_path):
    """WISE (agent form) -> MDL -> WISE writes the same entries again."""
    xml = tmp_path / "d.xml"
    assert cli("import", DATATYPES, "-o", xml).returncode == 0
    proc = cli("export", xml, "--to", "wise", "--serial", "COM6")
    assert proc.returncode == 0, proc.stderr
    entries = re.findall(r"^IR\d+=(.*)$", proc.stdout, re.M)
    source = re.findall(r"^IR\d+=(.*)$", DATATYPES.read_text(), re.M)
    assert entries == source
    assert 'R0=0,Scaled,-10,1000,1,V,0,"modbus_val-5"' in proc.stdout  # (m*2-10)*0.5 -> modbus_val*1-5


# --- fuzzing the reader ------------------------------------------------------------------------------------

PIECES = [
    "\n",
    "\r\n",
    "\r",
    "[",
    "]",
    "=",
    ",",
    '"',
    "#",
    ";",
    " ",
    "\t",
    "\x00",
    "\ufeff",
    "[Platform]",
    "Name=",
    "[Coils]",
    "[Holding Registers]",
    "[Analog Input]",
    "numberOfR=",
    "numberOfB=2",
    "R0=",
    "B1=",
    "AI0=",
    "0",
    "1",
    "65536",
    "-1",
    "1e999",
    "nan",
    "0.001",
    "9",
    "modbus_val",
    "modbus_val*2-10",
    "((((",
    "--",
    "é",
]
SEEDS = [SEED.read_text(), HANDLER.read_text(), DATATYPES.read_text(), (WISE / "bad.ini").read_text()]


@st.composite
def mangled(draw: st.DrawFn) -> str:
    text = draw(st.sampled_from(SEEDS))
    for _ in range(draw(st.integers(1, 8))):
        at = draw(st.integers(0, len(text)))
        cut = draw(st.integers(0, 12))
        text = text[:at] + draw(st.sampled_from(PIECES)) + text[at + cut :]
    return text


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(mangled(), st.lists(st.sampled_from(PIECES), max_size=60).map("".join), st.text(max_size=300)))
def test_fuzz_reader_gives_a_device_or_an_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "Modbus.ini"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    try:
        device = read_wise(path)
    except MdlError as exc:
        assert exc.diagnostics and all(d.file == str(path) for d in exc.diagnostics)
        return
    from mdl.resolver import resolve

    try:
        resolve(device, str(path))
    except MdlError:
        pass


def test_fuzz_controls():
    """The fuzz test's two outcomes both happen: the seeds import, a bad file is refused."""
    assert read_wise(SEED).functions
    with pytest.raises(MdlError):
        read_wise(WISE / "bad.ini")
