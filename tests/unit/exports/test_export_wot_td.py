"""`mdl export --to wot` (SPEC 11.1, issue 38): the Thing Description's shape, form by form, as node-wot 0.8's Modbus
binding and octet-stream codec read it (tests/engines/test_export_wot.py proves it with node-wot itself); the
mdl: terms that carry what the binding cannot say; one warning per kind of loss, naming the functions; the
Thing Model (--tm) with its placeholders; the profile's Thing Model (`mdl profiles NAME --as tm`) and the
TD that links it; text of the description reaching the TD only through json.dumps."""

from __future__ import annotations

import json
from xml.sax.saxutils import escape

import pytest

from support.common import DATA, EXAMPLE, device_xml, fn_xml
from support.fleet_checks import fn
from support.run import assert_clean_error, cli
from support.wot import ALL_TABLES, ARGS, TEMCO, kinds, named_in

CONTEXT = [
    "https://www.w3.org/2019/wot/td/v1",
    "https://www.w3.org/2022/wot/td/v1.1",
    {
        "modv": "https://www.w3.org/2019/wot/modbus#",
        "xsd": "http://www.w3.org/2001/XMLSchema#",
        "mdl": "http://www.ornl.gov/ModbusXMLSchema#",
    },
]


def export(path, *extra, code: int = 0):
    proc = cli("export", path, "--to", "wot", *extra)
    assert proc.returncode == code, proc.stderr
    return proc


def td(path, *extra) -> tuple[dict, str]:
    proc = export(path, *extra)
    return json.loads(proc.stdout), proc.stderr


def form(prop: dict) -> dict:
    (only,) = prop["forms"]
    return only


def test_the_thing_description_of_all_tables():
    doc, _ = td(ALL_TABLES, "--host", "192.0.2.10", "--port", "1502", "--unit", "7", "--interval", "2.5")
    assert doc["@context"] == CONTEXT
    assert "@type" not in doc and doc["title"] == "All Tables" and doc["description"] == "test"
    assert doc["securityDefinitions"] == {"nosec_sc": {"scheme": "nosec"}} and doc["security"] == "nosec_sc"
    props = doc["properties"]
    # the two fragments are left out; every other function is a property, in the description's order
    assert list(props) == [
        *("pump", "fan", "alarm_reset", "door_open", "filter_dirty", "energy", "power", "voltage"),
        *("gap_low", "gap_high", "setpoint", "mode", "label", "big", "temp_offset", "serial", "low_byte", "high_byte"),
    ]
    for prop in props.values():
        f = form(prop)
        assert f["href"] == f"modbus+tcp://192.0.2.10:1502/7/{f['modv:address']}?quantity={f['modv:quantity']}"
        assert f["modv:unitID"] == 7 and f["modv:pollingTime"] == 2500 and f["modv:timeout"] == 3000
        assert "modv:function" not in f  # node-wot 0.8 refuses it: the entity says the table
        assert f["contentType"].startswith("application/octet-stream;length=")
    pump, alarm, door = props["pump"], props["alarm_reset"], props["door_open"]
    assert pump["type"] == "boolean" and pump["readOnly"] is False and form(pump)["modv:entity"] == "Coil"
    assert form(pump)["op"] == ["readproperty", "writeproperty", "observeproperty", "unobserveproperty"]
    assert alarm["writeOnly"] is True and form(alarm)["op"] == ["writeproperty"] and "observable" not in alarm
    assert door["readOnly"] is True and form(door)["modv:entity"] == "DiscreteInput"
    energy = props["energy"]
    assert energy["type"] == "integer" and energy["unit"] == "kWh" and energy["mdl:multiplier"] == 0.001
    assert (
        form(energy)["contentType"] == "application/octet-stream;length=4;signed=false;byteSeq=LITTLE_ENDIAN_BYTE_SWAP"
    )
    assert form(energy)["modv:entity"] == "InputRegister" and form(energy)["modv:type"] == "xsd:unsignedInt"
    assert form(energy)["modv:mostSignificantByte"] is True and form(energy)["modv:mostSignificantWord"] is False
    power = props["power"]
    assert power["type"] == "number" and form(power)["modv:type"] == "xsd:float"
    assert form(power)["contentType"] == "application/octet-stream;length=4;byteSeq=BIG_ENDIAN"
    assert props["voltage"]["mdl:notImplemented"] == ["0xFFFF"]
    setpoint = props["setpoint"]  # INT16 x 0.1, 5..35 degC: the limits as the register values
    assert setpoint["type"] == "integer" and (setpoint["minimum"], setpoint["maximum"]) == (50, 350)
    assert form(setpoint)["contentType"] == "application/octet-stream;length=2;signed=true;byteSeq=BIG_ENDIAN"
    assert props["mode"]["enum"] == [0, 1, 2]
    assert props["mode"]["oneOf"] == [
        {"const": 0, "title": "Off"},
        {"const": 1, "title": "Heat"},
        {"const": 2, "title": "Cool"},
    ]
    assert props["label"]["type"] == "string" and form(props["label"])["modv:quantity"] == 4
    assert props["temp_offset"]["mdl:multiplier"] == 0.5 and props["temp_offset"]["mdl:offset"] == -40.0
    assert form(props["big"])["modv:type"] == "xsd:long"
    assert form(props["serial"])["contentType"].endswith("byteSeq=BIG_ENDIAN_BYTE_SWAP")
    low, high = props["low_byte"], props["high_byte"]
    assert (low["ex:bitOffset"], low["ex:bitLength"], form(low)["modv:type"]) == (8, 8, "xsd:byte")
    assert (high["ex:bitOffset"], high["ex:bitLength"], form(high)["modv:type"]) == (0, 8, "xsd:unsignedByte")


