"""Corpus: energy meters and EV chargers as their register tables are published (issue 22). Each table
is converted with the INI a user wrote from docs/ alone, served by `mdl sim` with raw registers worked
out by hand from the vendor's documented encoding, and read back with `mdl read` (tests/support/corpus.py).
Sources, licences and what was read: tests/data/corpus/README.md (section "meters")."""

from __future__ import annotations

import json

import pytest

from support.corpus import CORPUS, check_table, convert
from support.run import run_mdl

METERS = CORPUS / "meters"

pytest.importorskip("openpyxl")  # the Etrel workbook


def words(first: int, *values: int) -> dict[str, int]:
    """Consecutive registers from FIRST: {"first": v0, "first+1": v1, ...}."""
    return {str(first + i): v for i, v in enumerate(values)}


def write_and_read_back(tmp_path, sim_factory, name: str, value: float) -> object:
    """After check_table: serve its description (tmp_path/out.xml, raw image tmp_path/raw.json) again,
    `mdl write NAME=VALUE`, and return what `mdl read` gives for NAME."""
    xml, raw = tmp_path / "out.xml", tmp_path / "raw.json"
    sim = sim_factory(xml, "--registers", raw)
    where = ("--host", sim.host, "--port", sim.port)
    wrote = run_mdl("write", xml, *where, f"{name}={value}")
    assert wrote.returncode == 0, wrote.stderr
    read = run_mdl("read", xml, *where, name, "--format", "json")
    assert read.returncode == 0, read.stderr
    return json.loads(read.stdout)[name]


# --- go-e Controller (Markdown page of the vendor's API docs) ------------------------------------

GOE_TABLE = METERS / "goe_controller_modbus.md"

BRACKETED_LISTS = (
    "TOOL DEFECT: a cell '31001 (1000) <br /> 31002 (1001)' (Modicon number with its wire address in "
    "brackets, one per register, split by line breaks) is 'not an address', though docs/csv2xml.md says "
    "'`30101 (100)` ... the bracket is the address' and 'Address lists may be split by line breaks as by commas'"
)


def test_goe_controller_live_values(tmp_path, sim_factory):
    """go-e (Austria), go-e Controller home energy meter: the vendor's Modbus page is a Markdown file
    with four tables (function codes, API keys, input and holding registers); each register cell lists
    every register of the value as 'Modicon number (wire address)' joined by <br />, Float32 and Float64
    values (four registers), HTML comments as table rows, and an empty Description column (the Name
    column is the text to match). Float words are read big-endian: the page's swap options `msb`/`msr`
    (swap bytes, swap registers) are taken as left off."""
    registers = {
        "input": {
            **words(1000, 0x4366, 0x8000),  # Voltage L1 230.5 V
            **words(1010, 0x40F0, 0x0000),  # Current Sensor 1 Current 7.5 A
            **words(1034, 0x3F40, 0x0000),  # Current Sensor 1 Powerfactor 0.75
            **words(1080, 0xC4BE, 0x0800),  # Category Grid Power -1520.25 W (exporting)
            **words(1082, 0x4167, 0x8C29, 0xD000, 0x0000),  # Category Grid Energy In 12345678.5 Wh
            **words(1108, 0x412E, 0x240C, 0x8000, 0x0000),  # Category Car Energy In 987654.25 Wh
        }
    }
    expected = {
        "voltage_l1": 230.5,
        "sensor1_current": 7.5,
        "sensor1_pf": 0.75,
        "grid_power": -1520.25,
        "grid_energy_in": 12345678.5,
        "car_energy_in": 987654.25,
    }
    proc, fns = check_table(tmp_path, sim_factory, GOE_TABLE, METERS / "goe_controller.ini", registers, expected)
    assert fns["grid_energy_in"]["format"] == "FLOAT64"
    assert fns["grid_energy_in"]["addresses"] in ("1082", "1082 1083 1084 1085")
    assert "read table 3" in proc.stderr  # the first whose header holds an address column
    # the <!-- MODBUS-SET-ADDR --> rows hold no address: skipped silently, never a warning
    assert "'<!' is not an address" not in proc.stderr


def test_goe_controller_holding_table(tmp_path, sim_factory):
    """go-e Controller, the page's fourth table (holding registers, chosen with --table 4): its headers
    are German in the English page (Registertyp, Datentyp, Einheit) and its one value is the controller
    clock, an Int64 of milliseconds over four registers ('40001 (0) <br /> ... 40004 (3)')."""
    registers = {"holding": words(0, 0x0000, 0x019B, 0x76DA, 0xA800)}  # 1767225600000 ms: 2026-01-01 UTC
    expected = {"unix_time_ms": 1767225600000}
    proc, fns = check_table(
        tmp_path, sim_factory, GOE_TABLE, METERS / "goe_controller_holding.ini", registers, expected, "--table", "4"
    )
    assert fns["unix_time_ms"]["format"] == "INT64"


