"""The device served: `mdl sim` (sim.py, its scenarios in scenarios.py) and the gateway `mdl serve` (serve.py)."""
