"""The meta tier: the repository itself (the documentation and every example in it, the layering,
the linters on src/ and tests/). Cheap: scripts/test --fast runs it with unit and commands."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "meta", __file__)
