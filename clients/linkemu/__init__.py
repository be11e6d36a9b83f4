"""A userspace link emulator: a TCP proxy with rate, delay, jitter, stalls and a bounded
bottleneck queue, for tests, benchmarks and the report (docs/linkemu.md)."""

from clients.linkemu.profiles import PROFILES, Direction, LinkProfile, profile_named
from clients.linkemu.proxy import LinkEmulator, LinkStats

__all__ = ["PROFILES", "Direction", "LinkEmulator", "LinkProfile", "LinkStats", "profile_named"]