def test_goe_controller_comment_after_table_is_no_row(tmp_path):
    """go-e Controller: the line after the holding table's only row is an HTML comment, not a table row
    (docs/csv2xml.md: rows start and end with |), so nothing is said about it."""
    proc, _, _ = convert(tmp_path, GOE_TABLE, METERS / "goe_controller_holding.ini", "--table", "4")
    assert "goe_controller_modbus.md:233:" not in proc.stderr


# --- Etrel INCH (Excel workbook) -------------------------------------------------------------------

ETREL_TABLE = METERS / "etrel_inch_registers.xlsx"


def test_etrel_inch_read_registers(tmp_path, sim_factory):
    """Etrel (Slovenia), INCH wallbox (sold as the sonnenCharger): the vendor's workbook has three title
    rows above the header, section rows with no address between the registers, headers with stray spaces
    ('Parameter ', ' Words'), addresses as text cells starting at 0, 'ASCII' strings of 10 registers,
    Int16 enumerations, Float32, Int32 and Int64 values, one sheet for reads and one for writes."""
    registers = {
        "input": {
            "0": 4,  # Connnector status: 4 = Charging (sheet "Enumerations", ConnectorStatus)
            **words(2, 0x4180, 0x0000),  # EV max phase current 16.0 A
            **words(8, 0x4366, 0x8000),  # L-N voltage (L1) 230.5 V
            **words(26, 0x4134, 0x0000),  # Active power (total) 11.25 kW
            **words(32, 0x0000, 0x0000, 0x0000, 0x1518),  # Running session duration 5400 s
            **words(990, 0x4554, 0x3132, 0x3334, 0x3536, 0x3758),  # Serial number "ET1234567X"
            **words(1020, 0x0000, 0x0001),  # Number of connectors 1
        }
    }
    expected = {
        "connector_status": 4,
        "ev_max_current": 16.0,
        "voltage_l1": 230.5,
        "active_power_total": 11.25,
        "session_duration": 5400,
        "connectors": 1,
        "serial_number": "ET1234567X",
    }
    proc, fns = check_table(tmp_path, sim_factory, ETREL_TABLE, METERS / "etrel_inch.ini", registers, expected)
    assert fns["session_duration"]["format"] == "INT64"
    assert fns["serial_number"]["format"] == "STRING"
    assert fns["serial_number"]["count"] == "10"
    # the guesses it makes are said: which sheet, what the lines are, what the counts count
    assert "read sheet 'ReadRegisters'" in proc.stderr
    assert "counts in column 4 'Words' read as registers" in proc.stderr
    assert "format cell 'ASCII' on line 27 (and any like it) read as 'STRING'" in proc.stderr


def test_etrel_inch_write_registers(tmp_path, sim_factory):
    """Etrel INCH, sheet 'Write registers' (--sheet): holding registers for function code 16, command
    rows with no type (a write triggers them) between Float32 setpoints; the current setpoint's text has
    two spaces after the bullet ('Connector 1 •  Set current setpoint')."""
    registers = {
        "holding": {
            **words(8, 0x4148, 0x0000),  # Set current setpoint 12.5 A
            **words(2000, 0x40F0, 0x0000),  # Cluster Set limit (L1) 7.5 A
        }
    }
    expected = {"current_setpoint": 12.5, "cluster_limit_l1": 7.5}
    proc, fns = check_table(
        tmp_path,
        sim_factory,
        ETREL_TABLE,
        METERS / "etrel_inch_write.ini",
        registers,
        expected,
        "--sheet",
        "Write registers",
    )
    assert fns["current_setpoint"].get("register_type", "holding") == "holding"
    assert fns["current_setpoint"]["format"] == "FLOAT32"
    assert "read sheet 'Write registers'" in proc.stderr
    # the point of the sheet: an energy manager writes the charging current
    assert write_and_read_back(tmp_path, sim_factory, "current_setpoint", 8.5) == 8.5


def test_etrel_function_code_column_is_one_error(tmp_path):
    """Etrel INCH: the workbook's 'F. Code' column (4 on every read row) named in the INI as
    `read_function_code`, the key whose name says "function code". Its cells are no C fragment, so the
    right outcome is the documented one: exit 1 with one error naming the column, not a warning per row
    and an error blaming the addresses."""
    ini = tmp_path / "etrel_fc.ini"
    text = (METERS / "etrel_inch.ini").read_text(encoding="utf-8")
    text = text.replace("function_code = F. Code", "")  # the column leaves [Additional Column/Field Indices]
    text = text.replace("format             = Type", "format = Type\nread_function_code = F. Code")
    ini.write_text(text, encoding="utf-8")
    proc, _, _ = convert(tmp_path, ETREL_TABLE, ini)
    assert proc.returncode == 1
    assert "F. Code" in proc.stderr
    assert "usable address" not in proc.stderr
    assert "row skipped" not in proc.stderr


