"""Modbus Schema Toolkit YAML (`--from schema`), read only: `read.read_schema` (the document model),
`read.import_schema` and `read.with_registers` (what `mdl import` writes: each field's registers written in)."""
