"""Which topics a recording or a replay takes: shell-style globs over topic names.

``--topics`` takes fnmatch patterns (``/lidar/*``, ``/nav/*``); with none, every topic. The
player, given no patterns, leaves out the bridge's own topics (ask for them to get them): replaying
``/rosout`` or the telemetry (``/riverbridge/trace``, ``/riverbridge/process_stats``) into a
live bridge would mix old measurements into new ones.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

BRIDGE_OWNED = ("/rosout", "/client_count", "/riverbridge/*")
"""Topics the bridge and the telemetry publish: recorded, but not replayed by default."""


@dataclass(frozen=True)
class TopicFilter:
    """``patterns``: globs a topic must match (any of them). Without patterns every topic is
    taken but those matching ``excluded``."""

    patterns: tuple[str, ...] = ()
    excluded: tuple[str, ...] = ()

    def __call__(self, topic: str) -> bool:
        if self.patterns:
            return any(fnmatch.fnmatchcase(topic, glob) for glob in self.patterns)
        return not any(fnmatch.fnmatchcase(topic, glob) for glob in self.excluded)

    def select(self, topics: Iterable[str]) -> list[str]:
        return [topic for topic in topics if self(topic)]


def check_patterns(patterns: Sequence[str]) -> tuple[str, ...]:
    """The patterns as given; a pattern that cannot name a topic raises ValueError."""
    for pattern in patterns:
        if not pattern.startswith(("/", "*", "?", "[")):
            raise ValueError(f"topic pattern {pattern!r} must start with '/' (or a wildcard)")
    return tuple(patterns)
