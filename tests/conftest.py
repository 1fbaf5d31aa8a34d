"""Shared fixtures: serve devices with `mdl sim` on free ports, wire serial lines; the tiers (each folder's
conftest.py sets its tests' tier, support/tiers.py); the conformance data and the exhaustive variants.
What tests share that is not a fixture is in tests/support/."""

from __future__ import annotations

from pathlib import Path

import pytest

from support.common import CONFORMANCE, device_xml, in_ci, skip_or_fail
from support.devices import SerialLine, Sim
from support.tiers import ABOUT, TESTS, TIER_NAMES, TIER_VARIABLE, forbid_tier, own_tier


@pytest.fixture(autouse=True)
def _tier_in_environment(request, monkeypatch):
    """The running test's tier, where the helpers that compile or install an engine look (require_tier)."""
    monkeypatch.setenv(TIER_VARIABLE, own_tier(request.node) or "")


def pytest_configure(config):
    config.addinivalue_line("markers", "conformance(folder): needs CONFORMANCE/folder (ORNL's or the Toolkit's files)")
    config.addinivalue_line("markers", "exhaustive: slow, many-case variants; run with --exhaustive (CI=true does)")
    for tier in TIER_NAMES:
        config.addinivalue_line("markers", f"{tier}: the {tier} tier: {ABOUT[tier]} (tests/{tier}/)")


def pytest_addoption(parser):
    parser.addoption(
        "--exhaustive", action="store_true", help="also run the tests marked exhaustive (always on when CI=true)"
    )


def _exhaustive(config) -> bool:
    return bool(config.getoption("--exhaustive")) or in_ci()


def pytest_report_header(config):
    return None if _exhaustive(config) else "exhaustive variants deselected: add --exhaustive (CI runs them)"


@pytest.hookimpl(trylast=True)  # after the folders' conftest.py have set each test's tier (mark_folder)
def pytest_collection_modifyitems(config, items):
    for item in items:
        tier = own_tier(item)
        if tier is None:
            where = Path(str(item.fspath)).resolve().relative_to(TESTS)
            raise pytest.UsageError(
                f"tests/{where} is in no tier folder: put it under one of "
                + ", ".join(f"tests/{name}/" for name in TIER_NAMES)
                + " (docs/testing.md)"
            )
        if tier == "fuzz":  # the fuzzers are exhaustive variants by nature: CI runs them, a quick run need not
            item.add_marker(pytest.mark.exhaustive)
    if _exhaustive(config):
        return
    kept = [item for item in items if item.get_closest_marker("exhaustive") is None]
    if len(kept) != len(items):
        config.hook.pytest_deselected(items=[item for item in items if item not in kept])
        items[:] = kept


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    for mark in item.iter_markers("conformance"):
        folder = CONFORMANCE / mark.args[0]
        if not folder.is_dir():
            skip_or_fail(
                f"conformance data {folder} is absent: set MDL_CONFORMANCE_DIR to the folder holding "
                f"{mark.args[0]}/, or check out shared/ beside the repository"
            )


@pytest.fixture
def sim_factory():
    """start(path, *extra, serial=None, port=0, files=None) -> a running Sim, stopped when the test ends."""
    forbid_tier("unit", "a simulated device (sim_factory)", "commands")
    started: list[Sim] = []

    def start(path, *extra, serial: str | None = None, port: int = 0, files: int | None = None) -> Sim:
        sim = Sim(path, *extra, serial=serial, port=port, files=files)
        started.append(sim)
        return sim

    try:
        yield start
    finally:
        failures = []
        for sim in started:  # each is stopped (killed if need be) even when another did not stop cleanly
            try:
                sim.stop()
            except AssertionError as exc:
                failures.append(exc)
        if failures:
            raise failures[0]


@pytest.fixture
def serial_line():
    """A SerialLine (socat pseudo terminal pair), closed when the test ends; use it before the sims that
    open its ends (fixtures end in reverse order: the sims stop first)."""
    forbid_tier("unit", "a serial line (serial_line)", "commands")
    line = SerialLine()
    try:
        yield line
    finally:
        line.close()


@pytest.fixture
def write_device(tmp_path):
    def write(functions: str, name: str = "Test Device", version: str | None = "1.0", filename="device.xml") -> Path:
        path = tmp_path / filename
        path.write_text(device_xml(functions, name, version), encoding="ascii")
        return path

    return write
