"""`mdl read --interval S --publish mqtt[s]://HOST[:PORT]/PREFIX` (SPEC section 11, docs/fleet.md): each
poll's values to an MQTT broker with paho-mqtt (TLS for mqtts://), and Home Assistant MQTT discovery configs.

Topics (all retained, QoS 1, JSON): `PREFIX/<device>/<function>` {"value": V, "time": T} per function
per poll (the device's name as mdl.device.fleet.run gives it, the function's identifier, SPEC 3);
`PREFIX/<device>/$status` `online`/`offline` as the device's polls succeed or fail (`$` is in no
identifier: a function named `status` keeps its own topic); `PREFIX/status` `online`, `offline` when mdl
ends (the broker says it for mdl when the connection is lost: the will);
`homeassistant/<sensor|binary_sensor>/<node>/<function>/config` once at start, and again whenever Home
Assistant announces itself on `homeassistant/status` and no configs wait unacknowledged in the queue (a
flood of announcements costs one batch at a time); <node> and the unique_ids name the prefix too, so two
prefixes never share an entity.

A broker that refuses mdl (bad user name or password, not authorized, banned) or whose TLS certificate is
not trusted ends the run with exit 3: retrying cannot change its answer. The first connection's answer is
awaited (up to START_WAIT s) before polling starts; a refusal later ends polling at once.

The broker and the devices fail independently. Polls queue here in order (at most `queue` polls of each
device, 100 unless the URL says `?queue=N`; the oldest are dropped beyond, and said); one thread owns the broker
connection: it connects (again and again, backing off up to 2 s), sends the queue in order with at
most WINDOW messages unacknowledged, and forgets a poll only once the broker acknowledged all of it.
After a lost connection the unacknowledged messages go again, first, on a fresh client (paho's own
resend would race new messages): at least once, never out of order.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import ssl
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Protocol, TextIO
from urllib.parse import parse_qsl, unquote, urlsplit

import paho.mqtt.client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from mdl.device import output
from mdl.device.connection import split_host
from mdl.device.fleet.run import Polled, kind_of
from mdl.diagnostics import EXIT_DEVICE, MdlError, error
from mdl.exchange.connection import host_port
from mdl.model import Function, Value

DEFAULT_PORT = 1883
TLS_PORT = 8883
QUEUE_POLLS = 100  # polls of each device kept while the broker is away
WINDOW = 100  # messages sent and not yet acknowledged
FLUSH_GRACE = 5.0  # seconds the end of polling waits for the broker to take what is queued
DISCOVERY = "homeassistant"
BIRTH = f"{DISCOVERY}/status"
KEEPALIVE = 15
START_WAIT = 5.0  # seconds polling waits at start for the broker's answer to the first connection
DEVICE_STATUS = "$status"  # a device's availability topic level: `$` is in no identifier (SPEC 3)
# CONNACK reason codes retrying cannot change (MQTT 5; paho maps MQTT 3.1.1's 1, 4, 5 to 132, 134, 135)
REFUSALS = {
    132: "unsupported protocol version",
    134: "bad user name or password",
    135: "not authorized",
    138: "banned",
    140: "bad authentication method",
}
_PLAIN = re.compile(r"[A-Za-z0-9_]+")
_NODE = re.compile(r"[A-Za-z0-9_-]+")  # the characters of Home Assistant's node ids
Message = tuple[str, bytes]


class UnitClasses(Protocol):
    """A unit as Home Assistant spells and classes it (mdl.exports.ha_units.HaUnit, which the command hands
    in: the engines are a later stage than device/)."""

    @property
    def unit(self) -> str: ...
    @property
    def device_class(self) -> str | None: ...
    @property
    def state_class(self) -> str | None: ...
    @property
    def guesses(self) -> tuple[str, ...]: ...


Classify = Callable[[str, "str | None"], UnitClasses]  # (units, role) -> its classes


@dataclass(frozen=True)
class MqttUrl:
    host: str
    port: int
    prefix: str
    queue: int = QUEUE_POLLS
    username: str | None = None
    password: str | None = field(default=None, repr=False)  # never shown
    tls: bool = False

    def __str__(self) -> str:
        return f"{'mqtts' if self.tls else 'mqtt'}://{host_port(self.host, self.port)}/{self.prefix}"


def parse_url(text: str) -> MqttUrl:
    """`mqtt[s]://[USER[:PASSWORD]@]HOST[:PORT]/PREFIX[?queue=N]` -> MqttUrl; ValueError saying what is wrong
    (never quoting the password)."""
    parts = urlsplit(text)
    if parts.scheme not in ("mqtt", "mqtts"):
        raise ValueError("write mqtt://HOST[:PORT]/PREFIX or mqtts://HOST[:PORT]/PREFIX (TLS)")
    if "@" in text.partition("://")[2].removeprefix(parts.netloc):  # what follows HOST would be a password's
        raise ValueError(
            "an '@' after HOST: a prefix has none, and a password's '/', '?', '#' are written %2F, %3F, %23"
        )
    userinfo, at, hostport = parts.netloc.rpartition("@")
    if not hostport:
        raise ValueError("no broker: write mqtt://HOST[:PORT]/PREFIX")
    host, port = split_host(hostport)
    if port is not None and not 1 <= port <= 65535:
        raise ValueError(f"the port {port} is not in the range 1 to 65535")
    prefix = unquote(parts.path).strip("/")
    if not prefix:
        raise ValueError("no topic prefix: write mqtt://HOST[:PORT]/PREFIX, e.g. mqtt://localhost/mdl")
    if any(c in prefix for c in "+#\0") or "//" in prefix or prefix.startswith("$"):
        raise ValueError(f"the prefix {prefix!r} is not a topic: no '+', '#', empty levels or leading '$'")
    queue = QUEUE_POLLS
    for key, value in parse_qsl(parts.query, keep_blank_values=True):
        if key != "queue":
            raise ValueError(f"unknown setting {key!r} (an mqtt:// URL takes queue=N)")
        if not value.isascii() or not value.isdigit() or int(value) < 1:
            raise ValueError(f"queue={value}: a number of polls of each device, 1 or more")
        queue = int(value)
    user, _, password = userinfo.partition(":")
    tls = parts.scheme == "mqtts"
    return MqttUrl(
        host,
        port or (TLS_PORT if tls else DEFAULT_PORT),
        prefix,
        queue,
        unquote(user) if at else None,
        unquote(password) if at else None,
        tls,
    )


def tls_context(ca: Path | None) -> ssl.SSLContext:
    """The TLS context of mqtts://: the system's CA store, or only the CA certificates (PEM) in `ca`
    (--mqtt-ca); MdlError (exit 1) naming the file when it holds none."""
    try:
        return ssl.create_default_context(cafile=None if ca is None else str(ca))
    except (ssl.SSLError, OSError, ValueError) as exc:
        what = getattr(exc, "strerror", None) or getattr(exc, "reason", None) or exc
        raise error(f"not a CA certificate file (PEM) for --mqtt-ca: {what}", ca) from None


def node_id(prefix: str, ident: str) -> str:
    """A device's node in Home Assistant's discovery topics and ids: the prefix and the device, distinct for
    every (prefix, device) and the same on every run. A prefix of letters, digits and `_` is itself
    (`site1-meter`); another is spelled so and followed by a digest of it (`site_hall-1c2d3e4f-meter`).
    An inventory's device id may hold `.`, which Home Assistant's node ids may not: it is spelled `_` and
    followed by a digest of the id (`meter_3_9f8e7d6c` for `meter.3`), so `meter.3` and `meter_3` differ."""
    if not _NODE.fullmatch(ident):
        ident = f"{re.sub(r'[^A-Za-z0-9_-]', '_', ident)}_{hashlib.sha256(ident.encode()).hexdigest()[:8]}"
    if _PLAIN.fullmatch(prefix):
        return f"{prefix}-{ident}"
    digest = hashlib.sha256(prefix.encode()).hexdigest()[:8]
    return f"{re.sub(r'[^A-Za-z0-9_]', '_', prefix)}-{digest}-{ident}"


@dataclass
class _Batch:
    """Messages sent together (one poll, a status, the discovery configs) and how far they got."""

    messages: list[Message]
    what: str  # for the message saying it was dropped
    discovery: bool = False
    status_of: str | None = None  # a device's online/offline: never dropped, a newer one supersedes it
    unsent: deque[int] = field(default_factory=deque)
    unacked: set[int] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.unsent.extend(range(len(self.messages)))
        self.unacked.update(range(len(self.messages)))

    @property
    def poll(self) -> bool:
        """A poll's values: what the queue's bound counts and drops (discovery and status are kept)."""
        return not self.discovery and self.status_of is None


def _mqtt_value(fn: Function, value: Value) -> Value:
    """A value as its payload carries it: json records' (labels, exact doubles), but NaN and the infinities
    as null: Home Assistant's numeric sensors take null as unknown and refuse a text."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return output.json_value(fn, value)


