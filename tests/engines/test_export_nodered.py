"""`mdl export --to nodered`, proven by Node-RED itself (SPEC 11.1, docs/nodered.md): Node-RED 4.1.15 with
node-red-contrib-modbus 5.23.3 (tests/support/node_engines.py: from npm, cached), started headless (no editor,
no HTTP) with the exported flows against `mdl sim`. The test adds one `file` node per flow, wired from its
decoding function node, and every message's values equal what `mdl read --format json` reads from the same
simulator: the TEMCO example, tests/data/all_tables.xml, a SunSpec import (model 103), a device of 64-bit and
word-swapped values, random register images of each (text that is not UTF-8, NaN, not-implemented patterns,
scale registers), names that would break code, RTU frames over TCP and a unit other than 1, all in one
Node-RED run; RTU on a serial line (a pseudo terminal pair); a device gone drops the polls. With --publish, the
poll's message reaches a real broker (mosquitto). The read fragments of support/fragments.py, translated to
JavaScript, run by Node.js as Python runs them."""

from __future__ import annotations

import json
import math
import random
import struct
import subprocess
import time
from pathlib import Path
from xml.sax.saxutils import escape

import pytest

from mdl.exports.base import patterns_of
from mdl.formats.loading import load_resolved
from support.common import DATA, EXAMPLE, device_xml, fn_xml
from support.mqtt import Broker, Subscriber, wait_for
from support.node_engines import NODE_RED, NodeRed, require_node_engine
from support.raw_images import ALL_TABLES_RAW, TEMCO_RAW
from support.run import run_mdl

pytestmark = pytest.mark.engines

TEMCO = EXAMPLE / "temco_tstat.xml"
ALL_TABLES = DATA / "all_tables.xml"
SAFE = (1 << 53) - 1
LITTLE = {"word_order": "little"}
WIDE64 = "".join(
    [
        fn_xml("i64r", 0, format="INT64", **LITTLE),
        fn_xml("u64r", 4, format="UINT64", **LITTLE),
        fn_xml("u64", 8, format="UINT64"),
        fn_xml("f64r", 12, format="FLOAT64", **LITTLE),
        fn_xml("f64", 16, format="FLOAT64"),
        fn_xml("f64bl", 20, format="FLOAT64", byte_order="little", word_order="little"),
        fn_xml("i64s", 24, format="INT64", multiplier="0.001", offset="-5", **LITTLE),
        fn_xml("u64field", 28, format="UINT64", bits="40-59", **LITTLE),
        fn_xml("u64flag", 28, format="UINT64", bits="63", **LITTLE),
        fn_xml("i64ni", 32, format="INT64", not_implemented="0x8000000000000000"),
        fn_xml("i32bl", 36, format="INT32", byte_order="little"),
        fn_xml("f32r", 38, format="FLOAT32", **LITTLE),
        fn_xml("sf", 40, format="INT16", not_implemented="0x8000"),
        fn_xml("scaled", 41, format="INT32", scale_exponent="sf", **LITTLE),
        fn_xml("by", 43, format="UINT16", multiplier="0.5", scale_by="sf"),
        fn_xml("mode", 44, format="UINT16", values={0: "off", 1: "on", 65535: "fault"}),
        fn_xml("s8", 45, format="INT8", length="Upper byte"),
        fn_xml("field_scaled", 46, format="UINT16", bits="4-11", multiplier="0.5", offset="1"),
        fn_xml("frag_ni", 47, format="UINT16", read_function_code="arg = (int16_t)r1 / 4.0;", not_implemented="0x7FFF"),
        fn_xml("text_swapped", 48, count=3, format="STRING", byte_order="little"),
        fn_xml("text_low", 51, count=4, length="Lower byte", format="STRING"),
        fn_xml("bit_reg", 55, format="BIT"),
        fn_xml("coil_a", 0, format="BIT", register_type="coil"),
        fn_xml("in_u32r", 0, format="UINT32", register_type="input", **LITTLE),
    ]
)


HOSTILE = ['q"uote\\back', "</script>*/ -->", "__proto__", "line\u2028sep", "x'); node.send({}); //", "${a}`"]


def write_hostile(tmp_path: Path) -> Path:
    """Names, labels and a device name that would break code they were pasted into, and an expression (which
    the flow leaves out)."""
    functions = "".join(
        fn_xml(escape(name), i, format="UINT16", values={0: escape('o"ff\\'), 1: "__proto__"})
        for i, name in enumerate(HOSTILE)
    )
    functions += fn_xml("computed", 0, format="UINT16", expression="uint16(hr:0) * 2")
    path = tmp_path / "hostile.xml"
    path.write_bytes(device_xml(functions, escape('Dev "</script>\u2029')).encode("ascii", "xmlcharrefreplace"))
    return path


