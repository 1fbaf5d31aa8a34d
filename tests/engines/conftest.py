"""The engines tier: the engines' own code in cached virtual environments (support/engines.py,
support/engines_fleet.py, which fail a test of any other tier), a real broker, pysunspec2's client."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "engines", __file__)
