"""A real MQTT broker for the tests (Debian's mosquitto on a free loopback port, with a temporary configuration),
a subscriber that keeps what arrives, and waiting for it."""

from __future__ import annotations

import getpass
import json
import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest
from paho.mqtt.enums import CallbackAPIVersion  # noqa: E402

from support.common import skip_or_fail

mqtt = pytest.importorskip("paho.mqtt.client")


RUN = 60


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def wait_for(predicate, timeout: float = RUN, what: str = "") -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


class Broker:
    """mosquitto on a free loopback port, persistent (sessions and retained messages survive a restart);
    `extra`: more configuration for the listener (TLS files, a password file)."""

    def __init__(self, folder: Path, extra: str = "") -> None:
        exe = shutil.which("mosquitto") or ("/usr/sbin/mosquitto" if Path("/usr/sbin/mosquitto").exists() else None)
        if exe is None:
            skip_or_fail("mosquitto is not installed: the MQTT tests need a broker (apt-get install mosquitto)")
        self.exe, self.port, self.proc = exe, free_port(), None
        self.config = folder / "mosquitto.conf"
        self.config.write_text(
            f"listener {self.port} 127.0.0.1\n{extra}persistence true\n"
            f"persistence_location {folder}/\nuser {getpass.getuser()}\n"
            + ("" if "allow_anonymous" in extra else "allow_anonymous true\n")
        )
        self.start()

    def start(self) -> None:
        self.proc = subprocess.Popen([self.exe, "-c", str(self.config)], stderr=subprocess.PIPE, text=True)

        def listening() -> bool:
            assert self.proc.poll() is None, self.proc.stderr.read()
            with socket.socket() as sock:
                return sock.connect_ex(("127.0.0.1", self.port)) == 0

        wait_for(listening, what="mosquitto to listen")

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=20)
            self.proc.stderr.close()


class Subscriber:
    """Everything published under `topics`, in arrival order, over a persistent session (QoS 1): messages
    published while it was away (a broker restart) are kept for it by the broker."""

    def __init__(self, port: int, topics: list[str], auth: tuple[str, str] | None = None, ca: Path | None = None):
        self.messages: list[tuple[str, bytes, bool]] = []
        self.ready = threading.Event()
        self.client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=f"test-{port}", clean_session=False)
        self.client.reconnect_delay_set(0.1, 0.5)
        if auth is not None:
            self.client.username_pw_set(*auth)
        if ca is not None:
            self.client.tls_set(ca_certs=str(ca))

        def on_connect(c, u, flags, reason, props):
            c.subscribe([(topic, 1) for topic in topics])

        self.client.on_connect = on_connect
        self.client.on_subscribe = lambda *args: self.ready.set()
        self.client.on_message = lambda c, u, m: self.messages.append((m.topic, m.payload, m.retain))
        self.client.connect("127.0.0.1", port)
        self.client.loop_start()
        assert self.ready.wait(RUN)

    def close(self) -> None:
        self.client.loop_stop()
        self.client.disconnect()

    def payloads(self, topic: str) -> list[dict]:
        return [json.loads(p) for t, p, _ in self.messages if t == topic]


def times_in_order(payloads: list[dict]) -> list[str]:
    """The poll times a topic carried, repeats of the one before dropped (at least once: a message the
    broker took but did not acknowledge before it went away comes again, next to itself)."""
    out: list[str] = []
    for p in payloads:
        if not out or out[-1] != p["time"]:
            out.append(p["time"])
    return out
