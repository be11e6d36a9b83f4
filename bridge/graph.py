"""The ROS graph as the bridge sees it: topics, services, actions and who owns them.

The bridge is the whole graph for its clients: each connected client is a node named
`/rosbridge_client_<n>`. Entries record owners by node name so that another source of
messages (a DDS mirror, see `bridge.sinks`) can own publishers and services too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bridge.errors import GraphConflictError
from bridge.outgoing import TopicMessage
from schemas.values import JsonObject, OpId

BRIDGE_NODE = "/rosbridge_websocket"
ROSAPI_NODE = "/rosapi"
ROSOUT_TOPIC = "/rosout"
ROSOUT_TYPE = "rcl_interfaces/msg/Log"


@dataclass
class TopicEntry:
    """One topic: its type, its publishers (node -> advertisement ids) and subscribers."""

    name: str
    type_name: str | None = None
    publishers: dict[str, set[OpId]] = field(default_factory=dict)
    subscribers: set[str] = field(default_factory=set)
    latching: set[str] = field(default_factory=set)
    latched: TopicMessage | None = None
    # The `qos` object each publishing node advertised with (a DDS mirror's writer QoS).
    qos: dict[str, JsonObject] = field(default_factory=dict)
    # The `qos` object each subscribing node subscribed with (a DDS mirror's reader QoS).
    subscriber_qos: dict[str, JsonObject] = field(default_factory=dict)

    def is_unused(self) -> bool:
        return not self.publishers and not self.subscribers


@dataclass
class ServiceEntry:
    """A client-provided service; `requests_sent` numbers `service_request:<name>:<n>` ids.

    `spelling` is the name as the provider advertised it: forwarded requests carry it so the
    provider's library finds its handler.
    """

    name: str
    spelling: str
    type_name: str | None
    provider: str
    requests_sent: int = 0


@dataclass
class ActionEntry:
    """A client-provided action server; `goals_sent` numbers `action_goal:<name>:<n>` ids."""

    name: str
    spelling: str
    type_name: str | None
    provider: str
    goals_sent: int = 0


@dataclass
class Graph:
    """Topics, services and actions keyed by their absolute names."""

    topics: dict[str, TopicEntry] = field(default_factory=dict)
    services: dict[str, ServiceEntry] = field(default_factory=dict)
    actions: dict[str, ActionEntry] = field(default_factory=dict)

    def __post_init__(self) -> None:
        rosout = self.topic(ROSOUT_TOPIC)
        rosout.type_name = ROSOUT_TYPE
        rosout.publishers[BRIDGE_NODE] = {None}

    def topic(self, name: str) -> TopicEntry:
        """The entry for `name`, created empty if the topic is new."""
        entry = self.topics.get(name)
        if entry is None:
            entry = self.topics[name] = TopicEntry(name)
        return entry

    def declare_type(self, name: str, type_name: str) -> TopicEntry:
        """Fix the topic's type, or raise GraphConflictError if another type is established."""
        entry = self.topic(name)
        if entry.type_name is None:
            entry.type_name = type_name
        elif entry.type_name != type_name:
            raise GraphConflictError(
                f"Tried to register topic {name} with type {type_name} but it is already "
                f"established with type {entry.type_name}"
            )
        return entry

    def add_publisher(self, name: str, node: str, advert_id: OpId, latch: bool) -> TopicEntry:
        entry = self.topic(name)
        entry.publishers.setdefault(node, set()).add(advert_id)
        if latch:
            entry.latching.add(node)
        return entry

    def remove_publisher(
        self, name: str, node: str, advert_id: OpId = None, every_id: bool = True
    ) -> None:
        """Drop one advertisement id (or all of the node's) and forget the topic if unused."""
        entry = self.topics.get(name)
        if entry is None or node not in entry.publishers:
            return
        ids = entry.publishers[node]
        if every_id:
            ids.clear()
        else:
            ids.discard(advert_id)
        if not ids:
            del entry.publishers[node]
            entry.latching.discard(node)
            entry.qos.pop(node, None)
            if not entry.latching:
                entry.latched = None
        self.forget_if_unused(name)

    def add_subscriber(self, name: str, node: str) -> TopicEntry:
        entry = self.topic(name)
        entry.subscribers.add(node)
        return entry

    def remove_subscriber(self, name: str, node: str) -> None:
        entry = self.topics.get(name)
        if entry is not None:
            entry.subscribers.discard(node)
            entry.subscriber_qos.pop(node, None)
            self.forget_if_unused(name)

    def forget_if_unused(self, name: str) -> None:
        entry = self.topics.get(name)
        if entry is not None and entry.is_unused():
            del self.topics[name]

    def typed_topics(self) -> list[tuple[str, str]]:
        """(name, type) of every topic whose type is known, sorted by name."""
        return sorted(
            (t.name, t.type_name) for t in self.topics.values() if t.type_name is not None
        )

    def node_topics(self, node: str) -> tuple[list[str], list[str]]:
        """(publishing, subscribing) topic names of `node`, sorted."""
        publishing = sorted(t.name for t in self.topics.values() if node in t.publishers)
        subscribing = sorted(t.name for t in self.topics.values() if node in t.subscribers)
        return publishing, subscribing
