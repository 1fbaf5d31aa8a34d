"""mdl: Modbus register tables -> MDL XML -> drivers for C++ (libmodbus) and Python (pymodbus)."""

__version__ = "0.1.0"