def random_image(path: Path, seed: int) -> dict[str, dict[str, int]]:
    """Random registers for every readable function of the device; one in four of the functions with "not
    implemented" values gets one, and every scale register an exponent in -4..4."""
    rng = random.Random(seed)
    resolved = load_resolved(path)
    image: dict[str, dict[str, int]] = {}
    for f in resolved.functions:
        table = image.setdefault(f.layout.table, {})
        bit = f.layout.table in ("coil", "discrete")
        for address in f.layout.addresses:
            table.setdefault(str(address), rng.randint(0, 1) if bit else rng.choice([rng.getrandbits(16), 0, 0xFFFF]))
        patterns = patterns_of(f)
        if patterns and rng.random() < 0.25:
            for address, word in zip(f.layout.addresses, rng.choice(patterns), strict=True):
                table[str(address)] = word
    for f in resolved.functions:
        if f.fn.factor is not None:
            factor = resolved.by_name[f.fn.factor]
            image[factor.layout.table][str(factor.layout.addresses[0])] = rng.randint(-4, 4) & 0xFFFF
    return image


def same(got, want) -> bool:
    """A value of a message equals mdl read's: booleans as booleans, numbers as the same double (JSON has one
    number: 20 and 20.0), an integer beyond 2^53 - 1 as its digits in a string (warned), text exactly."""
    if isinstance(want, bool) or isinstance(got, bool):
        return got is want
    if isinstance(want, int) and abs(want) > SAFE:
        return got == str(want)
    if isinstance(want, (int, float)) and isinstance(got, (int, float)):
        return float(got) == float(want)
    return got == want


@pytest.fixture
def node_red():
    """start(folder, nodes) -> a running NodeRed, stopped when the test ends (whatever happens)."""
    started: list[NodeRed] = []

    def start(folder: Path, nodes: list[dict]) -> NodeRed:
        red = NodeRed(folder, nodes, require_node_engine(NODE_RED))
        started.append(red)
        return red

    try:
        yield start
    finally:
        for red in started:
            red.stop()


def wait_or_fail(red: NodeRed, predicate, timeout: float, what: str) -> None:
    """Wait for `predicate`, or fail with the end of Node-RED's log."""
    try:
        wait_for(predicate, timeout, what)
    except AssertionError:
        pytest.fail(f"timed out waiting for {what}\n{red.said()}")


def messages(path: Path) -> list[dict]:
    if not path.exists():
        return []
    text = path.read_text(encoding="utf-8")  # lines end in "\n" only (text may hold U+2028); the last may be partial
    return [json.loads(line) for line in text.split("\n")[:-1] if line.strip()]


def export_flow(path: Path, *args: str) -> tuple[list[dict], str]:
    proc = run_mdl("export", path, "--to", "nodered", "--interval", "1", *args)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout), proc.stderr


def with_sink(nodes: list[dict], sink: Path, name: str, decode_name: str | None = None) -> list[dict]:
    """The flow with a `file` node writing each message of its decoding node (the one named `decode_name`,
    else the first) as a line of JSON."""
    decode = next(
        n
        for n in nodes
        if n["type"] == "function" and n["name"].startswith("decode ") and decode_name in (None, n["name"])
    )
    sink_id = f"sink{name}".ljust(16, "0")[:16]
    decode["wires"][0].append(sink_id)
    file_node = {
        "id": sink_id,
        "type": "file",
        "z": decode["z"],
        "name": "",
        "filename": str(sink),
        "filenameType": "str",
        "appendNewline": True,
        "createDir": False,
        "overwriteFile": "false",
        "encoding": "none",
        "x": 950,
        "y": 20,
        "wires": [[]],
    }
    return [*nodes, file_node]


def write_wide64(tmp_path: Path) -> Path:
    path = tmp_path / "wide64.xml"
    path.write_text(device_xml(WIDE64, "Wide 64"), encoding="ascii")
    return path


def sunspec_103(tmp_path: Path) -> Path:
    path = tmp_path / "sunspec103.xml"
    proc = run_mdl("import", "--from", "sunspec", "103", "-o", path)
    assert proc.returncode == 0, proc.stderr
    return path


