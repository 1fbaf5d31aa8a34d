"""The compile tier: generated C, C++ and Python built (gcc, g++, clang++, clang-tidy, ruff, mypy)
and run against mdl sim; the wheel. The compiler helpers (support/c_harness.py, support/cpp_harness.py)
fail a test of any other tier."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "compile", __file__)
