"""The fuzz tier: hypothesis fuzzers, with a growth check for every reader; all marked exhaustive
(CI runs them, --exhaustive locally). A hypothesis test in another folder is fuzz too."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "fuzz", __file__)
