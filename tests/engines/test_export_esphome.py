"""`mdl export --to esphome`, proven two ways:
- ESPHome's own validation (`esphome config FILE.yaml`, esphome 2026.6.5 in a venv of its own:
  tests/support/engines_fleet.py) accepts the export of every example, of tests/data/all_tables.xml and of an
  imported SunSpec chain;
- a reader that follows ESPHome's documented value-type rules (modbus_controller: registers' bytes most
  significant first, U_/S_ WORD, DWORD, QWORD and FP32 with `_R` for the low word first, `bitmask` masking
  and shifting down, a sensor's value a 32-bit float, then its filters; esphome/components/modbus
  modbus_helpers.cpp payload_to_number) reads `mdl sim` with pymodbus, and every exported entity shows what
  `mdl read` gives."""

from __future__ import annotations

import json
import math
import re
import struct
import subprocess
from pathlib import Path

import pytest
import yaml
from pymodbus.client import ModbusTcpClient

from support.common import DATA, EXAMPLE, ROOT, device_xml, fn_xml
from support.engines import installed_version, require
from support.engines_fleet import ESPHOME
from support.fleet_checks import WIDE, WIDE_RAW
from support.raw_images import ALL_TABLES_RAW, TEMCO_RAW
from support.run import assert_clean_error, cli, run_mdl

pytestmark = pytest.mark.engines

ALL_TABLES = DATA / "all_tables.xml"
TEMCO = EXAMPLE / "temco_tstat.xml"
FLAGS = DATA / "flags_and_scale.xml"
EXAMPLES = sorted((ROOT / "examples").glob("*/*.xml")) + [ALL_TABLES, FLAGS]
PLATFORMS = ("sensor", "binary_sensor", "text_sensor", "number", "switch", "select")


def export(path, *extra) -> subprocess.CompletedProcess:
    proc = run_mdl("export", path, "--to", "esphome", *extra)
    assert proc.returncode == 0, proc.stderr
    return proc


def esphome_config(tmp_path: Path, text: str) -> subprocess.CompletedProcess:
    """`esphome config` on the node's YAML, as a user checks it (offline)."""
    python = require(ESPHOME)
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / "node.yaml"
    path.write_text(text, encoding="utf-8")
    esphome = python.parent / "esphome"
    return subprocess.run(
        [str(esphome), "config", str(path)], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )


def assert_valid(tmp_path: Path, text: str) -> None:
    proc = esphome_config(tmp_path, text)
    said = proc.stdout + proc.stderr
    assert proc.returncode == 0 and "Configuration is valid!" in said, said[-4000:]
    assert "WARNING" not in said, said[-4000:]


# the names, labels and units ESPHome's own configuration reader (substitutions and all) gives the node
READ_BACK = r"""
import json, sys
from pathlib import Path
from esphome.core import CORE
from esphome import config as esconfig
CORE.config_path = Path(sys.argv[1])
config = esconfig.read_config({})
out = {p: [e["name"] for e in config.get(p, [])] for p in sys.argv[2:]}
out["friendly_name"] = config["esphome"]["friendly_name"]
out["options"] = [list(e["optionsmap"]) for e in config.get("select", [])]
out["units"] = [e.get("unit_of_measurement") for p in ("sensor", "number") for e in config.get(p, [])]
print(json.dumps(out))
"""


