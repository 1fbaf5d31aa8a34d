"""The poller's back-off (SPEC 15, mdl.device.fleet.run.after_poll): a device that fails three polls in a row
is polled again after 2, 4, 8 ... intervals, at most 10 minutes apart; said once when it goes and once when
it answers again; a device that answers keeps its interval."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mdl.device.fleet.run import BACK_OFF_AFTER, MAX_BACK_OFF, after_poll, retry_delay


def schedule(interval: float, results: list[bool]) -> tuple[list[float], list[tuple[int, str]]]:
    """Start times of the polls with these results (True: it read), and what is said after which poll."""
    start, failures = 0.0, 0
    starts, said = [], []
    for i, ok in enumerate(results):
        starts.append(start)
        outcome = after_poll(interval, failures, ok)
        if outcome.said:
            said.append((i, outcome.said))
        failures = outcome.failures
        start += outcome.delay
    return starts, said


def test_three_failures_then_doubling_intervals():
    starts, said = schedule(10, [False] * 7)
    assert [b - a for a, b in zip(starts, starts[1:], strict=False)] == [10, 10, 20, 40, 80, 160]
    assert said == [(2, "backing off")]


def test_said_once_going_and_once_back_and_then_on_time_again():
    results = [True, False, False, False, False, False, True, True, False, True]
    starts, said = schedule(1, results)
    assert said == [(3, "backing off"), (6, "answering again")]
    gaps = [b - a for a, b in zip(starts, starts[1:], strict=False)]
    assert gaps == [1, 1, 1, 2, 4, 8, 1, 1, 1]  # back on its interval as soon as it reads; one failure is no back-off


def test_two_failures_are_no_back_off():
    starts, said = schedule(5, [False, False, True, False, False, True])
    assert said == [] and starts == [0, 5, 10, 15, 20, 25]


def test_the_back_off_stops_at_ten_minutes():
    assert MAX_BACK_OFF == 600
    assert [retry_delay(10, n) for n in range(1, 12)] == [10, 10, 20, 40, 80, 160, 320, 600, 600, 600, 600]
    assert retry_delay(10, 10_000) == 600  # no overflow however long it fails


def test_an_interval_longer_than_the_cap_is_never_shortened():
    assert retry_delay(3600, 5) == 3600
    assert retry_delay(0.1, 40) == 600


@given(st.floats(0.1, 86400), st.lists(st.booleans(), max_size=60))
def test_any_run_keeps_the_rules(interval, results):
    starts, said = schedule(interval, results)
    gaps = [b - a for a, b in zip(starts, starts[1:], strict=False)]
    assert all(interval * (1 - 1e-9) <= gap <= max(interval, MAX_BACK_OFF) * (1 + 1e-9) for gap in gaps)
    kinds = [text for _, text in said]
    assert all(a != b for a, b in zip(kinds, kinds[1:], strict=False))  # going and back alternate
    assert not kinds or kinds[0] == "backing off"
    run = 0
    for i, ok in enumerate(results):
        run = 0 if ok else run + 1
        if run == BACK_OFF_AFTER:
            assert (i, "backing off") in said


@pytest.mark.parametrize("failures", [0, 1, 2])
def test_a_poll_that_reads_resets_the_count(failures):
    outcome = after_poll(2.0, failures, ok=True)
    assert (outcome.failures, outcome.delay, outcome.said) == (0, 2.0, None)
