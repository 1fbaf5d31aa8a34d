"""Issue 20, the connection options: what a new user types is understood, the default ports are explained,
and every message docs/connecting.md quotes is one the program prints.

- Choice options take any case (`--parity e`, `--format JSON`, `--framer RTU`), as mbpoll and modbus-cli do.
- `--host HOST:PORT` and `--host [IPV6]:PORT` give host and port; a bare IPv6 address stays a host; a port
  given twice that disagrees is a usage error naming both.
- `mdl read`/`write`/`discover` --help explain 502 against the sim's 5020, and a refused connection to
  port 502 on this machine asks whether `mdl sim` is running.
"""

from __future__ import annotations

import errno
import fcntl
import os
import re
import socket
import struct
import subprocess
from pathlib import Path

import click
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.cli import main
from mdl.device.connection import host_port, split_host
from support.common import EXAMPLE, ROOT, fn_xml
from support.devices import read_lines
from support.hostile_server import hostile_server
from support.refusing_proxy import refusing_proxy
from support.run import assert_clean_error, cli, mdl_cmd, run_mdl

TSTAT = EXAMPLE / "temco_tstat.xml"
CONNECTING = (ROOT / "docs" / "connecting.md").read_text(encoding="utf-8")
HINT = "is `mdl sim` running? it listens on 5020 unless --port says otherwise"
PORT_HELP = "default 502, the Modbus TCP port; mdl sim listens on 5020 by default"


