"""SunSpec on the wire: walking a device's chain (discover.py), serving a profile as SunSpec models
(gateway.py, points.py)."""
