"""The bundled synonym list: functions of thermostats, meters and I/O modules, as vendors name them.

Compiled from the register tables of several vendors; used when the INI has no
[Function Name Search Synonyms] section (or sets default_synonyms = yes).
"""

DEFAULT_SYNONYMS: dict[str, list[str]] = {
    # thermostats and room controllers
    "room_temperature": ["room temperature", "space temperature", "indoor temperature", "zone temperature",
                         "temperature", "raumtemperatur", "temperature reading", "internal temperature"],
    "outdoor_temperature": ["outdoor temperature", "outside air temperature", "outside temperature",
                            "aussentemperatur"],
    "humidity": ["humidity", "relative humidity", "room humidity", "rh", "luftfeuchte"],
    "co2": ["co2", "co2 concentration", "carbon dioxide"],
    "setpoint": ["setpoint", "set point", "temperature setpoint", "sollwert"],
    "occupied_setpoint": ["occupied setpoint", "day setpoint", "comfort setpoint"],
    "unoccupied_setpoint": ["unoccupied setpoint", "night setpoint", "economy setpoint"],
    "occupied_heating_setpoint": ["occupied heating setpoint", "heating setpoint occupied"],
    "occupied_cooling_setpoint": ["occupied cooling setpoint", "cooling setpoint occupied"],
    "unoccupied_heating_setpoint": ["unoccupied heating setpoint", "heating setpoint unoccupied"],
    "unoccupied_cooling_setpoint": ["unoccupied cooling setpoint", "cooling setpoint unoccupied"],
    "fan_speed": ["fan speed", "fan mode", "fan level", "ventilator stufe", "fan stage"],
    "mode": ["operating mode", "system mode", "hvac mode", "mode", "betriebsart"],
    "occupancy": ["occupancy", "occupied", "occupancy status", "presence", "belegung"],
    "valve_position": ["valve position", "valve output", "valve", "ventilstellung"],
    "serial_number": ["serial number", "serial no", "serial", "seriennummer"],
    "firmware_version": ["firmware version", "software version", "firmware", "version"],
    "modbus_address": ["modbus address", "device address", "slave address", "unit id"],
    "baud_rate": ["baud rate", "baudrate", "communication speed"],
    # energy meters
    "voltage_l1": ["phase 1 voltage", "voltage l1", "l1 voltage", "voltage phase a", "phase a voltage", "v1", "ua"],
    "voltage_l2": ["phase 2 voltage", "voltage l2", "l2 voltage", "voltage phase b", "phase b voltage", "v2", "ub"],
    "voltage_l3": ["phase 3 voltage", "voltage l3", "l3 voltage", "voltage phase c", "phase c voltage", "v3", "uc"],
    "current_l1": ["phase 1 current", "current l1", "l1 current", "current phase a", "phase a current", "i1", "ia"],
    "current_l2": ["phase 2 current", "current l2", "l2 current", "current phase b", "phase b current", "i2", "ib"],
    "current_l3": ["phase 3 current", "current l3", "l3 current", "current phase c", "phase c current", "i3", "ic"],
    "frequency": ["frequency", "line frequency", "supply frequency", "frequenz"],
    "total_power": ["total system power", "total active power", "total power", "active power total",
                    "system power", "wirkleistung gesamt"],
    "total_power_factor": ["total system power factor", "total power factor", "power factor total",
                           "power factor", "system power factor"],
    "total_reactive_power": ["total system reactive power", "total reactive power", "reactive power total"],
    "total_apparent_power": ["total system apparent power", "total apparent power", "apparent power total"],
    "import_energy": ["total import active energy", "import active energy", "import energy", "imported energy",
                      "energy import", "active energy import", "bezug"],
    "export_energy": ["total export active energy", "export active energy", "export energy", "exported energy",
                      "energy export", "active energy export", "einspeisung"],
    "total_energy": ["total active energy", "total energy", "energy total", "total kwh"],
    # I/O modules
    "digital_input_1": ["digital input 1", "di1", "input 1", "di 1"],
    "digital_input_2": ["digital input 2", "di2", "input 2", "di 2"],
    "digital_output_1": ["digital output 1", "do1", "output 1", "relay 1", "relay1", "do 1"],
    "digital_output_2": ["digital output 2", "do2", "output 2", "relay 2", "relay2", "do 2"],
    "analog_input_1": ["analog input 1", "ai1", "ai 1", "analogue input 1"],
    "analog_input_2": ["analog input 2", "ai2", "ai 2", "analogue input 2"],
    "analog_output_1": ["analog output 1", "ao1", "ao 1", "analogue output 1"],
    "analog_output_2": ["analog output 2", "ao2", "ao 2", "analogue output 2"],
}
