"""Compatibility tests: real third-party rosbridge clients against `python -m bridge`."""
