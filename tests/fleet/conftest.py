"""The fleet tier: a site of hundreds of simulated devices (support/fleet_site.py: `mdl sim` processes on
Modbus TCP ports and RTU-over-TCP lines) polled at scale for tens of seconds, with Mosquitto on loopback
(SPEC 15, issue 39). Not in scripts/test --fast; CI runs it."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "fleet", __file__)