def test_each_kind_of_loss_is_one_warning_naming_the_functions():
    _, stderr = td(ALL_TABLES, *ARGS)
    said = kinds(stderr)  # (kinds() refuses a kind said twice)
    assert named_in(stderr, "a read fragment computes its value") == ["status_bit", "flow"]
    assert named_in(stderr, "the binding has no scale") == ["energy", "voltage", "setpoint", "temp_offset"]
    assert named_in(stderr, "no 'not implemented' value") == ["voltage"]
    assert named_in(stderr, "integers of up to 48 bits") == ["big"]
    assert named_in(stderr, "writes integers of up to 32 bits") == ["big"]
    assert named_in(stderr, "ignores the byte swap of byteSeq") == ["serial"]
    assert named_in(stderr, "one byte of a register") == ["low_byte", "high_byte"]
    assert named_in(stderr, "register's first byte into its second") == ["high_byte"]
    assert named_in(stderr, "keeps the NUL padding") == ["label"]
    assert named_in(stderr, "refuses to read a value outside minimum/maximum") == ["setpoint"]
    assert named_in(stderr, "enumeration does not list") == ["mode"]
    assert len(said) == 12, said
    assert "all_tables.xml:105: warning: functions 'status_bit', 'flow'" in stderr  # at the first one's line


def test_the_interval_and_the_connection_reach_the_forms():
    doc, stderr = td(TEMCO, "--host", "[2001:db8::1]:1502", "--interval", "0.25", "--timeout", "1.5")
    f = form(doc["properties"]["room_temperature"])
    assert f["href"].startswith("modbus+tcp://[2001:db8::1]:1502/1/")
    assert (f["modv:pollingTime"], f["modv:timeout"]) == (250, 1500)
    doc, stderr = td(TEMCO)
    assert form(doc["properties"]["room_temperature"])["href"].startswith("modbus+tcp://127.0.0.1:502/1/")
    assert "no connection given" in stderr


