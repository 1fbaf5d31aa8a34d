"""`mdl read --interval S --publish prometheus://[HOST]:PORT` (SPEC section 11, docs/fleet.md): the last
poll of each device as Prometheus metrics, served with prometheus-client on http://HOST:PORT/metrics.

One gauge per numeric function, `mdl_<function identifier>` (SPEC 3), labelled `device` (its name as
mdl.device.fleet.run gives it) and `unit` (its Modbus unit id): devices of one description share the
metric. An enumeration is its number, a boolean 1 or 0; text and bitsets are not metrics (a note says
which). A device whose last poll failed has no values, only `mdl_poll_up 0`; `mdl_poll_up` and
`mdl_poll_timestamp_seconds` (of its last good poll) are there for every device. Without HOST, every
interface (as exporters listen); port 0 picks a free port, and the note at start says which.

The HTTP server is bounded, so that clients cannot take the files and threads the poller needs: at most
SCRAPERS_MOST connections at once, each closed after IDLE_TIMEOUT seconds without a byte either way and
CONNECTION_TIME seconds in all; one connection more closes the oldest that has not yet sent its request
(or, if every one has, is itself closed at once). What a client does wrong is never a traceback.
"""

from __future__ import annotations

import io
import socket
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import suppress
from dataclasses import dataclass
from datetime import datetime
from socketserver import ThreadingMixIn
from typing import Any, TextIO
from urllib.parse import urlsplit
from wsgiref.simple_server import WSGIRequestHandler, WSGIServer

from prometheus_client import CollectorRegistry, make_wsgi_app
from prometheus_client.core import GaugeMetricFamily, Metric
from prometheus_client.registry import Collector

from mdl.device.connection import split_host
from mdl.device.fleet.run import Polled, kind_of
from mdl.diagnostics import MdlError, error
from mdl.exchange.connection import host_port
from mdl.model import Function, Value

UP, TIMESTAMP = "mdl_poll_up", "mdl_poll_timestamp_seconds"
ALL_INTERFACES = "0.0.0.0"
SCRAPERS_MOST = 16  # connections served at once (Prometheus scrapes with one)
IDLE_TIMEOUT = 10.0  # seconds a connection may wait for its client, at each read or write
CONNECTION_TIME = 30.0  # seconds a connection may last in all (a request sent a byte at a time)


@dataclass(frozen=True)
class PromUrl:
    host: str
    port: int


def parse_url(text: str) -> PromUrl:
    """`prometheus://[HOST]:PORT[/metrics]` -> PromUrl; ValueError saying what is wrong."""
    parts = urlsplit(text)
    if parts.scheme != "prometheus" or parts.path not in ("", "/", "/metrics") or parts.query:
        raise ValueError("write prometheus://[HOST]:PORT, e.g. prometheus://:9105")
    netloc = parts.netloc
    host, port = (ALL_INTERFACES, netloc[1:]) if netloc.startswith(":") else (None, None)
    if host is None:
        name, number = split_host(netloc)
        if number is None:
            raise ValueError("no port: write prometheus://[HOST]:PORT, e.g. prometheus://:9105")
        return _checked(name, number)
    if not port or not port.isascii() or not port.isdigit():
        raise ValueError(f"the port {port!r} is not a number: write prometheus://[HOST]:PORT")
    return _checked(host, int(port))


def _checked(host: str, port: int) -> PromUrl:
    if not 0 <= port <= 65535:
        raise ValueError(f"the port {port} is not in the range 0 to 65535")
    return PromUrl(host, port)


def metric_name(ident: str) -> str:
    """A function's metric: mdl_<its identifier> (identifiers are [a-z0-9_], as metric names take them)."""
    name = f"mdl_{ident}"
    return f"{name}_value" if name in (UP, TIMESTAMP) else name


