"""Polling many devices and publishing the polls: the targets and the poller (run.py), a site's inventory
(inventory.py), one device's polling (poll.py), MQTT (mqtt.py) and Prometheus (prometheus.py)."""
