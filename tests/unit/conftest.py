"""The unit tier: one module of src/mdl at a time, in process; the folders mirror src/mdl. A test that
serves or dials a device is a commands test (the sim_factory and serial_line fixtures fail here)."""

from support.tiers import mark_folder


def pytest_collection_modifyitems(items):
    mark_folder(items, "unit", __file__)
