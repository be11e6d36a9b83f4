"""ROS name handling for topics, services and actions."""

from __future__ import annotations

from fnmatch import fnmatchcase
from functools import lru_cache

from bridge.errors import InvalidNameError


@lru_cache(maxsize=4096)  # pure; every publish resolves its topic name
def absolute_name(name: str) -> str:
    """Resolve `name` against the bridge's namespace `/` (`rosapi/topics` -> `/rosapi/topics`)."""
    stripped = name.strip()
    if not stripped or stripped == "/" or any(c.isspace() for c in stripped):
        raise InvalidNameError(f"{name!r} is not a valid ROS name")
    return stripped if stripped.startswith("/") else "/" + stripped


def allowed(name: str, patterns: tuple[str, ...]) -> bool:
    """True if no glob is configured or `name` matches one of the fnmatch `patterns`."""
    return not patterns or any(fnmatchcase(name, p) for p in patterns)