def _payload(doc: Any) -> bytes:
    return json.dumps(doc, ensure_ascii=False, separators=(",", ":")).encode()


_BOOL_TEMPLATE = "{% if value_json.value is none %}None{% elif value_json.value %}ON{% else %}OFF{% endif %}"


def _templates(kind: str) -> dict[str, str]:
    if kind == "bool":  # None: Home Assistant's "unknown"
        return {"value_template": _BOOL_TEMPLATE}
    return {"value_template": "{{ value_json.value }}"}


class MqttPublisher:
    """A sink of mdl.device.fleet.run: polls to the broker, in order, from a thread of its own."""

    def __init__(
        self, url: MqttUrl, err: TextIO, classify: Classify | None = None, tls: ssl.SSLContext | None = None
    ) -> None:
        self.url, self.err, self.classify = url, err, classify
        self.tls = tls_context(None) if tls is None and url.tls else tls
        self.status_topic = f"{url.prefix}/status"
        self._cond = threading.Condition()
        self._pending: deque[_Batch] = deque()
        self._closing = False
        self._deadline = 0.0
        self._dropped = 0
        self._polls = 0  # batches in the queue that are not discovery configs
        self._bound = url.queue  # polls in all: `queue` of each device
        self._down_said = False
        self._topics: dict[str, list[tuple[Function, str]]] = {}
        self._online: dict[str, bool] = {}
        self._discovery: list[Message] = []
        self._thread = threading.Thread(target=self._run, name="mdl-mqtt", daemon=True)
        self._answered = threading.Event()  # the first connection attempt has its answer
        self.fatal: MdlError | None = None  # the broker refused mdl: the run ends with it
        self._abort: Callable[[MdlError], None] | None = None

    # the sink: called on the polling thread

    def started(self, polled: list[Polled]) -> None:
        self._bound = self.url.queue * len(polled)
        for p in polled:
            by_name = {f.name: f for f in p.resolved.functions}
            self._topics[p.ident] = [
                (fn, f"{self.url.prefix}/{p.ident}/{by_name[fn.name].ident}") for fn in p.functions
            ]
            self._discovery += self._configs(p)
        self._add(_Batch(list(self._discovery), "the discovery configs", discovery=True))
        self._thread.start()
        self._answered.wait(START_WAIT)
        if self.fatal is not None:  # refused at start: nothing is polled
            self._thread.join(KEEPALIVE)
            raise self.fatal

    def stop_with(self, abort: Callable[[MdlError], None]) -> None:
        """How a refusal later ends the polling (mdl.device.fleet.run.Stoppable)."""
        with self._cond:
            self._abort = abort
            fatal = self.fatal
        if fatal is not None:
            abort(fatal)

    def record(self, polled: Polled, values: dict[str, Value], when: datetime) -> None:
        stamp = output.iso_time(when)
        messages = [
            (topic, _payload({"value": _mqtt_value(fn, values[fn.name]), "time": stamp}))
            for fn, topic in self._topics[polled.ident]
        ]
        if not self._online.get(polled.ident):
            self._online[polled.ident] = True
            self._status(polled.ident, b"online", stamp)
        self._add(_Batch(messages, f"the poll of {polled.ident} at {stamp}"))

    def failed(self, polled: Polled, when: datetime, exc: MdlError) -> None:
        if self._online.get(polled.ident, True):
            self._online[polled.ident] = False
            self._status(polled.ident, b"offline", output.iso_time(when))

    def _status(self, ident: str, state: bytes, stamp: str) -> None:
        """A device's status in a batch of its own, which the queue's bound never drops."""
        topic = self._device_status(ident)
        self._add(_Batch([(topic, state)], f"{ident} {state.decode()} at {stamp}", status_of=ident))

    def _device_status(self, ident: str) -> str:
        return f"{self.url.prefix}/{ident}/{DEVICE_STATUS}"

    def close(self) -> None:
        """Give the broker FLUSH_GRACE seconds to take what is queued, then disconnect; say what it did not take.
        MdlError (exit 3) if the broker refused mdl."""
        with self._cond:
            self._closing = True
            self._deadline = time.monotonic() + FLUSH_GRACE
            self._cond.notify_all()
        self._thread.join(FLUSH_GRACE + KEEPALIVE)
        with self._cond:
            lost = [b for b in self._pending if b.unacked]
            if lost:
                n, polls = sum(len(b.unacked) for b in lost), sum(b.poll for b in lost)
                self._say(
                    f"{n} messages ({polls} polls, {len(lost) - polls} statuses or discovery configs) not "
                    "delivered: the broker did not take them before the end"
                )
        if self.fatal is not None:
            raise self.fatal

    # discovery

    def _configs(self, p: Polled) -> list[Message]:
        """Home Assistant's discovery config of each function of a polled device."""
        device = p.resolved.device
        node = node_id(self.url.prefix, p.ident)
        info: dict[str, Any] = {"identifiers": [f"mdl-{node}"], "name": device.name}
        if device.manufacturer:
            info["manufacturer"] = device.manufacturer
        if device.product:
            info["model"] = device.product
        by_name = {f.name: f for f in p.resolved.functions}
        out = []
        for fn, topic in self._topics[p.ident]:
            f = by_name[fn.name]
            kind = kind_of(f)
            config: dict[str, Any] = {
                "name": fn.name,
                "unique_id": f"mdl-{node}-{f.ident}",
                "state_topic": topic,
                **_templates(kind),
                "availability": [{"topic": self.status_topic}, {"topic": self._device_status(p.ident)}],
                "availability_mode": "all",
                "device": info,
            }
            if kind == "number" and not fn.values and (fn.units or fn.role) and self.classify is not None:
                found = self.classify(fn.units or "", fn.role)
                config.update(
                    {
                        key: value
                        for key, value in (
                            ("unit_of_measurement", found.unit),
                            ("device_class", found.device_class),
                            ("state_class", found.state_class),
                        )
                        if value
                    }
                )
                for guess in found.guesses:
                    self._say(f"{p.ident}: {fn.name}: {guess}", "note")
            component = "binary_sensor" if kind == "bool" else "sensor"
            out.append((f"{DISCOVERY}/{component}/{node}/{f.ident}/config", _payload(config)))
        return out

    # the queue

    def _add(self, batch: _Batch) -> None:
        with self._cond:
            if batch.status_of is not None:  # a status not yet begun is superseded by the newer one
                stale = [
                    b
                    for b in self._pending
                    if b.status_of == batch.status_of and len(b.unsent) == len(b.messages) == len(b.unacked)
                ]
                for b in stale:
                    self._pending.remove(b)
            self._pending.append(batch)
            self._polls += batch.poll
            if self._polls > self._bound:
                oldest = next(b for b in self._pending if b.poll)
                self._pending.remove(oldest)
                self._polls -= 1
                self._dropped += 1
                if self._dropped == 1:
                    self._say(
                        f"the queue holds {self.url.queue} polls of each device: dropping the oldest "
                        f"({oldest.what} first) until the broker takes them"
                    )
            self._cond.notify_all()

    def _rediscover(self) -> None:
        """Home Assistant asked for the configs: queue them again, unless configs the broker has not yet
        acknowledged wait in the queue already (they are retained: Home Assistant gets them on subscribing). A
        flood of births costs one batch at a time, never one each; the polls keep their order and bound."""
        with self._cond:
            if any(b.discovery and b.unacked for b in self._pending):
                return
        self._add(_Batch(list(self._discovery), "the discovery configs", discovery=True))

    def _acked(self, batch: _Batch, index: int) -> None:
        with self._cond:
            batch.unacked.discard(index)
            while self._pending and not self._pending[0].unacked:
                self._polls -= self._pending.popleft().poll
            self._cond.notify_all()

    def _say(self, text: str, severity: str = "warning") -> None:
        stamp = output.iso_time(datetime.now(timezone.utc))
        try:
            self.err.write(f"{stamp}: {self.url}: {severity}: {text}\n")
            self.err.flush()
        except (OSError, ValueError):  # stderr is gone: nothing to say it on
            pass

    # the broker connection: on the publisher's own thread

    def _finished(self) -> bool:
        """Closing, and nothing is left to send or the grace is over (under the lock)."""
        return self._closing and (not any(b.unacked for b in self._pending) or time.monotonic() > self._deadline)

    def _run(self) -> None:
        try:
            self._connect_and_send()
        finally:
            self._answered.set()

    def _connect_and_send(self) -> None:
        backoff = 0.2
        while True:
            with self._cond:
                if self._finished() or self.fatal is not None:
                    return
            client = self._client()
            try:
                client.connect(self.url.host, self.url.port, keepalive=KEEPALIVE)
            except ssl.SSLCertVerificationError as exc:
                self._refused(
                    f"the broker's TLS certificate is not trusted ({exc.verify_message}): "
                    "give its CA with --mqtt-ca FILE"
                )
                return
            except (OSError, ValueError) as exc:
                self._answered.set()
                self._down(f"cannot connect: {getattr(exc, 'strerror', None) or exc}")
                with self._cond:
                    self._cond.wait(backoff)
                backoff = min(backoff * 2, 2.0)
                continue
            if self._session(client):
                backoff = 0.2

    def _refused(self, why: str) -> None:
        """A broker that will not take mdl: the run ends (exit 3), at start or later."""
        with self._cond:
            self.fatal = MdlError(f"{self.url}: {why}", exit_code=EXIT_DEVICE)
            abort = self._abort
            self._cond.notify_all()
        self._answered.set()
        if abort is not None:
            abort(self.fatal)

    def _down(self, why: str) -> None:
        if not self._down_said:
            self._down_said = True
            bound = f"at most {self.url.queue} of each device"
            self._say(f"the broker is unreachable ({why}): polls queue ({bound}) until it is back")

    def _client(self) -> mqtt.Client:
        client = mqtt.Client(CallbackAPIVersion.VERSION2, clean_session=True)
        client.max_inflight_messages_set(WINDOW)
        client.connect_timeout = 5.0
        client.will_set(self.status_topic, b"offline", qos=1, retain=True)
        if self.tls is not None:
            client.tls_set_context(self.tls)
        if self.url.username is not None:
            client.username_pw_set(self.url.username, self.url.password or None)
        return client

    def _session(self, client: mqtt.Client) -> bool:
        """Send while connected; False if the broker refused the connection."""
        state: dict[str, Any] = {"up": None, "lost": False}
        mids: dict[int, tuple[_Batch, int]] = {}

        def on_connect(c: mqtt.Client, u: Any, flags: Any, reason: Any, props: Any) -> None:
            state["up"] = not reason.is_failure
            if reason.is_failure:
                state["why"] = str(reason)
                state["code"] = reason.value

        def on_disconnect(c: mqtt.Client, u: Any, flags: Any, reason: Any, props: Any) -> None:
            state["lost"] = True

        def on_publish(c: mqtt.Client, u: Any, mid: int, reason: Any, props: Any) -> None:
            entry = mids.pop(mid, None)
            if entry is not None:
                self._acked(*entry)

        def on_message(c: mqtt.Client, u: Any, message: mqtt.MQTTMessage) -> None:
            if message.topic == BIRTH and message.payload == b"online":  # Home Assistant (re)started
                self._rediscover()

        client.on_connect, client.on_disconnect = on_connect, on_disconnect
        client.on_publish, client.on_message = on_publish, on_message
        wait_until = time.monotonic() + 10
        while state["up"] is None and not state["lost"] and time.monotonic() < wait_until:
            if client.loop(0.05) != mqtt.MQTT_ERR_SUCCESS:
                break
        if not state["up"]:
            client.disconnect()
            if state.get("code") in REFUSALS:
                who = f"as {self.url.username!r}" if self.url.username is not None else "without a user name"
                self._refused(f"the broker refused the connection {who}: {REFUSALS[state['code']]}")
            else:
                self._answered.set()
                self._down(state.get("why", "no answer to CONNECT"))
            return False
        self._answered.set()
        client.subscribe(BIRTH, qos=1)
        client.publish(self.status_topic, b"online", qos=1, retain=True)
        with self._cond:
            for batch in self._pending:
                batch.unsent = deque(sorted(batch.unacked))
            if self._down_said:
                self._down_said = False
                dropped, self._dropped = self._dropped, 0
                gone = f"; {dropped} polls were dropped (the oldest)" if dropped else ""
                self._say(f"the broker is back: sending the queued polls in order{gone}", "note")
        while not state["lost"]:
            with self._cond:
                if self._finished():
                    break
            self._send(client, mids)
            if client.loop(0.02) != mqtt.MQTT_ERR_SUCCESS:
                state["lost"] = True
        if state["lost"]:
            self._down("the connection was lost")
            return True
        info = client.publish(self.status_topic, b"offline", qos=1, retain=True)
        until = time.monotonic() + 2.0
        while not info.is_published() and time.monotonic() < until:
            if client.loop(0.05) != mqtt.MQTT_ERR_SUCCESS:
                break
        client.disconnect()
        return True

    def _send(self, client: mqtt.Client, mids: dict[int, tuple[_Batch, int]]) -> None:
        """Hand queued messages to paho in order, keeping at most WINDOW unacknowledged. The queue's lock is held
        only to pick them, never across paho's work: the polling thread takes it for every poll (record), and
        must not wait for this thread while the system has it paused mid-send (a busy machine)."""
        picked: list[tuple[_Batch, int]] = []
        with self._cond:
            for batch in self._pending:
                while batch.unsent and len(mids) + len(picked) < WINDOW:
                    picked.append((batch, batch.unsent.popleft()))
                if len(mids) + len(picked) >= WINDOW:
                    break
        for n, (batch, index) in enumerate(picked):
            topic, payload = batch.messages[index]
            info = client.publish(topic, payload, qos=1, retain=True)
            if info.rc != mqtt.MQTT_ERR_SUCCESS:  # the connection is gone: the loop finds out; these go again
                with self._cond:
                    for unsent_batch, unsent in reversed(picked[n:]):
                        unsent_batch.unsent.appendleft(unsent)
                return
            mids[info.mid] = (batch, index)
