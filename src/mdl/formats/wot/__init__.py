"""W3C Web of Things Thing Descriptions with Modbus forms (`--from wot`, SPEC 11.1), read only here:
`read.read_wot` (a TD -> the document model). `vocabulary` holds the words a TD and node-wot's Modbus
binding use, which the writer (mdl.exports.wot) shares. `guess` is how mdl.formats tells a TD from the
start of a `.json` file; a `.jsonld` file is a TD by its name."""

from __future__ import annotations

_MODBUS_MARKS = ('"modbus+tcp://', '"modv:')


def guess(head: str) -> bool:
    """Whether the start of a file is a TD with Modbus forms: a JSON object naming the binding's scheme or
    vocabulary (`"modbus+tcp://`, `"modv:`) in its first 64 KiB."""
    return head.lstrip().startswith("{") and any(mark in head for mark in _MODBUS_MARKS)
