"""A site of hundreds of simulated devices for the fleet tier and bench/fleet_bench.py (SPEC 15, issue 39):
`mdl sim` processes serving units of tests/data/all_tables.xml on loopback, each unit with raw values of
its own (`--registers`), on Modbus TCP ports and on RTU-over-TCP lines, and the inventory naming them all.

- Modbus TCP: sims of at most PER_PORT units each. The poller opens a connection per Modbus TCP device, and
  a sim holds at most 100 (mdl.device.server.sim.CLIENTS_MOST; one more closes the idlest), so 500 units
  take several ports, as a site's gateways would.
- RTU over TCP: lines of LINE_UNITS units each (`mdl sim --framer rtu`), one request at a time (a real
  line at 9600 baud carries some 30 requests a second: 10 units of 11 requests each poll in about 4 s).
- The converter line (`converter=True`, the last line): a Converter, a serial-to-Ethernet converter standing
  in for the bus, whose units are served by two sims: unit 1 (Site.lone, the first polled on the line) by a
  sim of its own, which a test stops: that unit then answers nothing, as a unit on a bus that lost its
  power; the others by one sim.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import os
import random
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from support.common import DATA
from support.run import run_mdl

ALL = DATA / "all_tables.xml"
PER_PORT = 90  # Modbus TCP units one sim serves (a sim holds at most 100 connections)
LINE_UNITS = 10  # units on one RTU-over-TCP line: 110 requests a round, one at a time
HOST = "127.0.0.1"

StartSim = Callable[..., Any]  # sim_factory's start: (paths, *extra) -> support.devices.Sim


@dataclass(frozen=True)
class Unit:
    """A device of the site: its inventory id, connection URL, unit id, interval and line timeout, and its
    raw values (table -> address -> value)."""

    ident: str
    connection: str
    unit: int
    interval: float
    timeout: float
    raw: dict[str, dict[int, int]]


def _layout() -> tuple[dict[str, list[int]], dict[str, list[int]]]:
    """all_tables.xml's defined addresses per table, and the addresses of the functions whose raw values are
    kept readable (label: letters; mode: one of its labels)."""
    import mdl
    from mdl.device.server.sim import Registers

    registers = Registers(mdl.resolve(mdl.load(ALL)))
    tables = {table: sorted(addresses) for table, addresses in registers.tables.items()}
    special = {name: list(registers.layouts[name].addresses) for name in ("label", "mode")}
    return tables, special


def unit_values(seed: int, tables: dict[str, list[int]], special: dict[str, list[int]]) -> dict[str, dict[int, int]]:
    """Raw values of one unit, its own (seeded): bits at random; registers below 0x7F00, so no float is NaN
    or infinite; the label in letters and the mode one of its keys, so every value reads plainly."""
    rng = random.Random(seed)
    raw: dict[str, dict[int, int]] = {}
    for table, addresses in tables.items():
        bits = table in ("coil", "discrete")
        raw[table] = {a: rng.randint(0, 1) if bits else rng.randint(0, 0x7EFF) for a in addresses}
    for address in special["label"]:
        raw["holding"][address] = rng.randint(0x41, 0x5A) << 8 | rng.randint(0x61, 0x7A)
    for address in special["mode"]:
        raw["holding"][address] = rng.randint(0, 2)
    return raw


class Converter:
    """An RTU-over-TCP converter (`rtu+tcp://HOST:port`) whose bus holds units served by several
    `mdl sim --framer rtu` processes (`routes`: unit -> the sim's port). Each request frame goes to the sim
    serving its unit and its reply comes back; a unit whose sim is gone (or that none serves) answers
    nothing, as on a bus. Runs its own event loop on a thread."""

    REPLY_WAIT = 2.0

    def __init__(self, routes: dict[int, int]) -> None:
        self.routes = routes
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="converter", daemon=True)
        self.thread.start()
        self.server = asyncio.run_coroutine_threadsafe(self._listen(), self.loop).result(10)
        self.port: int = self.server.sockets[0].getsockname()[1]

    async def _listen(self) -> asyncio.Server:
        return await asyncio.start_server(self._client, HOST, 0)

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        upstream: dict[int, tuple[asyncio.StreamReader, asyncio.StreamWriter]] = {}
        try:
            while True:
                frame = await _request_frame(reader)
                if frame is None:
                    break
                reply = await self._ask(upstream, frame)
                if reply is not None:
                    writer.write(reply)
                    await writer.drain()
        except (OSError, asyncio.IncompleteReadError):
            pass
        finally:
            for _, w in upstream.values():
                w.close()
            writer.close()

    async def _ask(self, upstream: dict, frame: bytes) -> bytes | None:
        port = self.routes.get(frame[0])
        if port is None:
            return None
        try:
            if port not in upstream:
                upstream[port] = await asyncio.wait_for(asyncio.open_connection(HOST, port), self.REPLY_WAIT)
            r, w = upstream[port]
            w.write(frame)
            await w.drain()
            return await asyncio.wait_for(_reply_frame(r), self.REPLY_WAIT)
        except (OSError, asyncio.TimeoutError, asyncio.IncompleteReadError):
            gone = upstream.pop(port, None)
            if gone is not None:
                gone[1].close()
            return None

    def close(self) -> None:
        async def stop() -> None:
            self.server.close()
            await self.server.wait_closed()

        try:
            asyncio.run_coroutine_threadsafe(stop(), self.loop).result(10)
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join(10)


async def _request_frame(reader: asyncio.StreamReader) -> bytes | None:
    """One RTU request (unit, function, ..., CRC) as a client sends it; None at the end of the connection."""
    try:
        head = await reader.readexactly(2)
    except asyncio.IncompleteReadError:
        return None
    if head[1] in (15, 16):
        more = await reader.readexactly(5)
        return head + more + await reader.readexactly(more[4] + 2)
    if head[1] in (1, 2, 3, 4, 5, 6):
        return head + await reader.readexactly(6)
    raise asyncio.IncompleteReadError(head, None)  # a function no fleet poll sends: the connection ends


async def _reply_frame(reader: asyncio.StreamReader) -> bytes:
    head = await reader.readexactly(2)
    if head[1] & 0x80:
        return head + await reader.readexactly(3)
    if head[1] in (1, 2, 3, 4):
        size = await reader.readexactly(1)
        return head + size + await reader.readexactly(size[0] + 2)
    return head + await reader.readexactly(6)


def read_one(connection: str, unit: int) -> dict:
    """`mdl read` of one unit of a site (its connection URL and unit id), as a user reads it (json: every
    readable function)."""
    scheme, _, where = connection.partition("://")
    host, port = where.rsplit(":", 1)
    framer = ["--framer", "rtu"] if scheme == "rtu+tcp" else []
    proc = run_mdl("read", ALL, "--host", host, "--port", port, *framer, "--unit", unit, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU of a running process, from /proc (None once it has gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / TICK


class Usage:
    """The CPU of a process, sampled every `every` s on a thread: (`clock`'s time, CPU seconds) pairs."""

    def __init__(self, pid: int, every: float = 0.5, clock: Callable[[], float] = time.monotonic) -> None:
        self.pid, self.every, self.clock = pid, every, clock
        self.samples: list[tuple[float, float]] = []
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.done.is_set():
            cpu = cpu_seconds(self.pid)
            if cpu is None:
                return
            self.samples.append((self.clock(), cpu))
            self.done.wait(self.every)

    def stop(self) -> None:
        self.done.set()
        self.thread.join()

    def at(self, when: float) -> float:
        """CPU seconds at `when` (the clock's time) (the last sample at or before it)."""
        before = [cpu for t, cpu in self.samples if t <= when]
        return before[-1] if before else 0.0


class Site:
    """`units` simulated devices: LINE_UNITS on each of `lines` RTU-over-TCP lines (the last behind a
    Converter when `converter`), the rest on Modbus TCP ports of PER_PORT; every TCP device polled every
    `tcp_interval` s, every line device every `line_interval` s. `start` starts a sim (sim_factory's)."""

    def __init__(
        self,
        folder: Path,
        start: StartSim,
        units: int,
        lines: int = 2,
        tcp_interval: float = 5.0,
        line_interval: float = 2.0,
        converter: bool = True,
        line_timeout: float = 1.0,
        tcp_timeout: float = 3.0,
    ) -> None:
        self.folder, self.start = folder, start
        self.units: list[Unit] = []
        self.sims: list[Any] = []
        self.converter: Converter | None = None
        self.lone: Unit | None = None  # the converter's unit 1, served by a sim of its own
        self.lone_sim: Any = None
        tables, special = _layout()
        values = folder / "values"
        values.mkdir(exist_ok=True)
        seed = iter(range(1_000_000))
        on_lines = min(units, lines * LINE_UNITS)
        for line in range(lines):
            count = min(LINE_UNITS, on_lines - line * LINE_UNITS)
            if count <= 0:
                break
            raws = [unit_values(next(seed), tables, special) for _ in range(count)]
            behind = converter and line == lines - 1 and count > 1
            if behind:  # unit 1 (the first polled on the line) from a sim of its own, the others from one sim
                lone = self._sim(values, f"line{line + 1}-lone", raws[:1], "--framer", "rtu")
                main = self._sim(values, f"line{line + 1}", raws[1:], "--framer", "rtu", first=2)
                self.converter = Converter({1: lone.port, **dict.fromkeys(range(2, count + 1), main.port)})
                self.lone_sim, port = lone, self.converter.port
            else:
                port = self._sim(values, f"line{line + 1}", raws, "--framer", "rtu").port
            for u, raw in enumerate(raws, 1):
                where = f"rtu+tcp://{HOST}:{port}"
                self.units.append(Unit(f"line{line + 1}-u{u:02d}", where, u, line_interval, line_timeout, raw))
            if behind:
                self.lone = self.units[-count]
        left, ports = units - len(self.units), []
        while left > 0:
            count = min(PER_PORT, left)
            ports.append([unit_values(next(seed), tables, special) for _ in range(count)])
            left -= count
        with ThreadPoolExecutor(4) as pool:  # the sims start side by side (a second or so each)
            sims = list(pool.map(lambda job: self._sim(values, f"tcp{job[0]}", job[1]), enumerate(ports, 1)))
        tcp = [
            [Unit(f"tcp{n}-u{u:02d}", f"tcp://{HOST}:{sim.port}", u, tcp_interval, tcp_timeout, raw) for u, raw in
             enumerate(raws, 1)]
            for n, (raws, sim) in enumerate(zip(ports, sims, strict=True), 1)
        ]  # fmt: skip
        # listed a unit of each port in turn, as a site's devices on many hosts: the first polls (STAGGERed in
        # this order) connect to each sim in turn, never 90 in a row to one (it accepts 32 at a time)
        self.units += [unit for row in itertools.zip_longest(*tcp) for unit in row if unit is not None]

    def _sim(self, values: Path, name: str, raws: list[dict], *extra: str, first: int = 1) -> Any:
        args: list[str] = []
        for i, raw in enumerate(raws):
            path = values / f"{name}-u{first + i}.json"
            path.write_text(json.dumps({t: {str(a): v for a, v in regs.items()} for t, regs in raw.items()}))
            args += ["--unit", str(first + i), "--registers", str(path)]
        sim = self.start([ALL] * len(raws), *args, *extra)
        self.sims.append(sim)
        return sim

    def inventory(self, name: str = "site.yml") -> Path:
        """The inventory of every unit (YAML, beside a copy of all_tables.xml)."""
        (self.folder / ALL.name).write_bytes(ALL.read_bytes())
        lines = ["devices:"]
        for u in self.units:
            lines.append(
                f"  - {{id: {u.ident}, description: {ALL.name}, connection: '{u.connection}', unit: {u.unit}, "
                f"interval: {u.interval:g}, timeout: {u.timeout:g}, retries: 0}}"
            )
        path = self.folder / name
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path

    def close(self) -> None:
        if self.converter is not None:
            self.converter.close()
            self.converter = None
