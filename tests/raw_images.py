"""Raw register images the engine tests serve with `mdl sim --registers` (wire addresses), so that each
engine reads the same device as `mdl read`: every table of tests/data/all_tables.xml, and the TEMCO
thermostat of examples/."""

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
