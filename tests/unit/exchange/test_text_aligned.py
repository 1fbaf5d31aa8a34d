"""exchange.text.aligned, the one table printer of the commands' text output."""

from __future__ import annotations

from mdl.exchange.text import aligned


def test_every_column_but_the_last_is_padded_to_its_widest_cell():
    rows = [("UNIT", "FILE", "DEVICE"), ("1", "meter.xml", "Meter"), ("12", "a.xml", "")]
    assert aligned(rows) == ["UNIT  FILE       DEVICE", "1     meter.xml  Meter", "12    a.xml      "]


def test_no_rows_and_one_column():
    assert aligned([]) == []
    assert aligned([("a",), ("bcd",)]) == ["a", "bcd"]
