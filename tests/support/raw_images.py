"""What the tests serve: raw register images for `mdl sim --registers` (wire addresses), so that each
engine reads the same device as `mdl read` (every table of tests/data/all_tables.xml, and the TEMCO
thermostat of examples/), and the `--set` values the drivers' tests give all_tables.xml."""

ALL_TABLES_RAW = {
    "coil": {"0": 1, "1": 0, "5": 1},
    "discrete": {"0": 0, "1": 1},
    "input": {"0": 0x5678, "1": 0x1234, "2": 0x4049, "3": 0x0FDB, "10": 2301},
    "holding": {
        "50": 65535,
        "52": 7,
        "100": 0xFF38,
        "101": 2,
        "102": 0x4142,
        "103": 0x4320,
        "104": 0,
        "105": 0,
        "200": 0xFFFF,
        "201": 0xFFFE,
        "202": 0x1234,
        "203": 0x5678,
        "300": 101,
        "400": 0x1122,
        "401": 0x3344,
        "402": 0x7F85,
        "403": 0xC812,
    },
}
TEMCO_RAW = {
    "holding": {
        "6": 0xAB07,
        "7": 0x0112,
        "121": 0xFF06,
        "140": 455,
        "137": 0x0103,
        "128": 2,
        "255": 1,
        "256": 0,
        "257": 1,
        "258": 0,
        "259": 1,
        "345": 215,
        "346": 180,
        "348": 205,
    }
}

# every writable function of tests/data/all_tables.xml, as the driver tests seed it
ALL_SETTINGS = [
    "--set",
    "setpoint=21.5",
    "--set",
    "mode=Cool",
    "--set",
    "label=Hall",
    "--set",
    "energy=1234.567",
    "--set",
    "power=-12.5",
    "--set",
    "big=-5000000000",
    "--set",
    "temp_offset=-10",
    "--set",
    "serial=305419896",
    "--set",
    "low_byte=-3",
    "--set",
    "high_byte=200",
    "--set",
    "pump=1",
    "--set",
    "flow=12.3",
    "--set",
    "door_open=1",
]
