"""`mdl export --to nodered` (mdl.exports.nodered, nodered_js, nodered_frag): the flow's structure (one
modbus-read per request of the read plan, wired to the assembling and the decoding function nodes), the
connection's nodes, --publish, the warnings, and text: every name, label and device name reaches the JavaScript
only as a JSON string literal. Node-RED itself runs the flows in tests/engines/test_export_nodered.py."""

from __future__ import annotations

import json
import re
import typing
from xml.sax.saxutils import escape

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from mdl.exports.nodered_js import DECODE, js_string
from mdl.formats.loading import load_resolved
from mdl.ir import steps as ir
from support.common import DATA, EXAMPLE, device_xml, fn_xml
from support.run import assert_clean_error, run_mdl

ALL_TABLES = DATA / "all_tables.xml"
TEMCO = EXAMPLE / "temco_tstat.xml"
TCP = ("--host", "192.0.2.10", "--port", "1502")


def export(path, *extra) -> tuple[list[dict], str]:
    proc = run_mdl("export", path, "--to", "nodered", *extra)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout), proc.stderr


def of_type(nodes: list[dict], kind: str) -> list[dict]:
    return [n for n in nodes if n["type"] == kind]


def functions(nodes: list[dict]) -> tuple[dict, dict]:
    assemble, decode = of_type(nodes, "function")
    assert assemble["name"] == "assemble the poll" and decode["name"].startswith("decode ")
    return assemble, decode


@pytest.mark.parametrize("path", [ALL_TABLES, TEMCO], ids=["all_tables", "temco"])
def test_one_read_per_request_of_the_plan(path):
    nodes, _ = export(path, *TCP, "--unit", "7", "--interval", "2.5")
    resolved = load_resolved(path)
    reads = of_type(nodes, "modbus-read")
    plan = [g.request for g in resolved.plan]
    assert len(reads) == len(plan) > 0
    codes = {"coil": "Coil", "discrete": "Input", "holding": "HoldingRegister", "input": "InputRegister"}
    (client,) = of_type(nodes, "modbus-client")
    assemble, decode = functions(nodes)
    (debug,) = of_type(nodes, "debug")
    (tab,) = of_type(nodes, "tab")
    for read, req in zip(reads, plan, strict=True):
        assert (read["dataType"], read["adr"], read["quantity"]) == (codes[req.table], str(req.start), str(req.count))
        assert (read["rate"], read["rateUnit"], read["unitid"]) == ("2500", "ms", "7")
        assert read["server"] == client["id"] and read["emptyMsgOnFail"] is True
        assert read["wires"] == [[assemble["id"]], []]
        assert read["topic"] == read["name"] and read["z"] == tab["id"]
        assert json.dumps(read["topic"]) in assemble["func"]  # the assembling node knows every request
    assert len({r["topic"] for r in reads}) == len(reads)
    assert assemble["wires"] == [[decode["id"]]] and decode["wires"] == [[debug["id"]]]
    assert (client["clienttype"], client["tcpHost"], client["tcpPort"], client["tcpType"]) == (
        "tcp",
        "192.0.2.10",
        "1502",
        "DEFAULT",
    )
    assert "z" not in client  # a config node, global
    assert len({n["id"] for n in nodes}) == len(nodes)
    for f in resolved.functions:
        if f.fn.readable:
            assert f"[{js_string(f.name)}, " in decode["func"], f.name
    assert f"device: {js_string(resolved.name)}, unit: 7," in decode["func"]


