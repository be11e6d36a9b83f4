"""ROS 2 quality-of-service profiles for the DDS mirror, as plain data (no Cyclone here).

Writers take ROS 2's default profile (reliable, volatile, keep-last 10), transient-local
keep-last 1 for a latched advertisement, or what the advertise op's `qos` object asks for
(rosbridge PR #1150: `history`, `depth`, `reliability`, `durability`; `best_available` means
the stronger policy for a writer). Readers adapt to the writers they will meet, like
rosbridge's subscriptions: best effort if any writer is best effort (a reliable reader never
matches one), transient-local only if every writer keeps history, unless a subscribe op's
`qos` object (rosbridge's shape too) asks for a policy.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class QosProfile:
    """The QoS policies ROS 2 puts on a topic's endpoints; `depth` 0 means keep-all."""

    reliable: bool = True
    transient_local: bool = False
    depth: int = 10

    def describe(self) -> str:
        history = "keep-all" if self.depth == 0 else f"keep-last {self.depth}"
        return (
            f"{'reliable' if self.reliable else 'best-effort'}, "
            f"{'transient-local' if self.transient_local else 'volatile'}, {history}"
        )


# rmw_qos_profile_default: what rclcpp/rclpy publishers and subscriptions use unless told.
DEFAULT = QosProfile()
# A latched topic (`latch: true`): the last message waits for late subscribers.
LATCHED = QosProfile(transient_local=True, depth=1)
# rmw_qos_profile_sensor_data: best effort, volatile, keep-last 5.
SENSOR_DATA = QosProfile(reliable=False, depth=5)
# rmw_qos_profile_services_default: reliable, volatile, keep-last 10.
SERVICES = QosProfile()
# rmw_dds_common's ros_discovery_info: reliable, transient-local, keep-last 1.
DISCOVERY = QosProfile(transient_local=True, depth=1)

_RELIABILITY = {
    "reliable": True,
    "best_effort": False,
    "best_available": True,
    "system_default": True,
}
_DURABILITY = {
    "transient_local": True,
    "volatile": False,
    "best_available": True,
    "system_default": False,
}


class QosError(ValueError):
    """An advertise op's `qos` object names a policy value ROS 2 does not have."""


def writer_profile(latch: bool, qos: Mapping[str, Any] | None) -> QosProfile:
    """The writer profile for an advertisement: `qos` first, then `latch`, then the default."""
    base = LATCHED if latch else DEFAULT
    if not qos:
        return base
    reliable = _choice(qos, "reliability", _RELIABILITY, base.reliable)
    transient = _choice(qos, "durability", _DURABILITY, base.transient_local)
    depth = base.depth
    history = qos.get("history", "keep_last")
    if history == "keep_all":
        depth = 0
    elif history not in ("keep_last", "system_default"):
        raise QosError(f"qos.history must be keep_last or keep_all, got {history!r}")
    if "depth" in qos and history != "keep_all":
        depth = qos["depth"]
        if isinstance(depth, bool) or not isinstance(depth, int) or depth < 1:
            raise QosError(f"qos.depth must be a positive integer, got {qos['depth']!r}")
    return QosProfile(reliable, transient, depth)


def advertised_profile(latch: bool, qos: Mapping[str, Any] | None) -> tuple[QosProfile, str]:
    """`writer_profile`, or the profile without `qos` and the reason when `qos` is bad."""
    try:
        return writer_profile(latch, qos), ""
    except QosError as exc:
        return writer_profile(latch, None), str(exc)


def _choice(qos: Mapping[str, Any], key: str, table: Mapping[str, bool], default: bool) -> bool:
    value = qos.get(key)
    if value is None:
        return default
    if value not in table:
        raise QosError(f"qos.{key} must be one of {', '.join(table)}; got {value!r}")
    return table[value]


# A reader's history is the bridge's own buffer between Cyclone's receive thread and the pump
# thread (it is not part of QoS matching): deep enough that a burst of small messages
# arriving while the pump waits for the GIL is not overwritten.
READER_DEPTH = 64


def reader_profile(
    writers: Iterable[QosProfile], requests: Iterable[Mapping[str, Any]] = ()
) -> QosProfile:
    """A reader profile that matches every writer in `writers` (reliable, volatile if none),
    unless the local subscribers' `qos` objects (rosbridge's subscribe `qos`) ask otherwise.

    One reader serves every local subscriber: a policy one of them asks for explicitly
    replaces the adaptive choice (`best_effort` wins over `reliable`, as it matches more
    writers; `transient_local` then reads only writers that keep history, as in ROS 2);
    `best_available` and `system_default` keep adapting. `depth` may enlarge the buffer.
    Raises QosError for a value ROS 2 does not have.
    """
    known = list(writers)
    reliable = all(w.reliable for w in known)
    transient_local = bool(known) and all(w.transient_local for w in known)
    depth = READER_DEPTH
    asked = [_reader_request(qos) for qos in requests]
    reliabilities = {r for r, _, _ in asked if r is not None}
    if reliabilities:
        reliable = all(reliabilities)
    durabilities = {d for _, d, _ in asked if d is not None}
    if durabilities:
        transient_local = any(durabilities)
    depth = max([depth, *(n for _, _, n in asked if n is not None)])
    return QosProfile(reliable, transient_local, depth)


_READER_CHOICES = {
    "reliable": True,
    "best_effort": False,
    "transient_local": True,
    "volatile": False,
}


def _reader_request(qos: Mapping[str, Any]) -> tuple[bool | None, bool | None, int | None]:
    """(reliable, transient_local, depth) a subscribe `qos` asks for; None = adapt."""
    reliability, durability = qos.get("reliability"), qos.get("durability")
    _choice(qos, "reliability", _RELIABILITY, True)  # refuses unknown values
    _choice(qos, "durability", _DURABILITY, False)
    depth = writer_profile(False, qos).depth if "depth" in qos else None
    return (
        _READER_CHOICES.get(reliability) if reliability in ("reliable", "best_effort") else None,
        _READER_CHOICES.get(durability) if durability in ("transient_local", "volatile") else None,
        depth or None,
    )


def strongest(profiles: Iterable[QosProfile]) -> QosProfile:
    """One writer serves several local advertisers: the most demanding request wins."""
    chosen = list(profiles)
    if not chosen:
        return DEFAULT
    depths = [p.depth for p in chosen]
    return QosProfile(
        reliable=any(p.reliable for p in chosen),
        transient_local=any(p.transient_local for p in chosen),
        depth=0 if 0 in depths else max(depths),
    )