# --- Eastron SDM120 (Markdown inventory in an open-source integration) -----------------------------

SDM120_TABLE = METERS / "eastron_sdm120_registers.md"


def test_eastron_sdm120(tmp_path, sim_factory):
    """Eastron SDM120-Modbus single-phase meter: Modicon register numbers of five and six digits
    (30001, 40013, 463745 for holding 0xF900), a 'Length' column counting bytes (4 for a float), a
    second 'Address (Hex)' column written '00 0C', Eastron's 'HEX' type, 'None' as a unit, RO/RW access,
    and the same wire address in two tables (input 12 'Active power', holding 12 'Relay Pulse Width')."""
    registers = {
        "input": {
            **words(0, 0x4368, 0x4000),  # Voltage 232.25 V
            **words(12, 0xC4BE, 0x0800),  # Active power -1520.25 W (exporting)
            **words(30, 0x3F00, 0x0000),  # Power factor 0.5
            **words(72, 0x449A, 0x5000),  # Import active energy 1234.5 kWh
        },
        "holding": {
            **words(12, 0x42C8, 0x0000),  # Relay Pulse Width 100.0 ms
            "63744": 10,  # Time of scroll display 10 s
            **words(64512, 0x00BC, 0x614E),  # Serial number 12345678
            "64514": 0x0020,  # Meter code 0x0020
        },
    }
    expected = {
        "voltage": 232.25,
        "active_power": -1520.25,
        "power_factor": 0.5,
        "import_energy": 1234.5,
        "relay_pulse_width": 100.0,
        "scroll_time": 10,
        "serial_number": 12345678,
        "meter_code": 32,
    }
    proc, fns = check_table(tmp_path, sim_factory, SDM120_TABLE, METERS / "eastron_sdm120.ini", registers, expected)
    assert fns["scroll_time"]["addresses"] == "63744"
    assert fns["relay_pulse_width"].get("register_type", "holding") == "holding"
    assert fns["active_power"]["register_type"] == "input"
    # two guesses the table forces, both said with the key that overrides them
    assert "addresses read as Modicon register numbers" in proc.stderr
    assert "counts in column 3 'Length' read as bytes" in proc.stderr
    # 'RW' in the Access column: the relay pulse width (60, 100 or 200 ms) is a setting
    assert write_and_read_back(tmp_path, sim_factory, "relay_pulse_width", 200.0) == 200.0


# --- go-e Charger (Markdown page of the vendor's API v1 docs) --------------------------------------

GOE_CHARGER_TABLE = METERS / "goe_charger_modbus_v1.md"


def test_goe_charger_v1(tmp_path, sim_factory):
    """go-e (Austria), go-e Charger HOME+ (API v1): a Markdown page whose register cells list every
    register of a value split by <br> ('108<br>109', '110 <br>111'), types in words ('unsigned integer
    (32)', 'ascii (12 byte)', mapped in the INI), a misspelt 'Lenght' count column, names in capitals
    (CAR_STATE) beside prose descriptions, and scales given only in that prose ('Amps on L1 in 0.1A',
    'Total power in 0.01kW'), so the INI gives them per function; PHASES is a byte of bit flags."""
    registers = {
        "input": {
            "100": 2,  # CAR_STATE 2: Car is charging
            **words(108, 0x0000, 0x00E7),  # VOLT_L1 231 V
            **words(114, 0x0000, 0x007B),  # AMP_L1 123 x 0.1 A = 12.3 A ("123 equals 12, 3A")
            **words(120, 0x0000, 0x0168),  # POWER_TOTAL 360 x 0.01 kW = 3.6 kW
            **words(128, 0x0001, 0xE240),  # ENERGY_TOTAL 123456 x 0.1 kWh = 12345.6 kWh
            "205": 0b00111000,  # PHASES: phases 1-3 before the contactor (C = bit 3 set)
            **words(304, 0x474F, 0x4531, 0x3233, 0x3435, 0x3637, 0x3839),  # SNR "GOE123456789"
        },
        "holding": {"299": 16},  # AMPERE_VOLATILE 16 A
    }
    expected = {
        "car_state": 2,
        "volt_l1": 231,
        "amp_l1": 12.3,
        "power_total": 3.6,
        "energy_total": 12345.6,
        "phase1_before_contactor": True,
        "serial_number": "GOE123456789",
        "ampere_volatile": 16,
    }
    proc, fns = check_table(
        tmp_path, sim_factory, GOE_CHARGER_TABLE, METERS / "goe_charger_v1.ini", registers, expected
    )
    assert fns["volt_l1"]["format"] == "UINT32"
    assert fns["phase1_before_contactor"]["bits"] == "3"
    # the row the page could not type is said, the others still convert
    assert "goe_charger_modbus_v1.md:98: warning: row skipped" in proc.stderr
    assert "unknown format 'unsigned integer (48)'" in proc.stderr
    # AMPERE_VOLATILE is a holding register the page says is writable: the charging current setpoint
    assert write_and_read_back(tmp_path, sim_factory, "ampere_volatile", 10) == 10