def test_node_red_messages_equal_mdl_read(sim_factory, node_red, tmp_path):
    wide64, sunspec, hostile = write_wide64(tmp_path), sunspec_103(tmp_path), write_hostile(tmp_path)
    wide_image = random_image(wide64, 7)
    for address, word in zip(range(16, 20), (0x7FF0, 0, 0, 0), strict=True):  # f64: +inf
        wide_image["holding"][str(address)] = word
    for address, word in zip((38, 39), (0xFFFF, 0xFFFF), strict=True):  # f32r: NaN
        wide_image["holding"][str(address)] = word
    cases = {  # name -> (description, register image, unit, extra sim and export options)
        "temco": (TEMCO, TEMCO_RAW, 1, ()),
        "temco_random": (TEMCO, random_image(TEMCO, 1), 3, ()),
        "temco_rtu": (TEMCO, TEMCO_RAW, 1, ("--framer", "rtu")),
        "all_tables": (ALL_TABLES, ALL_TABLES_RAW, 4, ()),
        "all_tables_random": (ALL_TABLES, random_image(ALL_TABLES, 2), 1, ()),
        "sunspec103": (sunspec, random_image(sunspec, 3), 1, ()),
        "wide64": (wide64, wide_image, 2, ()),
        "wide64_random": (wide64, random_image(wide64, 4), 1, ()),
        "hostile": (hostile, {"holding": {"0": 1, "1": 0, "2": 1, "3": 7, "4": 1, "5": 0}}, 1, ()),
    }
    nodes: list[dict] = []
    expected: dict[str, dict] = {}
    sinks: dict[str, Path] = {}
    for name, (path, image, unit, extra) in cases.items():
        registers = tmp_path / f"{name}.json"
        registers.write_text(json.dumps(image), encoding="utf-8")
        sim = sim_factory(path, "--registers", registers, "--unit", str(unit), *extra)
        connection = [*sim.connection, "--unit", str(unit), *extra]
        flow, warnings = export_flow(path, *connection)
        assert "Node-RED" in warnings or not warnings.strip()
        read = run_mdl("read", path, *connection, "--format", "json")
        assert read.returncode == 0, read.stderr
        expected[name] = json.loads(read.stdout)
        sinks[name] = tmp_path / f"{name}.jsonl"
        nodes += with_sink(flow, sinks[name], name)
    assert len({n["id"] for n in nodes}) == len(nodes)  # the flows import side by side
    red = node_red(tmp_path / "node-red", nodes)
    wait_or_fail(red, lambda: all(len(messages(s)) >= 2 for s in sinks.values()), 120, "two polls of every flow")
    red.stop()
    for name, (path, _, unit, _) in cases.items():
        got = messages(sinks[name])[-1]
        resolved = load_resolved(path)
        assert set(got) == {"device", "unit", "values"}, name
        assert got["device"] == resolved.name and got["unit"] == unit, name
        # an expression's function, and one named __proto__, are left out (warned)
        left = {f.name for f in resolved.functions if f.compiled is not None or f.name == "__proto__"}
        want = {k: v for k, v in expected[name].items() if k not in left}
        assert sorted(got["values"]) == sorted(want), name
        wrong = {k: (got["values"][k], want[k]) for k in want if not same(got["values"][k], want[k])}
        assert not wrong, (name, wrong)
    wide = expected["wide64"]  # the cases meant are there: an infinity, a NaN, integers beyond 2^53 - 1
    assert wide["f64"] == "inf" and wide["f32r"] == "nan"
    assert any(isinstance(v, int) and not isinstance(v, bool) and abs(v) > SAFE for v in wide.values())
    assert any(isinstance(v, float) for v in expected["sunspec103"].values())  # scaled by their scale registers


def test_node_red_reads_an_rtu_serial_line(serial_line, sim_factory, node_red, tmp_path):
    """RTU on a serial line (a pseudo terminal pair): the modbus-client node's serial settings."""
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(ALL_TABLES_RAW), encoding="utf-8")
    line = ["--baud", "9600", "--unit", "5"]  # a pseudo terminal takes no parity
    sim_factory(ALL_TABLES, "--registers", registers, *line, serial=serial_line.ends[0])
    connection = ["--serial", serial_line.ends[1], *line]
    flow, _ = export_flow(ALL_TABLES, *connection)
    client = next(n for n in flow if n["type"] == "modbus-client")
    assert client["clienttype"] == "simpleser" and client["serialPort"] == serial_line.ends[1]
    assert (client["serialBaudrate"], client["serialParity"], client["unit_id"]) == ("9600", "none", "5")
    read = run_mdl("read", ALL_TABLES, *connection, "--format", "json")
    assert read.returncode == 0, read.stderr
    sink = tmp_path / "out.jsonl"
    red = node_red(tmp_path / "node-red", with_sink(flow, sink, "serial"))
    wait_or_fail(red, lambda: len(messages(sink)) >= 2, 90, "two polls over the serial line")
    red.stop()
    got, want = messages(sink)[-1], json.loads(read.stdout)
    assert got["unit"] == 5 and sorted(got["values"]) == sorted(want)
    assert all(same(got["values"][k], want[k]) for k in want), (got, want)


