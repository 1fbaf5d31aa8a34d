"""Surveying devices nobody described: `mdl discover` (discover.py), `mdl probe` (probe.py, probe_guess.py,
probe_options.py), `mdl capture` (capture.py) and `mdl read --raw` (rawread.py)."""
