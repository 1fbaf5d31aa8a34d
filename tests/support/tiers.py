"""The tiers: what a test costs (docs/testing.md). A test's tier is its folder's (tests/unit/,
tests/commands/, ...: each folder's conftest.py marks its tests with `mark_folder`), or a heavier marker of
its own (`@pytest.mark.compile` on one test of a unit file), or `fuzz` for a hypothesis property test
(@given) in a fast folder. Every test has exactly one tier marker.

The helpers that compile (support/c_harness.py, support/cpp_harness.py) or install an engine
(support/engines.py) call `require_tier`, and the fixtures that serve a device call `forbid_tier`, so a test
cannot slip a compiler, an engine or a device into a cheaper tier."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent.parent

# cheapest first; `scripts/test --fast` runs FAST
TIER_NAMES = ("unit", "commands", "meta", "hostile", "compile", "engines", "fleet", "fuzz")
FAST = ("unit", "commands", "meta")
ABOUT = {
    "unit": "one module of src/mdl, in process (tests/unit/ mirrors src/mdl)",
    "commands": "mdl commands end to end, against mdl sim, serial lines and lying servers",
    "meta": "the repository itself: documentation, its examples, layering, linters",
    "hostile": "hostile inputs whose proof costs seconds each (memory caps, bombs, floods, timeouts)",
    "compile": "generated C, C++ and Python built, linted and run; the wheel",
    "engines": "the engines' own code in cached virtual environments, a real broker",
    "fleet": "a site of hundreds of simulated devices polled at scale, with a real broker (SPEC 15)",
    "fuzz": "hypothesis fuzzers and property tests (also marked exhaustive)",
}

# where the running test's tier is, for the helpers (set by tests/conftest.py for each test)
TIER_VARIABLE = "MDL_TEST_TIER"


def own_tier(item) -> str | None:
    """The test's tier marker, if it has one (set by its folder or by itself)."""
    for tier in TIER_NAMES:
        if item.get_closest_marker(tier) is not None:
            return tier
    return None


def mark_folder(items, tier: str, conftest: str) -> None:
    """Give every test under the folder of `conftest` (a folder conftest's __file__) the folder's tier,
    unless it carries a tier marker of its own, or is a hypothesis property test in a fast folder (then
    `fuzz`: many examples are no part of the developer loop; in compile/, hostile/ and engines/ it keeps
    the folder's tier, which CI runs anyway)."""
    here = Path(conftest).parent
    folders = tuple({str(here) + os.sep, str(here.resolve()) + os.sep})  # as pytest found it, and resolved
    for item in items:  # a prefix says where an item stands: no path is resolved per item
        if not str(item.path).startswith(folders) or own_tier(item) is not None:
            continue
        if tier in FAST and getattr(getattr(item, "obj", None), "is_hypothesis_test", False):
            tier_here = "fuzz"  # a property test (hypothesis's @given): many examples, not one
        else:
            tier_here = tier
        item.add_marker(getattr(pytest.mark, tier_here))


def current_tier() -> str | None:
    return os.environ.get(TIER_VARIABLE)


def require_tier(tier: str, what: str) -> None:
    """Fail a test of another tier that reaches `what` (a compiler, an engine): tiers stay what they cost,
    and `scripts/test --fast` never compiles or installs. Outside a test (a script building the engines
    ahead of time) there is no tier to keep."""
    current = current_tier()
    if current is not None and current != tier:
        pytest.fail(
            f"{what} is for the {tier} tier, and this test is in the {current} tier: move it to tests/{tier}/ "
            f"(or mark that one test @pytest.mark.{tier})",
            pytrace=False,
        )


def forbid_tier(tier: str, what: str, instead: str) -> None:
    """Fail a test of `tier` that reaches `what`, which belongs to the tier `instead` or a heavier one."""
    if current_tier() == tier:
        pytest.fail(
            f"{what} is not for the {tier} tier: move the test to tests/{instead}/ "
            f"(or mark that one test @pytest.mark.{instead})",
            pytrace=False,
        )