def test_publish_reaches_the_broker(sim_factory, node_red, tmp_path):
    broker = Broker(tmp_path)
    subscriber = Subscriber(broker.port, ["nr/#"])
    try:
        registers = tmp_path / "raw.json"
        registers.write_text(json.dumps(ALL_TABLES_RAW), encoding="utf-8")
        sim = sim_factory(ALL_TABLES, "--registers", registers)
        flow, _ = export_flow(ALL_TABLES, *sim.connection, "--publish", f"mqtt://127.0.0.1:{broker.port}/nr")
        types = [n["type"] for n in flow]
        assert types.count("mqtt out") == 1 and types.count("mqtt-broker") == 1
        read = run_mdl("read", ALL_TABLES, *sim.connection, "--format", "json")
        assert read.returncode == 0, read.stderr
        red = node_red(tmp_path / "node-red", flow)
        wait_or_fail(red, lambda: subscriber.payloads("nr/all_tables"), 90, "a poll on nr/all_tables")
        red.stop()
        got = subscriber.payloads("nr/all_tables")[-1]
        assert got["device"] == "All Tables" and got["unit"] == 1
        want = json.loads(read.stdout)
        assert sorted(got["values"]) == sorted(want)
        assert all(same(got["values"][k], want[k]) for k in want), (got, want)
    finally:
        subscriber.close()
        broker.stop()


def test_node_red_versions_are_the_pinned_ones():
    home = require_node_engine(NODE_RED)
    for package, version in (("node-red", "4.1.15"), ("node-red-contrib-modbus", "5.23.3")):
        found = json.loads((home / "node_modules" / package / "package.json").read_text(encoding="utf-8"))
        assert found["version"] == version


def test_a_failed_request_drops_the_poll(sim_factory, node_red, tmp_path):
    """A device that stops answering: no message with stale or missing values, only the polls that answered."""
    registers = tmp_path / "raw.json"
    registers.write_text(json.dumps(ALL_TABLES_RAW), encoding="utf-8")
    sim = sim_factory(ALL_TABLES, "--registers", registers)
    flow, _ = export_flow(ALL_TABLES, *sim.connection)
    sink = tmp_path / "out.jsonl"
    red = node_red(tmp_path / "node-red", with_sink(flow, sink, "x"))
    wait_or_fail(red, lambda: len(messages(sink)) >= 1, 90, "a first poll")
    sim.stop()
    time.sleep(4)
    count = len(messages(sink))
    time.sleep(3)
    assert len(messages(sink)) == count  # nothing more once the device is gone
    red.stop()
    assert all(len(m["values"]) == len(messages(sink)[0]["values"]) for m in messages(sink))


def test_fragments_decode_as_python(tmp_path):
    """Every read fragment the tests share (support/fragments.py), translated by mdl.exports.nodered_frag and run
    by Node.js, gives Python's value bit for bit (every NaN alike) or fails where Python's fails."""
    from mdl.dsl.cfrag import compile_fragment, compile_read
    from mdl.exports.nodered_frag import FRAGMENT_HELPERS
    from mdl.exports.nodered_js import HELPERS, decoder
    from mdl.ir.steps import Fragment
    from support.fragments import EDGE_REGISTERS, NREGS, READS, UNDEFINED_READS

    require_node_engine(NODE_RED)  # the engines tier's Node.js
    rng = random.Random(11)
    codes = READS + UNDEFINED_READS
    functions = [
        decoder(f"f{i}", (Fragment(code, NREGS, True, compile_fragment(code, NREGS, True)),))
        for i, code in enumerate(codes)
    ]
    cases = []
    for i in range(len(codes)):
        for _ in range(150):
            pick = EDGE_REGISTERS if rng.random() < 0.6 else [rng.getrandbits(16)]
            cases.append((i, [rng.choice(pick) for _ in range(NREGS)]))
    program = "\n".join(
        [
            HELPERS,
            FRAGMENT_HELPERS,
            *functions,
            f"const fns = [{', '.join(f'f{i}' for i in range(len(codes)))}];",
            'const cases = JSON.parse(require("fs").readFileSync(0, "utf8"));',
            "const out = cases.map(([i, r]) => {",
            "    let x;",
            "    try { x = fns[i](r); } catch (err) { return 'err'; }",
            "    if (Number.isNaN(x)) return 'nan';",
            "    dv.setFloat64(0, x);",
            "    return dv.getBigUint64(0).toString(16).padStart(16, '0');",
            "});",
            "console.log(JSON.stringify(out));",
        ]
    )
    script = tmp_path / "fragments.js"
    script.write_text(program, encoding="utf-8")
    proc = subprocess.run(["node", str(script)], input=json.dumps(cases), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout)
    wrong = []
    for (i, regs), js in zip(cases, got, strict=True):
        try:
            x = compile_read(codes[i], NREGS)(list(regs))
        except ArithmeticError:
            want = "err"
        else:
            want = "nan" if math.isnan(x) else struct.pack(">d", x).hex()
        if js != want:
            wrong.append((codes[i], regs, js, want))
    assert not wrong, wrong[:10]