def _free_port() -> int:
    """A TCP port nothing listens on (bound and released at once)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _listening(host: str, port: int) -> bool:
    try:
        with socket.create_connection((host, port), timeout=1):
            return True
    except OSError:
        return False


def _ipv6_loopback() -> bool:
    if not socket.has_ipv6:
        return False
    try:
        with socket.socket(socket.AF_INET6) as sock:
            sock.bind(("::1", 0))
    except OSError:
        return False
    return True


# --- case-insensitive choices ------------------------------------------------------------------------


def _choice_params():
    for name, command in main.every_command().items():
        for param in command.params:
            if isinstance(param.type, click.Choice):
                yield f"{name} {param.opts[0]}", param.type


def test_every_choice_option_of_every_command_ignores_case():
    found = dict(_choice_params())
    assert {
        "read --format",
        "read --parity",
        "read --framer",
        "sim --parity",
        "discover --format",
        "export --to",
        "import --from",
        "gen --lang",
        "validate --schema",
    } <= set(found), sorted(found)
    assert [name for name, choice in found.items() if choice.case_sensitive] == []


@pytest.mark.parametrize(
    "args, expected",
    [
        (["read", TSTAT, "room_temperature", "--format", "JSON"], '"room_temperature": 21.5'),
        (["read", TSTAT, "room_temperature", "--format", "Csv"], "room_temperature,21.5,"),
        (["read", TSTAT, "room_temperature", "--format", "SENML"], '"n": "room_temperature"'),
        (["read", TSTAT, "room_temperature", "--format", "Table", "--framer", "TCP"], "room_temperature  21.5"),
    ],
)
def test_read_takes_choices_in_any_case(sim_factory, args, expected):
    sim = sim_factory(TSTAT, "--set", "room_temperature=21.5")
    proc = run_mdl(*args, *sim.connection)
    assert proc.returncode == 0, proc.stderr
    assert expected in proc.stdout


def test_rtu_framer_in_capitals_on_both_ends(sim_factory):
    sim = sim_factory(TSTAT, "--framer", "RTU", "--set", "room_temperature=21.5")
    proc = run_mdl("read", TSTAT, "room_temperature", *sim.connection, "--framer", "Rtu", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert '"room_temperature": 21.5' in proc.stdout


def test_discover_format_in_capitals(sim_factory):
    sim = sim_factory(TSTAT)
    proc = run_mdl("discover", TSTAT, *sim.connection, "--units", "1", "--format", "JSON")
    assert proc.returncode in (0, 1), proc.stderr  # matched or not: the option was taken, JSON came out
    assert proc.stdout.lstrip().startswith(("[", "{")), proc.stdout


def test_parity_in_lower_case_is_even_parity(serial_line):
    """The connection's name says 8E1 whether the pseudo terminal takes even parity (silence: nobody is at
    the other end) or refuses it (some kernels)."""
    proc = run_mdl(
        "read",
        TSTAT,
        "room_temperature",
        "--serial",
        serial_line.ends[0],
        "--parity",
        "e",
        "--timeout",
        "0.2",
        "--retries",
        "0",
    )
    assert_clean_error(proc, 3, "8E1")


@pytest.mark.parametrize(
    "args, expected",
    [
        (["export", TSTAT, "--to", "WISE", "--serial", "/dev/ttyUSB0", "--parity", "o"], "Parity=Odd"),
        (["export", TSTAT, "--to", "Telegraf", "--host", "192.0.2.10"], "tcp://192.0.2.10:502"),
        (["import", ROOT / "examples" / "xif_meter" / "meter.mod", "--from", "XIF"], "<device"),
    ],
)
def test_other_commands_take_choices_in_any_case(args, expected):
    proc = cli(*args)
    assert proc.returncode == 0, proc.stderr
    assert expected in proc.stdout


def test_validate_schema_in_capitals(write_device):
    path = write_device(fn_xml("level", "0", format="UINT16"), version=None)
    proc = cli("validate", path, "--schema", "0.9B")
    assert proc.returncode == 0, proc.stderr
    assert "valid MDL 0.9b" in proc.stdout


def test_gen_lang_in_capitals(tmp_path):
    proc = cli("gen", TSTAT, "--lang", "PYTHON", "-o", tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert list(tmp_path.glob("*.py"))


def test_an_unknown_choice_is_still_refused_with_the_choices():
    proc = cli("read", TSTAT, "--host", "127.0.0.1", "--format", "yaml")
    assert_clean_error(proc, 2, "'yaml' is not one of", "json")


# --- --host HOST:PORT ---------------------------------------------------------------------------------


def test_host_with_port_reaches_the_sim(sim_factory):
    sim = sim_factory(TSTAT, "--set", "room_temperature=21.5")
    proc = run_mdl("read", TSTAT, "room_temperature", "--host", f"127.0.0.1:{sim.port}", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert '"room_temperature": 21.5' in proc.stdout


def test_host_with_port_and_the_same_port_agree(sim_factory):
    sim = sim_factory(TSTAT)
    proc = run_mdl("write", TSTAT, "fan_speed=2", "--host", f"127.0.0.1:{sim.port}", "--port", sim.port)
    assert proc.returncode == 0, proc.stderr


def test_host_with_port_and_another_port_is_a_usage_error_naming_both():
    proc = cli("read", TSTAT, "--host", "127.0.0.1:5090", "--port", "502")
    assert_clean_error(proc, 2, "--host 127.0.0.1:5090", "--port 502", "disagree")


def test_a_refused_host_with_port_names_that_port():
    port = _free_port()
    proc = run_mdl("read", TSTAT, "room_temperature", "--host", f"127.0.0.1:{port}")
    assert_clean_error(proc, 3, f"cannot connect to 127.0.0.1:{port} for unit 1:")
    assert not re.search(r":502\b", proc.stderr) and HINT not in proc.stderr  # (a free port may start 502)


@pytest.mark.skipif(not _ipv6_loopback(), reason="no IPv6 loopback on this machine")
def test_ipv6_in_brackets_with_port_and_bare_ipv6_as_host(sim_factory):
    sim = sim_factory(TSTAT, "--host", "::1", "--set", "room_temperature=21.5")
    assert " on [::1]:" in sim.ready_line  # an IPv6 address is named in brackets, as --host takes it
    port = sim.ready_line.rsplit(" unit ", 1)[0].rsplit(":", 1)[1]
    for connection in (["--host", f"[::1]:{port}"], ["--host", "::1", "--port", port]):
        proc = run_mdl("read", TSTAT, "room_temperature", *connection, "--format", "json")
        assert proc.returncode == 0, (connection, proc.stderr)
        assert '"room_temperature": 21.5' in proc.stdout


def test_sim_listens_on_host_with_port():
    """The port in --host wins over the sim's default 5020 (0: a free port)."""
    proc = subprocess.Popen(
        mdl_cmd("sim", TSTAT, "--host", "127.0.0.1:0"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        lines = read_lines(proc.stdout, bool, proc, 30)
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=20)
    assert lines and lines[0].startswith("mdl sim: serving TEMCO Tstat on 127.0.0.1:"), (lines, err)
    assert ":5020 " not in lines[0] and ":0 " not in lines[0]
    assert proc.returncode == 0, err


def test_sim_host_with_port_and_another_port_is_a_usage_error():
    proc = cli("sim", TSTAT, "--host", "127.0.0.1:5090", "--port", "5020")
    assert_clean_error(proc, 2, "--host 127.0.0.1:5090", "--port 5020", "disagree")


def test_export_takes_host_with_port():
    proc = cli("export", TSTAT, "--to", "telegraf", "--host", "192.0.2.10:1502")
    assert proc.returncode == 0, proc.stderr
    assert 'controller = "tcp://192.0.2.10:1502"' in proc.stdout


@pytest.mark.parametrize(
    "host, words",
    [
        ("127.0.0.1:", "the port '' is not a number"),
        (":5020", "no host"),
        ("127.0.0.1:abc", "the port 'abc' is not a number"),
        ("127.0.0.1:0", "not in the range 1 to 65535"),
        ("127.0.0.1:70000", "not in the range 1 to 65535"),
        ("[::1", "needs its ']'"),
        ("[::1]5020", "after ']'"),
        ("[]:5020", "no host"),
    ],
)
def test_a_malformed_host_is_a_usage_error(host, words):
    proc = cli("read", TSTAT, "--host", host)
    assert_clean_error(proc, 2, "--host", words)


def test_split_host_forms():
    assert split_host("192.0.2.1") == ("192.0.2.1", None)
    assert split_host("192.0.2.1:1502") == ("192.0.2.1", 1502)
    assert split_host("plc.example:502") == ("plc.example", 502)
    assert split_host("fe80::1") == ("fe80::1", None)  # a bare IPv6 address stays a host
    assert split_host("[fe80::1]") == ("fe80::1", None)
    assert split_host("[fe80::1]:5020") == ("fe80::1", 5020)


_HOSTS = st.one_of(
    st.from_regex(r"[a-z][a-z0-9-]{0,20}(\.[a-z][a-z0-9-]{0,10}){0,3}", fullmatch=True),
    st.ip_addresses(v=4).map(str),
    st.ip_addresses(v=6).map(str),
)


@settings(max_examples=200, deadline=None)
@given(_HOSTS, st.integers(1, 65535))
def test_fuzz_host_port_round_trips(host, port):
    assert split_host(host_port(host, port)) == (host, port)
    assert split_host(host) == (host, None)


@settings(max_examples=60, deadline=None)
@given(st.text(st.sampled_from("[]:0123456789abf.x -"), max_size=16) | st.text(max_size=12))
def test_fuzz_any_host_text_is_taken_or_refused_cleanly(text):
    """Whatever --host says: a configuration (exit 0) or a usage error naming --host (exit 2); never a
    traceback (cli() raises any exception the CLI does not turn into an exit status)."""
    proc = cli("export", TSTAT, "--to", "telegraf", "--host", text)
    assert proc.returncode in (0, 2), (text, proc.stderr)
    if proc.returncode == 2:
        assert "--host" in proc.stderr or "Usage:" in proc.stderr, proc.stderr


# --- the default ports, said ----------------------------------------------------------------------------


@pytest.mark.parametrize("command", ["read", "write", "discover"])
def test_client_help_explains_the_port_default(command):
    proc = cli(command, "--help")
    assert proc.returncode == 0
    assert PORT_HELP in " ".join(proc.stdout.split())


def test_sim_help_keeps_its_own_default():
    proc = cli("sim", "--help")
    assert "default: 5020" in " ".join(proc.stdout.split())


@pytest.fixture
def nothing_on_502():
    if _listening("127.0.0.1", 502):
        pytest.skip("something listens on 127.0.0.1:502 here")


@pytest.mark.parametrize("host", ["127.0.0.1", "localhost"])
def test_refused_on_local_502_asks_whether_the_sim_runs(nothing_on_502, host):
    proc = run_mdl("read", TSTAT, "room_temperature", "--host", host)
    assert_clean_error(proc, 3, f"cannot connect to {host}:502 for unit 1: no Modbus TCP device answers; {HINT}")


def test_refused_on_local_502_while_polling_and_discovering(nothing_on_502):
    proc = run_mdl("read", TSTAT, "room_temperature", "--host", "127.0.0.1", "--interval", "0.1", "--count", "1")
    assert_clean_error(proc, 3, HINT)
    proc = run_mdl("discover", TSTAT, "--host", "127.0.0.1:502", "--units", "1")
    assert_clean_error(proc, 3, HINT)


def test_no_sim_hint_for_a_remote_device_or_another_port():
    proc = run_mdl("read", TSTAT, "room_temperature", "--host", "127.0.0.1", "--port", _free_port())
    assert_clean_error(proc, 3, "cannot connect to 127.0.0.1:")
    assert "mdl sim" not in proc.stderr


# --- every message docs/connecting.md quotes is one mdl prints --------------------------------------------


def _assert_quoted(quote: str, stderr: str, fills: dict[str, str] | None = None) -> None:
    """`quote` is in docs/connecting.md, and stderr says it: placeholders (D, S, N, ...) replaced by `fills`,
    and `…` (or a leading `... `) standing for any text."""
    assert quote in CONNECTING, f"docs/connecting.md no longer quotes {quote!r}"
    text = quote.removeprefix("... ")
    for placeholder, value in sorted((fills or {}).items(), key=lambda item: -len(item[0])):
        text = re.sub(rf"(?<![\w/]){re.escape(placeholder)}(?![\w])", lambda _m, v=value: v, text)
    pattern = ".*?".join(re.escape(piece) for piece in text.split("…"))
    assert re.search(pattern, stderr), (quote, text, stderr)


def test_doc_quotes_serial_device_missing(tmp_path):
    missing = str(tmp_path / "ttyUSB9")
    proc = run_mdl("read", TSTAT, "--serial", missing)
    assert proc.returncode == 3
    _assert_quoted(
        "cannot open serial device D for unit U: No such file or directory", proc.stderr, {"D": missing, "U": "1"}
    )


def test_doc_quotes_permission_denied(tmp_path, monkeypatch):
    device = tmp_path / "ttyUSB0"
    device.write_bytes(b"")
    args = ["read", TSTAT, "--serial", device]
    if os.geteuid() != 0:
        device.chmod(0)
    else:  # root opens anything: the kernel's refusal, as another user gets it, for this one file
        real_open = os.open

        def refusing_open(path, flags, *rest, **kw):
            if os.fspath(path) == str(device):
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(device))
            return real_open(path, flags, *rest, **kw)

        monkeypatch.setattr(os, "open", refusing_open)
    proc = cli(*args)
    assert proc.returncode == 3, proc.stderr
    _assert_quoted(
        "cannot open serial device /dev/ttyUSB0 for unit 1: Permission denied",
        proc.stderr,
        {"/dev/ttyUSB0": str(device)},
    )
    _assert_quoted("... Permission denied", proc.stderr)