def test_serial_and_rtu_over_tcp_clients():
    nodes, _ = export(ALL_TABLES, "--serial", "/dev/ttyUSB1", "--baud", "9600", "--parity", "O", "--stopbits", "2")
    (client,) = of_type(nodes, "modbus-client")
    assert client["clienttype"] == "simpleser" and client["serialPort"] == "/dev/ttyUSB1"
    assert (client["serialBaudrate"], client["serialParity"], client["serialStopbits"]) == ("9600", "odd", "2")
    assert client["serialType"] == "RTU-BUFFERD" and client["serialDatabits"] == "8"
    # a line's units share the client: one request at a time, and a silent unit does not reconnect the line
    assert client["parallelUnitIdsAllowed"] is False and client["reconnectOnTimeout"] is False
    nodes, _ = export(ALL_TABLES, *TCP, "--framer", "rtu", "--timeout", "1.5")
    (client,) = of_type(nodes, "modbus-client")
    assert (client["clienttype"], client["tcpType"], client["clientTimeout"]) == ("tcp", "TELNET", "1500")
    assert client["parallelUnitIdsAllowed"] is True and client["reconnectOnTimeout"] is True  # a client a device


def test_no_connection_is_a_note():
    nodes, said = export(ALL_TABLES)
    (client,) = of_type(nodes, "modbus-client")
    assert (client["tcpHost"], client["tcpPort"]) == ("127.0.0.1", "502")
    assert "note: Node-RED: no connection given" in said


def test_export_is_deterministic_and_ids_follow_the_device():
    first, _ = export(ALL_TABLES, *TCP)
    assert first == export(ALL_TABLES, *TCP)[0]
    other, _ = export(ALL_TABLES, *TCP, "--unit", "2")
    assert not {n["id"] for n in first} & {n["id"] for n in other}  # two units' flows import side by side


def test_publish_wires_an_mqtt_out_node():
    nodes, _ = export(TEMCO, *TCP, "--publish", "mqtt://broker.example:1884/site/a")
    (out,) = of_type(nodes, "mqtt out")
    (broker,) = of_type(nodes, "mqtt-broker")
    _, decode = functions(nodes)
    assert out["id"] in decode["wires"][0] and out["broker"] == broker["id"]
    assert (out["topic"], out["qos"], out["retain"]) == ("site/a/temco_tstat", "1", "true")
    assert (broker["broker"], broker["port"], broker["usetls"]) == ("broker.example", "1884", False)
    assert 'topic: "site/a/temco_tstat"' in decode["func"]
    nodes, _ = export(TEMCO, "--publish", "mqtts://broker.example/p")
    (broker,) = of_type(nodes, "mqtt-broker")
    assert (broker["port"], broker["usetls"], broker["verifyservercert"]) == ("8883", True, True)


def test_publish_keeps_the_password_out_of_the_flow():
    proc = run_mdl("export", TEMCO, "--to", "nodered", "--publish", "mqtt://user:s3cret@broker.example/p")
    assert proc.returncode == 0, proc.stderr
    assert "s3cret" not in proc.stdout and "s3cret" not in proc.stderr
    assert "user name and password are not written into the flow" in proc.stderr


def test_a_bad_publish_url_is_a_clean_error():
    proc = run_mdl("export", TEMCO, "--to", "nodered", "--publish", "mqtt://user:s3cret@broker.example")
    assert_clean_error(proc, 1, "no topic prefix")
    assert "s3cret" not in proc.stderr


def test_warnings_name_what_the_flow_cannot_do(write_device):
    path = write_device(
        fn_xml("big", 0, format="UINT64")
        + fn_xml("small", 4, format="UINT64", bits="3-9")
        + fn_xml("scaled", 8, format="INT64", multiplier="0.5")
        + fn_xml("t", 12, format="UINT16", expression="uint16(hr:12) * 2")
    )
    nodes, said = export(path, *TCP, "--interval", "0.1234")
    assert "function 'big': Node-RED: a JavaScript number holds integers up to 2^53 - 1" in said
    assert "'scaled'" not in said.split("2^53")[0]  # a scaled value is a double
    assert "function 't': Node-RED: a Toolkit expression computes its value" in said
    assert "polls in whole milliseconds: --interval 0.1234 becomes 123 ms" in said
    _, decode = functions(nodes)
    assert '["t", ' not in decode["func"] and '["big", ' in decode["func"]


