"""The hostile tier: hostile inputs whose proof costs seconds each (processes under a memory cap,
bombs, floods of connections, timeouts that must pass). The cheap hostile tests are in unit/ and commands/."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "hostile", __file__)