def test_a_fleets_flow_has_a_tab_per_line_and_node_red_reads_every_device(sim_factory, node_red, tmp_path):
    """`mdl export --inventory --to nodered` (SPEC 15): three units behind one gateway (a host and port) share a
    tab, each with its own connection, a fourth device on its own port has its own tab; Node-RED gives every
    device's values as `mdl read` reads them, each message named by the device's id."""
    temco_raw, tables_raw = tmp_path / "temco.json", tmp_path / "tables.json"
    temco_raw.write_text(json.dumps(TEMCO_RAW), encoding="utf-8")
    tables_raw.write_text(json.dumps(ALL_TABLES_RAW), encoding="utf-8")
    gateway = sim_factory(
        [TEMCO, TEMCO, TEMCO], "--unit", "1", "--unit", "2", "--unit", "3",
        "--registers", temco_raw, "--registers", temco_raw, "--registers", temco_raw,
    )  # fmt: skip
    alone = sim_factory(ALL_TABLES, "--registers", tables_raw)
    rows = ["id,description,connection,unit,interval"]
    rows += [f"tstat-{u},{TEMCO},tcp://{gateway.host}:{gateway.port},{u},1" for u in (1, 2, 3)]
    rows.append(f"tables,{ALL_TABLES},tcp://{alone.host}:{alone.port},1,1")
    inventory = tmp_path / "site.csv"
    inventory.write_text("\n".join(rows) + "\n", encoding="utf-8")
    proc = run_mdl("export", "--inventory", inventory, "--to", "nodered", "-o", tmp_path / "flow")
    assert proc.returncode == 0, proc.stderr
    nodes = json.loads((tmp_path / "flow" / "flows.json").read_text(encoding="utf-8"))
    tabs = [n for n in nodes if n["type"] == "tab"]
    clients = [n for n in nodes if n["type"] == "modbus-client"]
    assert len(tabs) == 2 and len(clients) == 4  # a tab per line, a connection per TCP device
    assert {n["z"] for n in nodes if "z" in n} == {t["id"] for t in tabs}
    assert {n["server"] for n in nodes if n["type"] == "modbus-read"} == {c["id"] for c in clients}
    sinks = {}
    for decode in [n for n in nodes if n["type"] == "function" and n["name"].startswith("decode ")]:
        ident = decode["name"].removeprefix("decode ")
        sinks[ident] = tmp_path / f"{ident}.jsonl"
        nodes = with_sink(nodes, sinks[ident], ident.replace("-", ""), decode["name"])
    assert sorted(sinks) == ["tables", "tstat-1", "tstat-2", "tstat-3"]
    red = node_red(tmp_path / "node-red", nodes)
    wait_or_fail(red, lambda: all(len(messages(s)) >= 1 for s in sinks.values()), 120, "a poll of every device")
    red.stop()
    for ident, sink in sinks.items():
        got = messages(sink)[-1]
        assert got["device"] == ident
        path, sim, unit = (ALL_TABLES, alone, 1) if ident == "tables" else (TEMCO, gateway, int(ident[-1]))
        read = run_mdl("read", path, *sim.connection, "--unit", str(unit), "--format", "json")
        want = {k: v for k, v in json.loads(read.stdout).items() if k in got["values"]}
        assert sorted(got["values"]) == sorted(want) and all(same(got["values"][k], want[k]) for k in want), ident