class PrometheusPublisher(Collector):
    """A sink of mdl.device.fleet.run and a prometheus-client collector of the last polls."""

    def __init__(self, url: PromUrl, err: TextIO) -> None:
        self.url, self.err = url, err
        self._lock = threading.Lock()
        self._metrics: dict[str, list[tuple[Function, str, str]]] = {}  # device -> function, metric, kind
        self._help: dict[str, str] = {}
        self._labels: dict[str, list[str]] = {}
        self._last: dict[str, tuple[dict[str, Value], float]] = {}
        self._up: dict[str, int] = {}
        self._server: Any = None

    def started(self, polled: list[Polled]) -> None:
        for p in polled:
            self._labels[p.ident] = [p.ident, str(p.target.unit)]
            by_name = {f.name: f for f in p.resolved.functions}
            chosen, left_out, renamed = [], [], []
            seen: set[str] = set()
            for fn in p.functions:
                f = by_name[fn.name]
                kind = kind_of(f)
                if kind == "text":
                    left_out.append(fn.name)
                    continue
                name = first = metric_name(f.ident)
                n = 1
                while name in seen:  # `poll_up` is mdl_poll_up_value, as is `poll_up_value`: the second numbered
                    n += 1
                    name = f"{first}_{n}"
                if name != first:
                    renamed.append(f"{fn.name} as {name}")
                seen.add(name)
                units = (fn.units or "").strip()
                self._help.setdefault(name, f"{fn.name}{f' ({units})' if units else ''}: {fn.description}".strip())
                chosen.append((fn, name, kind))
            self._metrics[p.ident] = chosen
            if left_out:
                self._say(f"{p.ident}: text is not a metric: {', '.join(left_out)} left out", "note")
            if renamed:
                self._say(f"{p.ident}: metric names taken already: {', '.join(renamed)}", "note")
        registry = CollectorRegistry(auto_describe=False)
        registry.register(self)
        try:
            self._server = serve_metrics(self.url, registry)
        except OSError as exc:
            where = host_port(self.url.host, self.url.port)
            raise error(f"cannot serve Prometheus metrics on {where}: {exc.strerror or exc}") from None
        where = host_port(self.url.host, self._server.server_port)
        self._say(f"serving Prometheus metrics on http://{where}/metrics", "note")

    def record(self, polled: Polled, values: dict[str, Value], when: datetime) -> None:
        with self._lock:
            self._last[polled.ident] = (dict(values), when.timestamp())
            self._up[polled.ident] = 1

    def failed(self, polled: Polled, when: datetime, exc: MdlError) -> None:
        with self._lock:
            self._up[polled.ident] = 0
            if polled.ident in self._last:
                self._last[polled.ident] = ({}, self._last[polled.ident][1])

    def close(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()

    def collect(self) -> Iterator[Metric]:
        with self._lock:
            last, up = dict(self._last), dict(self._up)
        families: dict[str, GaugeMetricFamily] = {}
        for device, chosen in self._metrics.items():
            values = last.get(device, ({}, 0.0))[0]
            for fn, name, kind in chosen:
                value = values.get(fn.name)
                if isinstance(value, bool) or (isinstance(value, (int, float)) and kind == "number"):
                    family = families.get(name)
                    if family is None:
                        family = families[name] = GaugeMetricFamily(name, self._help[name], labels=["device", "unit"])
                    family.add_metric(self._labels[device], float(value))
        yield from families.values()
        ups = GaugeMetricFamily(UP, "1 if the device's last poll read, 0 if it failed", labels=["device", "unit"])
        stamps = GaugeMetricFamily(
            TIMESTAMP, "when the device's last good poll started (seconds since 1970)", labels=["device", "unit"]
        )
        for device, labels in self._labels.items():
            if device in up:
                ups.add_metric(labels, float(up[device]))
            if device in last:
                stamps.add_metric(labels, last[device][1])
        yield ups
        yield stamps

    def _say(self, text: str, severity: str) -> None:
        self.err.write(f"mdl read: {severity}: prometheus://{host_port(self.url.host, self.url.port)}: {text}\n")
        self.err.flush()


class _Handler(WSGIRequestHandler):
    """One connection: one request (HTTP/1.0), waiting at most IDLE_TIMEOUT seconds for each read or write;
    nothing logged (a client that goes away or times out is no news)."""

    timeout = IDLE_TIMEOUT
    server: BoundedServer

    def parse_request(self) -> bool:
        """Counted as having asked only once the request's headers are in: a client that trickles its
        headers is still one a newcomer may push out."""
        ok = super().parse_request()
        if ok:
            self.server.requested(self.connection)
        return ok

    def get_stderr(self) -> TextIO:
        return io.StringIO()  # wsgiref's traceback of a reply the client stopped reading: dropped

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002  (the standard library's name)
        pass


class BoundedServer(ThreadingMixIn, WSGIServer):
    """A thread per connection, at most SCRAPERS_MOST of them (see the module's docstring)."""

    daemon_threads = True
    request_queue_size = 64

    def __init__(self, address: tuple[str, int], family: socket.AddressFamily) -> None:
        self.address_family = family
        self.lock = threading.Lock()
        self.open: dict[socket.socket, tuple[float, bool]] = {}  # connection -> (opened, still reading its request)
        super().__init__(address, _Handler)

    def verify_request(self, request: Any, client_address: Any) -> bool:
        now = time.monotonic()
        with self.lock:
            self._reap(now)
            if len(self.open) >= SCRAPERS_MOST:
                waiting = [(since, i) for i, (since, reading) in enumerate(self.open.values()) if reading]
                if not waiting:
                    return False  # socketserver closes it
                self._cut(list(self.open)[min(waiting)[1]])
            self.open[request] = (now, True)
        return True

    def requested(self, connection: socket.socket) -> None:
        with self.lock:
            if connection in self.open:
                self.open[connection] = (self.open[connection][0], False)

    def service_actions(self) -> None:  # serve_forever calls it twice a second
        with self.lock:
            self._reap(time.monotonic())

    def _reap(self, now: float) -> None:
        for connection, (since, _) in list(self.open.items()):
            if now - since > CONNECTION_TIME:
                self._cut(connection)

    def _cut(self, connection: socket.socket) -> None:
        """End a connection: its thread's next read or write fails, and it closes the socket."""
        del self.open[connection]
        with suppress(OSError):
            connection.shutdown(socket.SHUT_RDWR)

    def shutdown_request(self, request: Any) -> None:
        with self.lock:
            self.open.pop(request, None)
        super().shutdown_request(request)

    def handle_error(self, request: Any, client_address: Any) -> None:
        if not isinstance(sys.exc_info()[1], OSError):  # a client that went away or timed out says nothing
            super().handle_error(request, client_address)


def serve_metrics(url: PromUrl, registry: CollectorRegistry) -> BoundedServer:
    """The registry's metrics on http://HOST:PORT/metrics, served by a daemon thread; OSError if it cannot listen."""
    family = socket.getaddrinfo(url.host, url.port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)[0][0]
    server = BoundedServer((url.host, url.port), family)
    server.set_app(make_wsgi_app(registry))
    threading.Thread(target=server.serve_forever, name="mdl prometheus", daemon=True).start()
    return server
