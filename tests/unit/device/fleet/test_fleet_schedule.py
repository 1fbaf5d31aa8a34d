"""The fleet poller's schedule and shared plans (mdl.device.fleet.run; issue 39): first polls STAGGERed and
wrapped into each device's interval, so hundreds of devices never connect and poll at once; each next poll
due an interval after the last was due (a late start shifts none after it; a poll slower than its interval
is followed at once, never by a burst); the devices of one description share one read plan and decoder."""

from __future__ import annotations

import asyncio
import time
from collections import Counter

import pytest

import mdl
from mdl.device.fleet import run
from mdl.device.fleet.run import STAGGER, Polled, _Fleet, first_start, next_start, parse_target
from support.common import DATA

ALL = DATA / "all_tables.xml"


def test_a_few_devices_start_at_once_and_one_read_of_each_is_not_staggered():
    assert [first_start(i, 10.0, None) for i in range(3)] == [0.0, STAGGER, 2 * STAGGER]
    assert all(first_start(i, 10.0, 1) == 0.0 for i in range(500))  # one read of each: as soon as possible


@pytest.mark.parametrize(("devices", "interval"), [(500, 10.0), (2000, 10.0), (500, 5.0), (200, 0.5)])
def test_thousands_of_first_polls_spread_evenly_over_the_interval(devices, interval):
    offsets = [first_start(i, interval, None) for i in range(devices)]
    assert all(0.0 <= o < interval for o in offsets)
    per_slot = Counter(int(o / STAGGER + 1e-6) for o in offsets)  # first polls in each STAGGER-long slot
    assert max(per_slot.values()) <= -(-devices * STAGGER // interval)  # never more than the fair share


def test_the_next_poll_is_due_an_interval_after_the_last_was_due():
    assert next_start(due=100.0, delay=10.0, now=100.4) == 110.0  # began 0.4 s late: the grid holds
    assert next_start(due=100.0, delay=20.0, now=101.0) == 120.0  # backed off: 2 intervals after it was due
    assert next_start(due=100.0, delay=10.0, now=112.5) == 112.5  # slower than its interval: at once, no burst


def test_late_starts_never_drift_the_schedule():
    due, starts = 0.0, []
    for lateness in [0.3, 0.0, 0.9, 0.1, 0.5]:  # each poll began late, by less than the interval
        starts.append(due + lateness)
        due = next_start(due, 1.0, now=due + lateness + 0.05)
    assert starts == pytest.approx([0.3, 1.0, 2.9, 3.1, 4.5])
    assert due == 5.0


def _polled(resolved, unit: int, ident: str, interval: float | None = None) -> Polled:
    return Polled(parse_target(f"{ALL}@tcp://127.0.0.1:1#{unit}"), resolved, [f.fn for f in resolved.readable],
                  ident, interval)  # fmt: skip


def test_the_devices_of_one_description_share_its_plan_and_decoder():
    one, other = (mdl.resolve(mdl.load(ALL)) for _ in range(2))  # `other`: another description, alike

    async def sessions():
        polled = [_polled(one, 1, "a"), _polled(one, 2, "b"), _polled(other, 3, "c")]
        fleet = _Fleet(polled, [], 1.0, None)
        return [fleet._session(p) for p in polled]

    a, b, c = asyncio.run(sessions())
    assert a._plans is b._plans and a.evaluator is b.evaluator  # made and compiled once for both
    assert c._plans is not a._plans and c.evaluator is not a.evaluator
    assert a.refused is not b.refused and (a.unit, b.unit) == (1, 2)  # what a device refused stays its own
    functions = [f.fn for f in one.readable]
    plan = a._plan(tuple(fn.name for fn in functions))
    assert b._plan(tuple(fn.name for fn in functions)) is plan
    raw = [0] * plan.size
    for _ in range(3):  # the second decode compiles the decoder: once, whichever device decodes
        plan.decode(raw)
    assert plan.decode.compiled is not None


class _Times:
    """A sink keeping when each device's polls came (loop time)."""

    def __init__(self) -> None:
        self.at: dict[str, list[float]] = {}

    def started(self, polled) -> None: ...
    def failed(self, polled, when, exc) -> None: ...
    def close(self) -> None: ...

    def record(self, polled, values, when) -> None:
        self.at.setdefault(polled.ident, []).append(asyncio.get_running_loop().time())


def _poll_with(monkeypatch, devices: int, interval: float, count: int, took=lambda ident, n: (0.0, 0.0)):
    """Poll `devices` devices `count` times with a read (no device) that holds the event loop, then waits,
    `took(ident, poll)` = (held, waited) s: the loop time each poll's record came, by device, and the loop
    time polling began."""
    resolved = mdl.resolve(mdl.load(ALL))
    polls: Counter[str] = Counter()

    async def read(session, line, functions, turn):
        ident = next(p.ident for p in polled if p.target.unit == session.unit)
        turn.append(run.datetime.now(run.timezone.utc))
        held, waited = took(ident, polls[ident])
        time.sleep(held)  # the loop does nothing else meanwhile: the other devices start late
        await asyncio.sleep(waited)
        polls[ident] += 1
        return {}

    monkeypatch.setattr(run, "_read", read)
    polled = [_polled(resolved, i + 1, f"d{i}", interval) for i in range(devices)]
    times = _Times()

    async def main():
        fleet = _Fleet(polled, [times], interval, count)
        began = asyncio.get_running_loop().time()
        assert await fleet.run() == 0
        return began

    began = asyncio.run(main())
    return times.at, began


def test_first_polls_come_staggered_and_the_rest_on_the_grid(monkeypatch):
    at, began = _poll_with(monkeypatch, devices=40, interval=0.2, count=3)
    assert set(at) == {f"d{i}" for i in range(40)} and all(len(t) == 3 for t in at.values())
    for i in range(40):
        due = began + first_start(i, 0.2, 3)
        polls = at[f"d{i}"]
        assert polls[0] >= due - 1e-3  # never before it is due
        for k, t in enumerate(polls):
            assert due + k * 0.2 - 1e-3 <= t < due + k * 0.2 + 0.1, (i, k, t - due)  # on the grid, no drift
    firsts = [t[0] - began for t in at.values()]  # 40 x 0.01 s wrapped into 0.2 s: two rounds of the interval
    assert min(firsts) < 0.05 and max(firsts) > 0.15


def test_a_late_start_shifts_none_after_it_and_a_slow_poll_is_followed_at_once(monkeypatch):
    def took(ident: str, n: int) -> tuple[float, float]:
        return {("d0", 1): (0.12, 0.0), ("d2", 1): (0.0, 0.35)}.get((ident, n), (0.0, 0.0))

    at, began = _poll_with(monkeypatch, devices=3, interval=0.2, count=4, took=took)
    d1 = [t - began for t in at["d1"]]  # its second poll, due at 0.21, began late (d0 held the loop to 0.32)
    assert d1[1] >= 0.31 and 0.41 - 1e-3 <= d1[2] < 0.47  # the third still due at 0.41, not 0.52
    d2 = [t - began for t in at["d2"]]  # its second took 0.35 s (> 0.2): the third at once, then 0.2 on
    # (0.2 after the third was due, which was when the second ended: the third's turn may come a little later)
    assert d2[1] == pytest.approx(d2[2], abs=0.03) and 0.2 - 0.03 <= d2[3] - d2[2] < 0.25


def test_a_stop_ends_the_run_though_a_read_swallows_its_cancellation(monkeypatch):
    """asyncio.wait_for (pymodbus's connect and requests) can return its result, or raise its error, when that
    comes as it is cancelled (Python before 3.12): the task then polled on, and a SIGINT under load never
    ended `mdl read --interval` (seen in CI, a device refusing connections). The run cancels again and the
    polling loop ends at its next turn once the stop is set."""
    resolved = mdl.resolve(mdl.load(ALL))
    swallowed: list[str] = []

    async def read(session, line, functions, turn):
        turn.append(run.datetime.now(run.timezone.utc))
        try:
            await asyncio.sleep(0.05)
        except asyncio.CancelledError:  # what wait_for does when the connection's refusal comes at that moment
            swallowed.append(f"unit {session.unit}")
            raise run.error("cannot connect: refused") from None
        return {}

    monkeypatch.setattr(run, "_read", read)
    polled = [_polled(resolved, i + 1, f"d{i}", 0.05) for i in range(3)]

    async def main():
        fleet = _Fleet(polled, [_Times()], 0.05, None)  # polls until stopped
        asyncio.get_running_loop().call_later(0.3, fleet.stop.set)
        return await asyncio.wait_for(fleet.run(), 10)

    asyncio.run(main())
    assert swallowed  # the stop came while a read was under way: its cancellation was swallowed, and it ended