def as_esphome_reads(tmp_path: Path, text: str) -> dict:
    path = tmp_path / "read_back.yaml"
    path.write_text(text, encoding="utf-8")
    python = require(ESPHOME)
    proc = subprocess.run(
        [str(python), "-c", READ_BACK, str(path), *PLATFORMS], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def sunspec_chain(tmp_path: Path) -> Path:
    out = tmp_path / "sunspec.xml"
    proc = cli("import", "--from", "sunspec", "1", "203", "-o", out)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_esphome_config_accepts_every_example(tmp_path, path):
    text = export(path, "--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E", "--unit", "3").stdout
    assert_valid(tmp_path, text)
    node = yaml.safe_load(text)
    assert node["uart"]["parity"] == "EVEN" and node["uart"]["baud_rate"] == 9600
    assert node["modbus_controller"] == [{"address": 3, "update_interval": "60s"}]


def test_the_line_options_alone_set_the_uart(tmp_path):
    """SPEC 11: baud and parity from --baud/--parity; the ESP32 is on the line, which needs no --serial
    here (another engine still asks for one)."""
    proc = export(EXAMPLES[0], "--baud", "9600", "--parity", "E", "--stopbits", "2")
    assert proc.returncode == 0, proc.stderr
    assert_valid(tmp_path, proc.stdout)
    uart = yaml.safe_load(proc.stdout)["uart"]
    assert (uart["baud_rate"], uart["parity"], uart["stop_bits"]) == (9600, "EVEN", 2)
    assert "the ESP32's UART on GPIO17/GPIO16 runs at 9600 8E2" in proc.stderr
    other = cli("export", EXAMPLES[0], "--to", "telegraf", "--baud", "9600")
    assert other.returncode == 2 and "--baud sets a serial line: it needs --serial DEVICE" in other.stderr
    for to in ("telegraf", "esphome"):  # an empty device name is no line given by its settings alone
        assert_clean_error(cli("export", EXAMPLES[0], "--to", to, "--serial", ""), 2, "give the serial device's name")


def test_esphome_config_accepts_an_imported_sunspec_chain_and_roles(tmp_path):
    path = sunspec_chain(tmp_path)
    assert_valid(tmp_path, export(path, "--interval", "0.5").stdout)
    for meter in ("meter_a", "meter_b"):
        text = export(ROOT / "examples" / "profiles" / f"{meter}.xml", "--names", "roles").stdout
        assert_valid(tmp_path, text)


RANDOM_NAMES = ["a b", "a_b", "A b", "a.b", "a/b", "a$b", "None", "ab", "a b 2", "x"]  # one object id, mostly
RANDOM_KINDS = [
    {"format": "UINT16", "multiplier": "0.1", "units": "V"},
    {"format": "INT16", "units": "degC", "not_implemented": "0x8000"},
    {"format": "UINT32", "word_order": "little", "units": "kWh"},
    {"format": "INT64"},
    {"format": "FLOAT32", "units": "Hz"},
    {"format": "FLOAT64"},
    {"format": "UINT16", "byte_order": "little"},
    {"format": "BIT"},
    {"format": "BIT", "register_type": "coil"},
    {"format": "BIT", "register_type": "discrete"},
    {"format": "UINT8", "length": "Lower byte"},
    {"format": "INT8", "length": "Upper byte"},
    {"format": "UINT16", "values": {0: "off", 1: "on"}},
    {"format": "UINT16", "bits": "3"},
    {"format": "UINT32", "bits": "4-11"},
    {"format": "INT16", "multiplier": "0.5", "offset": "-40", "units": "%RH"},
    {"format": "STRING", "count": "3"},
]


def test_random_descriptions_pass_esphome_config(tmp_path):
    """Random descriptions, functions sharing registers, every kind of layout: ESPHome's own validation
    accepts every export (names and object ids unique, value types, bitmasks and ranges its own)."""
    import random

    rng = random.Random(26)
    checked = 0
    for case in range(12):
        functions = ""
        for i in range(rng.randint(3, 10)):
            fields = dict(rng.choice(RANDOM_KINDS))
            read_only = fields.get("register_type") == "discrete"
            fields["access"] = "read" if read_only else rng.choice(["read", "read_write", "read_write", "write"])
            if rng.random() < 0.3 and fields["access"] != "read":
                fields["write_multiple"] = "true"
            functions += fn_xml(RANDOM_NAMES[i], rng.randint(0, 6), **fields)
        path = tmp_path / f"d{case}.xml"
        path.write_text(device_xml(functions), encoding="ascii")
        proc = run_mdl("export", path, "--to", "esphome")
        if proc.returncode != 0:  # an invalid random description (two functions of one name...): refused cleanly
            assert "Traceback" not in proc.stderr and proc.returncode == 1, proc.stderr
            continue
        assert_valid(tmp_path / f"c{case}", proc.stdout)
        checked += 1
    assert checked >= 8


def test_esphome_config_refuses_a_broken_export(tmp_path):
    """A control: the check can fail (a value type ESPHome does not have)."""
    text = export(TEMCO).stdout.replace("value_type: S_WORD", "value_type: S_TRIPLE", 1)
    proc = esphome_config(tmp_path, text)
    assert proc.returncode != 0 and "S_TRIPLE" in proc.stdout + proc.stderr


def test_esphome_version_is_the_pinned_one():
    assert installed_version(require(ESPHOME), "esphome") == "2026.6.5"


# --- ESPHome's value-type rules, from its documentation and modbus_helpers.cpp -----------------------------------


def f32(x: float) -> float:
    """`x` as the 32-bit float ESPHome keeps a sensor's value in."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def size_of(value_type: str) -> int:
    """The registers a value type reads (modbus_controller TYPE_REGISTER_MAP)."""
    return {"WORD": 1, "DWORD": 2, "FP32": 2, "QWORD": 4}[
        value_type.removeprefix("U_").removeprefix("S_").removesuffix("_R")
    ]


def payload_to_number(regs: list[int], value_type: str, bitmask: int) -> int:
    """The integer ESPHome takes from the registers (payload_to_number): words most significant first, or
    least significant first for `_R`; then the bitmask keeps its bits, shifted down to bit 0."""
    size = size_of(value_type)
    words = regs[:size]
    if value_type.endswith("_R"):
        words.reverse()
    number = 0
    for word in words:
        number = (number << 16) | word
    if value_type.startswith("S_"):
        bits = 16 * size
        number -= (number >> (bits - 1)) << bits
    if "QWORD" in value_type or bitmask == 0xFFFFFFFF:
        return number
    masked = number & bitmask
    return masked >> ((bitmask & -bitmask).bit_length() - 1) if masked else 0


def payload_to_float(regs: list[int], entity: dict) -> float:
    """The float ESPHome makes of the number (payload_to_float): the FP32 types' bits, else the number."""
    value_type = entity.get("value_type", "U_WORD")
    number = payload_to_number(regs, value_type, entity.get("bitmask", 0xFFFFFFFF))
    return struct.unpack(">f", number.to_bytes(4, "big"))[0] if value_type.startswith("FP") else f32(number)


def sensor_value(regs: list[int], entity: dict) -> float | None:
    x = payload_to_float(regs, entity)
    for step in entity.get("filters", []):
        if "lambda" in step and "NAN" in step["lambda"]:  # the values that mean "not implemented": unknown
            missing = re.fullmatch(r"return (x == -?\d+(?: \|\| x == -?\d+)*) \? NAN : x;", step["lambda"])
            assert missing is not None, step
            if x in [float(v) for v in re.findall(r"-?\d+", missing.group(1))]:
                return None
        elif "lambda" in step:  # the other lambda the export writes: a signed byte
            assert step["lambda"] == "return x >= 128 ? x - 256 : x;"
            x = x - 256 if x >= 128 else x
        elif "multiply" in step:
            x = f32(x * step["multiply"])
        else:
            x = f32(x + step["offset"])
    return x


def registers(client: ModbusTcpClient, entity: dict, unit: int) -> list[int]:
    count = entity.get("register_count") or size_of(entity.get("value_type", "U_WORD"))
    read = client.read_input_registers if entity.get("register_type") == "read" else client.read_holding_registers
    return list(read(entity["address"], count=count, device_id=unit).registers)


def state(client: ModbusTcpClient, platform: str, entity: dict, unit: int):
    """What the ESPHome entity shows for the device's registers."""
    table = entity.get("register_type", "holding")
    if table in ("coil", "discrete_input"):
        read = client.read_discrete_inputs if table == "discrete_input" else client.read_coils
        return bool(read(entity["address"], count=1, device_id=unit).bits[0])
    regs = registers(client, entity, unit)
    if platform in ("binary_sensor", "switch"):
        return (regs[0] & entity["bitmask"]) != 0
    if platform == "text_sensor":  # raw_encode ANSI: every byte, but those under 0x20
        data = b"".join(r.to_bytes(2, "big") for r in regs)[: entity["response_size"]]
        return bytes(b for b in data if b >= 0x20).decode("utf-8", "replace")
    if platform == "select":
        number = payload_to_number(regs, entity["value_type"], 0xFFFFFFFF)
        return next(label for label, value in entity["optionsmap"].items() if value == number)
    if platform == "number":  # the register divided by multiply
        return f32(payload_to_float(regs, entity) / entity.get("multiply", 1.0))
    return sensor_value(regs, entity)


def same(got, want, platform: str) -> bool:
    if got is None or want is None:
        return got is want
    if platform == "text_sensor":
        return got.rstrip(" ") == want  # the trailing spaces ESPHome keeps (warned)
    if isinstance(want, bool) or isinstance(got, bool) or isinstance(want, str):
        return got == want
    return math.isclose(got, f32(want), rel_tol=1e-6, abs_tol=1e-6)


@pytest.mark.parametrize(("path", "raw", "entities"), [(ALL_TABLES, ALL_TABLES_RAW, 16), (TEMCO, TEMCO_RAW, 14)])
def test_reading_as_esphome_does_gives_mdl_read_values(sim_factory, tmp_path, path, raw, entities):
    image = tmp_path / "raw.json"
    image.write_text(json.dumps(raw))
    sim = sim_factory(path, "--registers", image, "--unit", "4")
    proc = export(path, "--unit", "4")
    node = yaml.safe_load(proc.stdout)
    read = run_mdl("read", path, *sim.connection, "--unit", "4", "--format", "json")
    assert read.returncode == 0, read.stderr
    expected = json.loads(read.stdout)
    client = ModbusTcpClient(sim.host, port=sim.port)
    assert client.connect()
    checked = 0
    try:
        for platform in PLATFORMS:
            for entity in node.get(platform, []):
                want = expected[entity["name"]]
                got = state(client, platform, entity, 4)
                if want is None and got is not None:  # no 'not implemented' value (warned): it reads the value
                    assert f"'{entity['name']}'" in proc.stderr and "no 'not implemented' value here" in proc.stderr
                    continue
                assert same(got, want, platform), (platform, entity, got, want)
                checked += 1
    finally:
        client.close()
    assert checked == entities


def test_every_value_type_and_bitmask_reads_as_mdl_read(sim_factory, tmp_path, write_device):
    path = write_device("".join(WIDE))
    assert_valid(tmp_path, export(path).stdout)
    test_reading_as_esphome_does_gives_mdl_read_values(sim_factory, tmp_path, path, WIDE_RAW, len(WIDE))


def test_hostile_names_pass_esphome_config_as_written(tmp_path):
    """Names, units and labels that ESPHome's substitution pass would expand ($, ${...}, <% %>), that it
    refuses (/, over 120 bytes) or that collide by object id: ESPHome keeps every entity, with the names the
    export wrote (and said)."""
    from support.fleet_checks import check_esphome
    from support.hostile_exports import HOSTILE, INJECTING_NAME, Fn, write_device

    texts = [*HOSTILE, "$HOME ${ 7*7 } <% set x = 1 %>", "a/b", "None", "x" * 130, "\u00dc1", "\u00c41"]
    functions = [Fn(t, description=t, units=t, values={1: t, 2: "ok"} if i % 2 else {}) for i, t in enumerate(texts)]
    path = write_device(tmp_path / "d.xml", INJECTING_NAME + " ${ 1+1 }", functions)
    proc = export(path)
    check_esphome(path, proc.stdout, proc.stderr)
    assert_valid(tmp_path, proc.stdout)
    kept = as_esphome_reads(tmp_path, proc.stdout)
    written = yaml.safe_load(proc.stdout)
    for platform in PLATFORMS:  # ESPHome reads each name and label as written: nothing expanded or dropped
        assert kept[platform] == [entity["name"] for entity in written.get(platform, [])]
    assert kept["options"] == [list(entity["optionsmap"]) for entity in written.get("select", [])]
    assert kept["friendly_name"] == written["esphome"]["friendly_name"]
    units = [e.get("unit_of_measurement") for p in ("sensor", "number") for e in written.get(p, [])]
    assert kept["units"] == units


def test_esphome_warnings_and_refusal(tmp_path, write_device):
    path = write_device(
        "<function><name>f64</name><description>x</description><addresses>0 1 2 3</addresses>"
        "<format>FLOAT64</format></function>"
    )
    assert_clean_error(
        run_mdl("export", path, "--to", "esphome"), 1, "ESPHome can hold none of this description's functions"
    )
    proc = run_mdl("export", TEMCO, "--to", "esphome", "--host", "192.0.2.1")
    assert proc.returncode == 0 and "ESPHome's modbus talks RTU on the ESP32's UART, not TCP" in proc.stderr


def test_node_options_need_esphome():
    proc = run_mdl("export", TEMCO, "--to", "telegraf", "--board", "esp32dev")
    assert proc.returncode == 2 and "--board sets the ESPHome node: it needs --to esphome" in proc.stderr
    node = yaml.safe_load(
        export(TEMCO, "--board", "esp32-s3-devkitc-1", "--tx-pin", "GPIO4", "--rx-pin", "GPIO5").stdout
    )
    assert node["esp32"]["board"] == "esp32-s3-devkitc-1"
    assert (node["uart"]["tx_pin"], node["uart"]["rx_pin"]) == ("GPIO4", "GPIO5")


@pytest.mark.parametrize("pin", ["GPIO4", "4"])
def test_esphome_config_accepts_a_flow_control_pin(tmp_path, pin):
    """Issue 37: a MAX485 module's DE/RE pin, which ESPHome's modbus drives high while it sends, from
    --flow-control-pin. The control: ESPHome refuses the pin the UART sends on, as the command does."""
    text = export(TEMCO, "--baud", "9600", "--parity", "E", "--flow-control-pin", pin).stdout
    assert yaml.safe_load(text)["modbus"] == {"flow_control_pin": pin}
    assert_valid(tmp_path, text)
    clash = text.replace(
        f"flow_control_pin: '{pin}'" if pin.isdigit() else f"flow_control_pin: {pin}", "flow_control_pin: GPIO17"
    )
    assert "flow_control_pin: GPIO17" in clash
    proc = esphome_config(tmp_path / "clash", clash)
    assert proc.returncode != 0 and "Pin 17 is used in multiple places" in proc.stdout, proc.stdout[-3000:]
    refused = run_mdl("export", TEMCO, "--to", "esphome", "--flow-control-pin", "GPIO17")
    assert_clean_error(refused, 2, "--tx-pin GPIO17 and --flow-control-pin GPIO17 name one pin")


def test_esphome_export_is_deterministic():
    assert export(ALL_TABLES).stdout == export(ALL_TABLES).stdout


def test_an_enumeration_in_part_of_a_register_is_no_select(write_device):
    """ESPHome's select compares the whole register with its options: an enumeration in a byte would find
    no option whenever the other byte is not 0. It is a number with its bitmask, and a warning says why."""
    path = write_device(
        fn_xml("mode", 0, format="UINT8", length="Lower byte", values={0: "off", 1: "on"})
        + fn_xml("level", 1, format="UINT16", values={0: "low", 1: "high"})
    )
    proc = export(path, "--serial", "uart")
    assert proc.returncode == 0, proc.stderr
    config = yaml.safe_load(proc.stdout)
    assert [s["name"] for s in config["select"]] == ["level"]
    assert {"name": "mode", "bitmask": 0xFF}.items() <= next(n for n in config["number"] if n["name"] == "mode").items()
    assert "function 'mode' (U_WORD): ESPHome: a select maps whole registers, not part of one" in proc.stderr