def test_goe_charger_width_disagreements_are_said(tmp_path):
    """go-e Charger: the page contradicts itself on two text rows. HOSTNAME lists five registers
    (310-314) but says 'ascii (12 byte)' and Lenght 6; GATEWAY says 'ascii (4 byte)' but lists four
    registers with Lenght 4. Whichever reading csv2xml takes, it must say so (docs/csv2xml.md: the
    count wins over a text format's width, with a note; every guess is said)."""
    proc, fns, _ = convert(tmp_path, GOE_CHARGER_TABLE, METERS / "goe_charger_v1.ini", "--all")
    assert proc.returncode == 0, proc.stderr
    assert "goe_charger_modbus_v1.md:100:" in proc.stderr  # HOSTNAME
    assert "goe_charger_modbus_v1.md:103:" in proc.stderr  # GATEWAY


# --- Alfen NG9xx (vendor document, Markdown transcription) -----------------------------------------

ALFEN_TABLE = METERS / "alfen_ng9xx_modbus_slave.md"

ALFEN_REGISTERS = {
    "holding": {
        **words(301, 0x0000, 0x0000, 0x0000, 0x05DC),  # Meter last value timestamp 1500 x 0.001 s
        **words(306, 0x4366, 0x8000),  # Voltage Phase V(L1-N) 230.5 V
        **words(320, 0x417C, 0x0000),  # Current Phase L1 15.75 A
        **words(344, 0x45E6, 0x0400),  # Real Power Sum 7360.5 W
        **words(374, 0x4132, 0xD687, 0x4000, 0x0000),  # Real Energy Delivered Sum 1234567.25 Wh
        **words(1201, 0x4332, 0x0000, 0x0000, 0x0000, 0x0000),  # Mode 3 state "C2", zero-terminated
        **words(1210, 0x4180, 0x0000),  # Modbus Slave Max Current 16.0 A
        "1215": 3,  # Charge using 1 or 3 phases: 3
    }
}


def test_alfen_ng9xx_socket(tmp_path, sim_factory):
    """Alfen (Netherlands), NG9xx charging stations (Eve Single/Double Pro-line): the vendor's Modbus
    document as Markdown, eight tables in one file (the socket registers are the seventh); names in
    bold, LaTeX and citation marks left by the PDF conversion, Start and End Address columns, a 'Step'
    column holding resolution and unit in one cell (1V, 0.001s, 1Wh, n.a.), FLOAT64 energies, a
    zero-terminated 5-register STRING, and two writable settings (the EMS current setpoint and 1 or 3
    phase charging)."""
    expected = {
        "voltage_l1": 230.5,
        "current_l1": 15.75,
        "real_power_sum": 7360.5,
        "energy_delivered": 1234567.25,
        "meter_value_age": 1.5,
        "mode3_state": "C2",
        "max_current": 16.0,
        "charge_phases": 3,
    }
    ini = METERS / "alfen_ng9xx_socket.ini"
    proc, fns = check_table(tmp_path, sim_factory, ALFEN_TABLE, ini, ALFEN_REGISTERS, expected, "--table", "7")
    assert fns["energy_delivered"]["format"] == "FLOAT64"
    assert fns["meter_value_age"]["multiplier"] == "0.001"
    assert fns["voltage_l1"]["units"] == "V"
    assert fns["voltage_l1"]["access"] == "read"
    assert "read table 7 (line 197)" in proc.stderr
    assert "plain addresses read as wire addresses" in proc.stderr
    # the EMS writes its current limit here (section 1.3.1 "Maximum current")
    assert write_and_read_back(tmp_path, sim_factory, "max_current", 10.5) == 10.5


def test_alfen_placeholder_units_are_no_unit(tmp_path):
    """Alfen NG9xx: 'n.a.' and 'N.A.' in the Step column mean 'not applicable', as 'n/a' does: the
    Mode 3 state string and the power factors have no unit."""
    proc, fns, _ = convert(tmp_path, ALFEN_TABLE, METERS / "alfen_ng9xx_socket.ini", "--table", "7")
    assert proc.returncode == 0, proc.stderr
    assert "units" not in fns["mode3_state"]
