"""How each kind of file a vendor publishes a register table in becomes a `Table` of rows with
lines: `delimited.py` (CSV, TSV, semicolons; the `Row`/`Table` every pass reads and the header
search), `document.py` (which table of a document with several is read), `markdown.py`, `html.py`, `xlsx.py`."""