def test_an_rtu_line_cannot_be_said():
    doc, stderr = td(ALL_TABLES, "--serial", "/dev/ttyUSB0", "--baud", "9600", "--parity", "E")
    assert "the Modbus binding is TCP only: the serial line /dev/ttyUSB0 (9600 8E1) cannot be named" in stderr
    assert form(doc["properties"]["pump"])["href"].startswith("modbus+tcp://127.0.0.1:502/")
    _, stderr = td(ALL_TABLES, "--host", "192.0.2.10", "--framer", "rtu")
    assert "not RTU over TCP" in stderr


def test_scaled_bits_and_registers_that_scale(write_device):
    path = write_device(
        fn_xml("flags", 0, format="UINT16", access="read", minimum=1, bits="4-6")
        + fn_xml("on", 1, format="INT16", bits="15")
        + fn_xml("sf", 2, format="INT16", access="read")
        + fn_xml("w", 3, format="INT16", units="W", scale_exponent="sf")
        + fn_xml("neg", 4, format="INT16", multiplier=-0.5, minimum=-10, maximum=4)
        + fn_xml("odd", 5, format="UINT16", multiplier=0.1, minimum=0.25, maximum=9.99)
        + fn_xml("lab", 6, format="UINT16", multiplier=2, values={2: "two"})
        + fn_xml("t", 7, format="BIT", values={0: "off", 1: "on"})
        + fn_xml("mw", 8, format="UINT16", write_multiple="true")
    )
    doc, stderr = td(path, *ARGS)
    props = doc["properties"]
    assert props["flags"]["mdl:bits"] == "4-6" and "minimum" not in props["flags"]
    assert props["on"]["mdl:bits"] == "15" and props["on"]["type"] == "integer"
    assert props["w"]["mdl:scaleExponent"] == "sf" and props["w"]["unit"] == "W"
    assert (props["neg"]["minimum"], props["neg"]["maximum"]) == (-8, 20)  # the register values, swapped
    assert (props["odd"]["minimum"], props["odd"]["maximum"]) == (3, 99)  # rounded inwards: the same registers
    assert "enum" not in props["lab"] and props["lab"]["mdl:multiplier"] == 2.0
    assert props["t"]["enum"] == [False, True] and props["t"]["oneOf"][1] == {"const": True, "title": "on"}
    assert named_in(stderr, "mdl:bits says which of its bits") == ["flags", "on"]
    assert named_in(stderr, "sets the whole register, where mdl changes only the function's bits") == ["on"]
    assert named_in(stderr, "no scale register") == ["w"]
    assert named_in(stderr, "minimum and maximum bound the description's value") == ["flags"]
    assert named_in(stderr, "its labels name the description's value") == ["lab"]
    assert named_in(stderr, "writes true into a register as 0xFFFF") == ["t"]
    assert named_in(stderr, "writes one register with function 6") == ["mw"]


def test_text_in_little_word_order_is_left_out(write_device):
    path = write_device(
        fn("txt", "0", "STRING", "<word_order>little</word_order>", "<count>2</count>") + fn("u", "2", "UINT16")
    )
    doc, stderr = td(path, *ARGS)
    assert list(doc["properties"]) == ["u"] and named_in(stderr, "little-endian word order") == ["txt"]


def test_nothing_left_is_an_error(write_device):
    path = write_device(
        fn("t", "0", "UINT16", "<read_function_code>arg = r1;</read_function_code><access>read</access>")
    )
    assert_clean_error(cli("export", path, "--to", "wot"), 1, "WoT can hold none of this description's functions")


def test_the_thing_model_has_placeholders_and_no_connection():
    doc, stderr = td(ALL_TABLES, "--tm")
    assert doc["@type"] == "tm:ThingModel" and doc["title"] == "All Tables"
    f = form(doc["properties"]["energy"])
    assert f["href"] == "modbus+tcp://{{HOST}}:{{PORT}}/{{UNIT_ID}}/0?quantity=2"
    assert (f["modv:unitID"], f["modv:pollingTime"], f["modv:timeout"]) == (
        "{{UNIT_ID}}",
        "{{POLLING_TIME}}",
        "{{TIMEOUT}}",
    )
    assert "no connection given" not in stderr
    _, stderr = td(ALL_TABLES, "--tm", "--host", "192.0.2.10")
    assert "a Thing Model names no connection" in stderr
    assert_clean_error(cli("export", ALL_TABLES, "--to", "telegraf", "--tm"), 2, "--tm writes a WoT Thing Model")


