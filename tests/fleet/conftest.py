"""The fleet tier: a site of hundreds of simulated devices (support/fleet_site.py: `mdl sim` processes on
Modbus TCP ports and RTU-over-TCP lines) polled at scale for tens of seconds, with Mosquitto on loopback
(SPEC 15, issue 39), by mdl's own poller, the ThingsBoard gateway's connector and Node-RED. Not in
scripts/test --fast; CI runs it after the other tiers, one test at a time (scripts/test)."""

import pytest

from support.mqtt import Broker
from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "fleet", __file__)


@pytest.fixture
def broker(tmp_path):
    """Mosquitto on loopback for one test, keeping every message for a subscriber that falls behind."""
    folder = tmp_path / "broker"
    folder.mkdir()
    b = Broker(folder, "max_queued_messages 0\n")
    try:
        yield b
    finally:
        b.stop()
