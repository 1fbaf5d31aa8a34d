"""SmartServer Modbus XIF (`.mod`): `read.read_xif` (import) and `write.export_xif` (export).
`columns` holds the format's words (column headings current and pre-3.2, native types, function
codes, write enable values), `records` its CSV records with positions, `rows` a datapoint row read
into a function, `scaling` the two-point and A'/B'/C' scaling both ways. docs/xif.md has the mapping."""
