"""rmw_zenoh's liveliness tokens: how its graph cache learns nodes and endpoints. Pure.

`@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>` for a
node (kind `NN`, its entity id repeats its node id), followed by
`/<topic>/<dds type>/<type hash>/<qos>` for a publisher (`MP`), subscription (`MS`), service
server (`SS`) or client (`SC`). Names are mangled (`/` -> `%`, an empty one is `%`). The QoS
element lists reliability, durability, history and depth, deadline, lifespan and liveliness,
each left empty where it equals rmw_zenoh's default (reliable, volatile, keep-last 42,
infinite durations, automatic liveliness): a keep-last 7 reliable endpoint is `::,7:,:,:,,`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from bridge.dds.naming import type_from_dds, type_to_dds
from bridge.dds.qos import QosProfile
from bridge.zenoh.keys import demangle, mangle

ADMIN_SPACE = "@ros2_lv"
DEFAULT_DEPTH = 42  # rmw_zenoh's depth for KEEP_LAST with depth 0, and its default
# rmw's enum values as rmw_zenoh writes them into the QoS element.
RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST, KEEP_ALL = 1, 2


class TokenProblem(ValueError):
    """A key under `@ros2_lv` that is not a token rmw_zenoh would declare."""


class EntityKind(Enum):
    NODE = "NN"
    PUBLISHER = "MP"
    SUBSCRIPTION = "MS"
    SERVICE = "SS"
    CLIENT = "SC"


@dataclass(frozen=True)
class Endpoint:
    name: str  # absolute ROS name of the topic or service
    type_name: str  # ROS type: "sensor_msgs/msg/Imu", "std_srvs/srv/SetBool"
    type_hash: str
    qos: QosProfile = field(default_factory=lambda: QosProfile(depth=DEFAULT_DEPTH))


@dataclass(frozen=True)
class Entity:
    """One liveliness token's meaning."""

    domain: int
    zid: str  # the Zenoh session id, lowercase hex
    node_id: int
    entity_id: int
    kind: EntityKind
    namespace: str  # "/" or "/ns"
    node_name: str  # "talker"
    enclave: str = "/"
    endpoint: Endpoint | None = None  # None for a node

    @property
    def node(self) -> str:
        """The fully qualified node name: `/talker`, `/ns/talker`."""
        return self.namespace.rstrip("/") + "/" + self.node_name


def qos_element(qos: QosProfile) -> str:
    """The QoS element of a token (deadline, lifespan, liveliness: always the default)."""
    reliability = "" if qos.reliable else str(BEST_EFFORT)
    durability = str(TRANSIENT_LOCAL) if qos.transient_local else ""
    history = str(KEEP_ALL) if qos.depth == 0 else ""
    depth = "" if qos.depth in (0, DEFAULT_DEPTH) else str(qos.depth)
    return f"{reliability}:{durability}:{history},{depth}:,:,:,,"


def parse_qos_element(element: str) -> QosProfile:
    parts = element.split(":")
    if len(parts) != 6 or parts[2].count(",") != 1:
        raise TokenProblem(f"QoS element {element!r} is not rmw_zenoh's")
    history, depth = parts[2].split(",")
    try:
        keep_all = _enum(history, KEEP_LAST, KEEP_ALL) == KEEP_ALL
        return QosProfile(
            reliable=_enum(parts[0], RELIABLE, BEST_EFFORT) == RELIABLE,
            transient_local=_enum(parts[1], VOLATILE, TRANSIENT_LOCAL) == TRANSIENT_LOCAL,
            depth=0 if keep_all else int(depth) if depth else DEFAULT_DEPTH,
        )
    except ValueError as exc:
        raise TokenProblem(f"QoS element {element!r}: {exc}") from exc


def _enum(text: str, default: int, other: int) -> int:
    """An rmw enum value; "" is rmw_zenoh's default, 0 (system default) counts as it too."""
    value = int(text) if text else default
    return other if value == other else default


def token_key(entity: Entity) -> str:
    """The liveliness key expression rmw_zenoh declares for `entity`."""
    parts = [
        ADMIN_SPACE,
        str(entity.domain),
        entity.zid,
        str(entity.node_id),
        str(entity.entity_id),
        entity.kind.value,
        mangle(entity.enclave),
        mangle(entity.namespace),
        mangle(entity.node_name),
    ]
    if entity.endpoint is not None:
        endpoint = entity.endpoint
        parts += [
            mangle(endpoint.name),
            type_to_dds(endpoint.type_name),
            endpoint.type_hash,
            qos_element(endpoint.qos),
        ]
    return "/".join(parts)


def parse_token(key: str) -> Entity:
    """The entity a liveliness key announces (TokenProblem if it is not a valid token)."""
    parts = key.split("/")
    if len(parts) not in (9, 13) or parts[0] != ADMIN_SPACE or not all(parts):
        raise TokenProblem(f"{key!r} is not an rmw_zenoh liveliness token")
    try:
        kind = EntityKind(parts[5])
        domain, node_id, entity_id = int(parts[1]), int(parts[3]), int(parts[4])
    except ValueError as exc:
        raise TokenProblem(f"{key!r}: {exc}") from exc
    if (kind is EntityKind.NODE) != (len(parts) == 9):
        raise TokenProblem(f"{key!r}: a {kind.name.lower()} token with {len(parts)} elements")
    endpoint = None
    if kind is not EntityKind.NODE:
        type_name = type_from_dds(parts[10])
        if type_name is None:
            raise TokenProblem(f"{key!r}: {parts[10]!r} is not a ROS 2 DDS type name")
        endpoint = Endpoint(demangle(parts[9]), type_name, parts[11], parse_qos_element(parts[12]))
    return Entity(
        domain,
        parts[2],
        node_id,
        entity_id,
        kind,
        namespace=demangle(parts[7]),
        node_name=demangle(parts[8]),
        enclave=demangle(parts[6]),
        endpoint=endpoint,
    )