def test_doc_quotes_another_program(serial_line):
    end = serial_line.ends[1]
    fd = os.open(end, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as pyserial holds a line it opened
        proc = run_mdl("read", TSTAT, "--serial", end)
    finally:
        os.close(fd)
    assert proc.returncode == 3
    _assert_quoted("... another program has it open", proc.stderr)


def test_doc_quotes_serial_silence_as_the_rehearsal_shows_it(serial_line, sim_factory):
    """The rehearsal of docs/connecting.md: a sim at unit 3 on one end, a read of unit 1 on the other."""
    sim_factory(TSTAT, "--baud", "9600", "--unit", "3", serial=serial_line.ends[0])
    proc = run_mdl(
        "read",
        TSTAT,
        "--serial",
        serial_line.ends[1],
        "--baud",
        "9600",
        "--unit",
        "1",
        "--timeout",
        "0.5",
        "room_temperature",
    )
    assert proc.returncode == 3
    assert (
        "mdl read examples/temco_tstat/temco_tstat.xml --serial /dev/pts/4 --baud 9600 --unit 1 --timeout 0.5 "
        "room_temperature"
    ) in CONNECTING
    _assert_quoted(
        "error: /dev/pts/4 (9600 8N1) unit 1: reading 1 holding from 121: no reply within 0.5 s "
        "(2 tries); check baud rate, parity and unit id",
        proc.stderr,
        {"/dev/pts/4": serial_line.ends[1]},
    )
    _assert_quoted(
        "no reply within S s (N tries); check baud rate, parity and unit id", proc.stderr, {"S": "0.5", "N": "2"}
    )


def test_doc_quotes_parity_a_pseudo_terminal_refuses(serial_line):
    proc = run_mdl(
        "read",
        TSTAT,
        "--serial",
        serial_line.ends[0],
        "--baud",
        "9600",
        "--parity",
        "E",
        "--timeout",
        "0.2",
        "--retries",
        "0",
        "room_temperature",
    )
    if "refuses" not in proc.stderr:
        pytest.skip("this kernel's pseudo terminals take even parity")
    assert proc.returncode == 3
    _assert_quoted("it refuses 9600 8E1 (Invalid argument)", proc.stderr)


def test_doc_quotes_rtu_over_tcp_silence(sim_factory):
    sim = sim_factory(TSTAT, "--framer", "rtu")
    proc = run_mdl(
        "read", TSTAT, *sim.connection, "--framer", "rtu", "--unit", "5", "--timeout", "0.3", "room_temperature"
    )
    assert proc.returncode == 3
    _assert_quoted("check the unit id, and the converter's baud rate and parity", proc.stderr)


@pytest.mark.parametrize(
    "mode, framing, quote, fills",
    [
        ("garbage", "rtu", "the reply is not a Modbus RTU frame (…)", {}),
        ("wrong_unit", "tcp", "the reply comes from unit U", {"U": "2"}),
        ("drop", "tcp", "the connection closed without a reply", {}),
    ],
)
def test_doc_quotes_a_misbehaving_device(mode, framing, quote, fills):
    with hostile_server(mode, framing=framing) as (host, port):
        proc = run_mdl(
            "read", TSTAT, "room_temperature", "--host", host, "--port", port, "--framer", framing, "--timeout", "0.5"
        )
    assert proc.returncode == 3
    _assert_quoted(quote, proc.stderr, fills)


def test_doc_quotes_exception_1(sim_factory):
    sim = sim_factory(TSTAT)
    with refusing_proxy(sim.host, sim.port, refused={3}) as proxy:
        proc = run_mdl("read", TSTAT, "room_temperature", "--host", proxy.host, "--port", proxy.port)
    assert proc.returncode == 3
    _assert_quoted("Modbus exception 1 (ILLEGAL FUNCTION)", proc.stderr)


def test_doc_quotes_exception_2(sim_factory, write_device):
    sim = sim_factory(TSTAT)
    other = write_device(fn_xml("far_away", "9000", format="UINT16"))
    proc = run_mdl("read", other, *sim.connection)
    assert proc.returncode == 3
    _assert_quoted("Modbus exception 2 (ILLEGAL DATA ADDRESS)", proc.stderr)


def test_doc_quotes_gateway_exception(sim_factory):
    sim = sim_factory(TSTAT)
    proc = run_mdl("read", TSTAT, "room_temperature", *sim.connection, "--unit", "5")
    assert proc.returncode == 3
    _assert_quoted("Modbus exception 10/11 (GATEWAY …)", proc.stderr, {"10/11": "11"})


def test_doc_quotes_cannot_connect():
    port = _free_port()
    proc = run_mdl("read", TSTAT, "room_temperature", "--host", "127.0.0.1", "--port", port)
    assert proc.returncode == 3
    _assert_quoted(
        "cannot connect to H:P for unit U: no Modbus TCP device answers",
        proc.stderr,
        {"H:P": f"127.0.0.1:{port}", "U": "1"},
    )


def test_doc_quotes_the_sim_hint(nothing_on_502):
    proc = run_mdl("read", TSTAT, "room_temperature", "--host", "127.0.0.1")
    assert proc.returncode == 3
    _assert_quoted(
        "cannot connect to 127.0.0.1:502 for unit 1: no Modbus TCP device answers; is `mdl sim` running? it "
        "listens on 5020 unless --port says otherwise",
        proc.stderr,
    )


def test_doc_quotes_what_the_sim_logs(sim_factory):
    """Bad frames from many connections at once: the first ones logged one line each, the rest counted."""
    sim = sim_factory(TSTAT)
    socks = [socket.create_connection((sim.host, sim.port), timeout=5) for _ in range(60)]
    try:
        for i, sock in enumerate(socks):  # an MBAP header with protocol id 7: pymodbus logs it
            sock.sendall(struct.pack(">HHHB", i, 7, 2, 1) + bytes([3]))
        with socket.create_connection((sim.host, sim.port), timeout=10) as sock:  # a request the sim answers
            sock.sendall(struct.pack(">HHHB", 1, 0, 6, 1) + struct.pack(">BHH", 3, 121, 1))  # after the flood
            assert sock.recv(64)[7] == 3
    finally:
        for sock in socks:
            sock.close()
    sim.stop()
    logged = sim.stderr
    client = re.search(r"^mdl sim: (127\.0\.0\.1:\d+): (.+)$", logged, re.M)
    assert client, logged
    _assert_quoted("mdl sim: CLIENT: MESSAGE", logged, {"CLIENT": client.group(1), "MESSAGE": client.group(2)})
    counted = re.search(r"mdl sim: (\d+) more messages suppressed \(from (\d+) clients\)", logged)
    assert counted, logged
    _assert_quoted(
        "mdl sim: 1052 more messages suppressed (from 658 clients)",
        logged,
        {"1052": counted.group(1), "658": counted.group(2)},
    )


def test_the_quotes_checked_here_cover_the_table_of_docs_connecting():
    """Each row of the table "What the messages point at" is a quote one of the tests above triggers."""
    table = CONNECTING.split("| message says | check |", 1)[1].split("\n\n", 1)[0]
    rows = re.findall(r"^\| `([^`]+)` \|", table, re.M)
    source = Path(__file__).read_text(encoding="utf-8")
    assert rows and [row for row in rows if f'"{row}"' not in source] == []
