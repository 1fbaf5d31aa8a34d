"""WISE-Agent `Modbus.ini` (SPEC 7): read into the document model (`read`) and written back in the shipped
agent's form (`write`); `sections` holds the format's vocabulary, `lua` the arithmetic its Lua column may carry."""
