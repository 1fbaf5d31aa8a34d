"""The MQTT publisher's sending (mdl.device.fleet.mqtt.MqttPublisher._send): messages handed to paho in order,
at most WINDOW unacknowledged, and the queue's lock never held while paho works, so the polling thread's
record() never waits for the publisher's thread (issue 39: at 500 devices it waited up to 20 ms a poll)."""

from __future__ import annotations

import io
import threading
from types import SimpleNamespace

import paho.mqtt.client as mqtt

from mdl.device.fleet.mqtt import WINDOW, MqttPublisher, _Batch, parse_url


class FakeClient:
    """paho's publish, as _send uses it; each call checks that another thread can take the queue's lock."""

    def __init__(self, publisher: MqttPublisher, fail_after: int | None = None) -> None:
        self.publisher, self.fail_after = publisher, fail_after
        self.sent: list[str] = []
        self.lock_free: list[bool] = []

    def publish(self, topic: str, payload: bytes, qos: int, retain: bool):
        taken: list[bool] = []

        def take() -> None:
            got = self.publisher._cond.acquire(timeout=1.0)
            taken.append(got)
            if got:
                self.publisher._cond.release()

        other = threading.Thread(target=take)
        other.start()
        other.join()
        self.lock_free.append(taken == [True])
        if self.fail_after is not None and len(self.sent) >= self.fail_after:
            return SimpleNamespace(rc=mqtt.MQTT_ERR_NO_CONN, mid=0)
        self.sent.append(topic)
        return SimpleNamespace(rc=mqtt.MQTT_ERR_SUCCESS, mid=len(self.sent))


def _publisher(*batches: int) -> MqttPublisher:
    publisher = MqttPublisher(parse_url("mqtt://127.0.0.1/site"), io.StringIO())
    for b, size in enumerate(batches):
        publisher._pending.append(_Batch([(f"site/d{b}/f{i}", b"{}") for i in range(size)], f"poll {b}"))
    return publisher


def test_messages_go_in_order_within_the_window_and_the_lock_stays_free():
    publisher = _publisher(60, 60, 60)
    client = FakeClient(publisher)
    mids: dict = {}
    publisher._send(client, mids)
    assert len(client.sent) == WINDOW == len(mids)
    assert client.sent == [f"site/d0/f{i}" for i in range(60)] + [f"site/d1/f{i}" for i in range(40)]
    assert all(client.lock_free)
    publisher._send(client, mids)  # the window is full: nothing more
    assert len(client.sent) == WINDOW
    for mid in list(mids)[:30]:  # 30 acknowledged: 30 more go, in order
        publisher._acked(*mids.pop(mid))
    publisher._send(client, mids)
    assert client.sent[WINDOW:] == [f"site/d1/f{i}" for i in range(40, 60)] + [f"site/d2/f{i}" for i in range(10)]


def test_a_connection_lost_mid_send_keeps_the_rest_for_the_next_session():
    publisher = _publisher(10)
    client = FakeClient(publisher, fail_after=4)
    mids: dict = {}
    publisher._send(client, mids)
    assert client.sent == [f"site/d0/f{i}" for i in range(4)] and len(mids) == 4
    batch = publisher._pending[0]
    assert list(batch.unsent) == list(range(4, 10))  # the unsent ones, in order, first next time
    assert batch.unacked == set(range(10))