def test_nothing_left_is_an_error(write_device):
    path = write_device(fn_xml("t", 0, format="UINT16", expression="uint16(hr:0) * 2"))
    assert_clean_error(run_mdl("export", path, "--to", "nodered"), 1, "Node-RED can hold none")


STRING = re.compile(r'"(?:[^"\\]|\\.)*"')  # a JSON string literal
HOSTILE = ['q"uote\\back', "</script>*/ -->", "__proto__", "line\u2028sep", "x'); node.send({}); //", "${a}`"]


def test_text_reaches_the_code_only_as_json_strings(tmp_path):
    functions_xml = "".join(
        fn_xml(escape(name), i, format="UINT16", values={0: escape('o"ff\\'), 1: escape("</script>")})
        for i, name in enumerate(HOSTILE)
    )
    path = tmp_path / "hostile.xml"
    path.write_bytes(device_xml(functions_xml, escape('Dev "</script>\u2029')).encode("ascii", "xmlcharrefreplace"))
    nodes, said = export(path, *TCP, "--publish", "mqtt://broker.example/p")
    assert "function '__proto__': Node-RED: a Node-RED message cannot hold a value named __proto__" in said
    assemble, decode = functions(nodes)
    for name in HOSTILE:
        if name != "__proto__":  # left out, warned
            assert f"[{js_string(name)}, label(" in decode["func"]
        assert json.dumps(name, ensure_ascii=True) == js_string(name)
    code = assemble["func"] + decode["func"]
    assert code.isascii()
    outside = STRING.sub('""', code)  # the code less its string literals
    for raw in ("</script>", "quote", "__proto__", "node.send", "${a}", "Dev"):
        assert raw not in outside, raw
    assert js_string('Dev "</script>\u2029') in decode["func"]
    (tab,) = of_type(nodes, "tab")
    assert tab["label"] == 'mdl: Dev "</script>\u2029'  # a JSON value, as the flow file holds it


def test_every_decode_step_kind_has_a_printer():
    kinds = set(typing.get_args(ir.DecodeStep))
    assert set(DECODE) == kinds - {ir.Expression}  # an expression's function is left out, warned


def test_fragments_are_translated_not_copied(write_device):
    path = write_device(fn_xml("f", 0, format="UINT16", read_function_code="arg = (int16_t)r1 / 10.0; /* x */"))
    nodes, said = export(path, *TCP)
    _, decode = functions(nodes)
    assert "    arg = Number(wrap(r1, 16, true)) / 10.0;\n" in decode["func"]
    assert "/* x */" not in decode["func"] and "int16_t" not in decode["func"]
    assert "Node-RED" not in said.replace("note: Node-RED", "")


def _flow_code(tmp_path, names: list[str], label: str, device: str) -> list[str]:
    xml = "".join(
        fn_xml(escape(name), i, format="UINT16", values={0: escape(label), 1: "y"}) for i, name in enumerate(names)
    )
    path = tmp_path / "device.xml"
    path.write_bytes(device_xml(xml, escape(device)).encode("ascii", "xmlcharrefreplace"))
    proc = run_mdl("export", path, "--to", "nodered", *TCP)
    if proc.returncode != 0:
        return []  # a name MDL refuses
    return [STRING.sub('""', n["func"]) for n in json.loads(proc.stdout) if n["type"] == "function"]


TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc")), min_size=1, max_size=12)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(TEXT, min_size=1, max_size=4, unique=True), TEXT, TEXT)
def test_any_text_leaves_the_code_as_it_is(tmp_path, names, label, device):
    """The function nodes' code, less its string literals, is the same whatever the names, labels and device
    name are: text is data in them, never code."""
    assume("__proto__" not in names)
    got = _flow_code(tmp_path, names, label, device)
    assume(got)
    plain = _flow_code(tmp_path, [f"n{i}" for i in range(len(names))], "x", "Device")
    assert got == plain
