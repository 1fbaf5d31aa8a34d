"""The commands tier: mdl commands end to end, as a user runs them, against mdl sim, serial lines
and lying servers."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "commands", __file__)
