"""Other device description formats."""
