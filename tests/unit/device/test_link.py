"""device.link.Link, a client of one unit with checked frames and no description: how its errors name
the connection and the units it asks (probe and discover ask many through one connection)."""

from __future__ import annotations

from mdl.device.connection import Connection
from mdl.device.link import Link


def test_a_link_names_its_connection_and_unit():
    link = Link(Connection(host="127.0.0.1", port=1502), 7)
    assert link.where("reading 2 holding from 10") == "127.0.0.1:1502 unit 7: reading 2 holding from 10"
    assert link.asking == "unit 7"


def test_a_link_asking_many_units_names_them_as_runs():
    link = Link(Connection(host="127.0.0.1", port=1502))
    link.asking_units([5, 1, 2, 3, 9])
    assert link.asking == "units 1-3, 5, 9"
    link.asking_units([4])
    assert link.asking == "unit 4"


def test_a_link_to_nobody_says_so_without_a_traceback():
    link = Link(Connection(host="127.0.0.1", port=1, timeout=0.2, retries=0))
    error = link.connect_error()
    assert "cannot connect to 127.0.0.1:1 for unit 1" in str(error)
