"""The restart counts `riverbridge up` publishes, as a standard diagnostics message.

`up` publishes a latched `diagnostic_msgs/msg/DiagnosticArray` on `/riverbridge/restarts`
with one status per component (name `up/<component>`, key `restarts`), so the dashboard,
Foxglove and the bridge's `GET /metrics` (`riverbridge_component_restarts_total`) read the
same numbers without the bridge knowing anything about `up`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from schemas.catalogue import TOPICS

RESTARTS_TOPIC, RESTARTS_TYPE = TOPICS["restarts"].pair
NAME_PREFIX = "up/"
OK, WARN = 0, 1  # diagnostic_msgs/DiagnosticStatus levels


@dataclass(frozen=True)
class ComponentRestarts:
    """One component's restarts so far and how its last run ended (empty if it never did)."""

    restarts: int = 0
    last_exit: str = ""
    pid: int = 0


def restarts_msg(components: Mapping[str, ComponentRestarts], stamp_ns: int) -> dict[str, Any]:
    """The DiagnosticArray for `components` (component name -> its restarts)."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return {
        "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
        "status": [_status(name, state) for name, state in components.items()],
    }


def _status(name: str, state: ComponentRestarts) -> dict[str, Any]:
    message = (
        f"restarted {state.restarts} times; last exit: {state.last_exit}"
        if state.restarts
        else "running since start"
    )
    return {
        "level": WARN if state.restarts else OK,
        "name": NAME_PREFIX + name,
        "message": message,
        "hardware_id": "",
        "values": [
            {"key": "restarts", "value": str(state.restarts)},
            {"key": "pid", "value": str(state.pid)},
        ],
    }


def restart_counts(msg: Mapping[str, Any]) -> dict[str, int]:
    """Component name -> restarts, read back from a restarts message (others ignored)."""
    counts: dict[str, int] = {}
    for status in msg.get("status", []):
        name = status.get("name", "")
        if not name.startswith(NAME_PREFIX):
            continue
        values = {kv.get("key"): kv.get("value") for kv in status.get("values", [])}
        restarts = values.get("restarts", "")
        if isinstance(restarts, str) and restarts.isdigit():
            counts[name.removeprefix(NAME_PREFIX)] = int(restarts)
    return counts
