"""The values the later stages hand each other, below all of them: where a device is (`connection.py`,
a plain value), what the command line adds to a description and what a writer returns (`export.py`), and
how every writer keeps text from breaking its output (`text.py`)."""