def test_a_profile_names_the_properties_by_role_and_links_its_thing_model():
    doc, _ = td(EXAMPLE.parent / "profiles" / "meter_b.xml", "--names", "roles", "--profile", "meter", *ARGS)
    assert doc["links"] == [{"rel": "type", "href": "meter.tm.jsonld", "type": "application/tm+json"}]
    assert {"power_w", "energy_import_wh"} <= set(doc["properties"])
    doc, _ = td(EXAMPLE.parent / "profiles" / "meter_b.xml", "--names", "roles", *ARGS)
    assert "links" not in doc and "power_w" not in doc["properties"]  # roles named, no profile: own names kept
    doc, _ = td(EXAMPLE.parent / "profiles" / "meter_b.xml", *ARGS)
    assert "links" not in doc


@pytest.mark.parametrize("name", ["meter", "thermostat", "battery", "inverter", "evcharger"])
def test_a_profile_thing_model(name):
    from mdl.profiles.load import load_profile

    profile = load_profile(name)
    proc = cli("profiles", name, "--as", "tm")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["@type"] == "tm:ThingModel" and doc["title"] == profile.title
    assert list(doc["properties"]) == list(profile.roles)
    assert doc.get("tm:optional", []) == [f"/properties/{r.name}" for r in profile.roles.values() if not r.required]
    for role in profile.roles.values():
        prop = doc["properties"][role.name]
        assert prop["type"] == {"float": "number", "int": "integer", "bool": "boolean"}[role.type]
        assert prop.get("unit") == (role.unit if role.unit not in (None, "1") else None)
        assert prop["readOnly"] is (role.access == "read")
        assert "forms" not in prop


def test_profiles_as_tm_needs_one_profile():
    assert_clean_error(cli("profiles", "--as", "tm"), 2, "give its NAME")
    assert_clean_error(cli("profiles", "meter", "--as", "tm", "--format", "json"), 2, "it takes no --format")


HOSTILE = ['a"b', "back\\slash", "</script><x>", "line\u2028break", "tab\there", "{{HOST}}", "é ü ∑", "\u202eRTL"]


def test_text_reaches_the_td_only_through_json(tmp_path):
    """Names, descriptions, units and labels come back from json.loads exactly: no text becomes JSON of its own."""
    functions = "".join(
        f"<function><name>n{i}{escape(text)}</name><description>{escape(text)}</description><addresses>{i}</addresses>"
        f"<format>UINT16</format><units>{escape(text)}</units>"
        f'<values><value key="1">{escape(text)}</value></values></function>'
        for i, text in enumerate(HOSTILE)
    )
    path = tmp_path / "device.xml"
    path.write_text(device_xml(functions, escape('Dev "x" \\')), encoding="ascii", errors="xmlcharrefreplace")
    proc = export(path, *ARGS)
    assert "\u2028" not in proc.stdout  # escaped: a line break in JavaScript
    doc = json.loads(proc.stdout)
    assert doc["title"] == 'Dev "x" \\'
    for i, text in enumerate(HOSTILE):
        prop = doc["properties"][f"n{i}{text}"]
        assert prop["description"] == text and prop["unit"] == text and prop["oneOf"] == [{"const": 1, "title": text}]


def test_the_export_is_deterministic():
    assert export(ALL_TABLES, *ARGS).stdout == export(ALL_TABLES, *ARGS).stdout
    assert export(DATA / "all_tables.xml", "--tm").stdout == export(DATA / "all_tables.xml", "--tm").stdout
