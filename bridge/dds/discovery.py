"""What the DDS domain holds, in ROS terms: topics, services and the nodes owning them.

Cyclone's built-in discovery topics tell which participants and endpoints came and went
(a `DiscoveryDelta` per take); ROS 2's `ros_discovery_info` tells which node of a participant
owns which endpoint. `DomainView` keeps both by GUID, updated by the delta, so a change costs
what changed, and the ROS graph it derives (topics, services, actions) is rebuilt once per
change, not on every read. An endpoint that no `ros_discovery_info` claims (a plain DDS
program) is owned by its participant's only node if it has exactly one, else by a name made
from the participant: `/dds_participant_<8 hex digits>`. Pure: no Cyclone here.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field

from bridge.dds.naming import (
    DISCOVERY_TOPIC,
    action_of_send_goal,
    parse_dds_topic,
    service_type_of_part,
    type_from_dds,
)
from bridge.dds.qos import DEFAULT, QosProfile


@dataclass(frozen=True)
class Endpoint:
    """A remote reader or writer as discovery announced it."""

    guid: bytes
    participant: bytes
    dds_topic: str
    dds_type: str
    is_writer: bool
    qos: QosProfile = DEFAULT
    user_data: str = ""


@dataclass(frozen=True)
class DiscoveryDelta:
    """What discovery reported since the last take: remote participants and endpoints that
    appeared (or changed their QoS), and the GUIDs of those that left."""

    participants: frozenset[bytes] = frozenset()
    endpoints: tuple[Endpoint, ...] = ()
    participants_gone: frozenset[bytes] = frozenset()
    endpoints_gone: frozenset[bytes] = frozenset()

    def __bool__(self) -> bool:
        return bool(
            self.participants or self.endpoints or self.participants_gone or self.endpoints_gone
        )


@dataclass(frozen=True)
class NodeEntities:
    """One ROS 2 node of a participant (`ros_discovery_info`) and the endpoints it owns."""

    name: str
    readers: frozenset[bytes] = frozenset()
    writers: frozenset[bytes] = frozenset()


@dataclass
class RemoteTopic:
    """A ROS topic seen on the domain: type, publishing nodes (with their writers' QoS),
    subscribing nodes."""

    name: str
    type_name: str
    publishers: dict[str, list[QosProfile]] = field(default_factory=dict)
    subscribers: set[str] = field(default_factory=set)


@dataclass(frozen=True)
class RemoteService:
    """A ROS service server seen on the domain (request reader + reply writer of one node).

    `request_header`: whether its samples carry rmw_cyclonedds's request header; Fast DDS's
    rmw keeps the request id in RTPS inline QoS instead, and its payload is the bare request.
    """

    name: str
    type_name: str
    node: str
    request_header: bool = True


@dataclass(frozen=True)
class RemoteAction:
    """A ROS 2 action server on the domain: the node serving `<name>/_action/send_goal`."""

    name: str
    type_name: str  # pkg/action/T
    node: str
    request_header: bool = True


# RTPS GUID prefixes start with the vendor id; eProsima Fast DDS is 01.0f (OMG's vendor list).
FAST_DDS_VENDOR = b"\x01\x0f"


def is_fast_dds(participant: bytes) -> bool:
    """A participant of eProsima Fast DDS (rmw_fastrtps_cpp, the ROS 2 default)."""
    return participant[:2] == FAST_DDS_VENDOR


def _announces(endpoint: Endpoint) -> bool:
    return endpoint.is_writer and endpoint.dds_topic == DISCOVERY_TOPIC


def participant_node(participant: bytes) -> str:
    """The node name given to endpoints of a participant that announces no nodes."""
    return f"/dds_participant_{zlib.crc32(participant[:12]):08x}"


class DomainView:
    """The domain's participants and endpoints by GUID, kept up to date by `apply`, and
    `ros_discovery_info` per participant, read as a ROS graph.

    `topics()`, `services()` and `actions()` are computed once per change and then shared:
    callers must not modify what they return (an unchanged graph returns the same object).
    """

    def __init__(self) -> None:
        self.participants: set[bytes] = set()
        self.node_info: dict[bytes, tuple[NodeEntities, ...]] = {}
        self._by_guid: dict[bytes, Endpoint] = {}
        self._announcing: set[bytes] = set()  # participants writing ros_discovery_info
        self._held: frozenset[bytes] = frozenset()  # their endpoints are not listed yet
        self._topics: dict[str, RemoteTopic] | None = None
        self._services: dict[str, RemoteService] | None = None
        self._actions: dict[str, RemoteAction] | None = None

    @property
    def endpoints(self) -> list[Endpoint]:
        return list(self._by_guid.values())

    def apply(self, delta: DiscoveryDelta) -> bool:
        """Take in what discovery reported (departures first); whether anything changed."""
        changed = False
        for guid in delta.endpoints_gone:
            gone = self._by_guid.pop(guid, None)
            changed |= gone is not None
            if gone is not None and _announces(gone):
                self._announcing.discard(gone.participant)
        for participant in delta.participants_gone:
            changed |= self._forget_participant(participant)
        for endpoint in delta.endpoints:
            changed |= self._by_guid.get(endpoint.guid) != endpoint
            self._by_guid[endpoint.guid] = endpoint
            if _announces(endpoint):
                self._announcing.add(endpoint.participant)
        fresh = delta.participants - self.participants
        self.participants |= fresh
        if changed:
            self._changed()
        return changed or bool(fresh)

    def _forget_participant(self, participant: bytes) -> bool:
        """Drop a departed participant with its nodes and any endpoint still listed."""
        self.participants.discard(participant)
        self._announcing.discard(participant)
        orphans = [g for g, e in self._by_guid.items() if e.participant == participant]
        for guid in orphans:
            del self._by_guid[guid]
        return self.node_info.pop(participant, None) is not None or bool(orphans)

    def update_nodes(self, participant: bytes, nodes: tuple[NodeEntities, ...]) -> bool:
        """A participant's `ros_discovery_info`; whether it changed anything."""
        if self.node_info.get(participant) == nodes:
            return False
        self.node_info[participant] = nodes
        self._changed()
        return True

    def unannounced(self) -> set[bytes]:
        """Participants that write `ros_discovery_info` but whose sample has not arrived."""
        return self._announcing - self.node_info.keys()

    def hold(self, participants: frozenset[bytes]) -> None:
        """Leave these participants' endpoints out of topics and services for now: their
        node names are on the way, and a service listed under a stand-in name would be
        listed again under the right one (cancelling its calls in flight)."""
        if participants != self._held:
            self._held = participants
            self._changed()

    def _changed(self) -> None:
        self._topics = self._services = self._actions = None

    def _listed(self) -> list[Endpoint]:
        held = self._held
        return [e for e in self._by_guid.values() if e.participant not in held]

    def owner(self, endpoint: Endpoint) -> str:
        """The ROS node that owns `endpoint`."""
        nodes = self.node_info.get(endpoint.participant, ())
        for node in nodes:
            if endpoint.guid in (node.writers if endpoint.is_writer else node.readers):
                return node.name
        if len(nodes) == 1:
            return nodes[0].name
        return participant_node(endpoint.participant)

    def writer_node(self, guid: bytes | None) -> str | None:
        """The node owning the remote writer `guid`, None if discovery does not know it."""
        endpoint = self._by_guid.get(guid) if guid is not None else None
        return self.owner(endpoint) if endpoint is not None else None

    def announced_nodes(self) -> set[str]:
        """The ROS 2 nodes remote participants announce in `ros_discovery_info`."""
        return {node.name for nodes in self.node_info.values() for node in nodes}

    def topics(self) -> dict[str, RemoteTopic]:
        """ROS topics on the domain by name; a name seen with two types keeps the first."""
        if self._topics is None:
            self._topics = self._find_topics()
        return self._topics

    def _find_topics(self) -> dict[str, RemoteTopic]:
        found: dict[str, RemoteTopic] = {}
        for endpoint in self._listed():
            meaning = parse_dds_topic(endpoint.dds_topic)
            type_name = type_from_dds(endpoint.dds_type)
            if meaning is None or meaning.role != "topic" or type_name is None:
                continue
            topic = found.setdefault(meaning.ros_name, RemoteTopic(meaning.ros_name, type_name))
            if topic.type_name != type_name:
                continue
            node = self.owner(endpoint)
            if endpoint.is_writer:
                topic.publishers.setdefault(node, []).append(endpoint.qos)
            else:
                topic.subscribers.add(node)
        return found

    def services(self) -> dict[str, RemoteService]:
        """Service servers: a node with a reader on `rq/<s>Request` and a writer on
        `rr/<s>Reply`."""
        if self._services is None:
            self._services = self._find_services()
        return self._services

    def _find_services(self) -> dict[str, RemoteService]:
        requests: dict[tuple[str, str], str] = {}
        fast_dds: set[tuple[str, str]] = set()
        replies: set[tuple[str, str]] = set()
        for endpoint in self._listed():
            meaning = parse_dds_topic(endpoint.dds_topic)
            part = type_from_dds(endpoint.dds_type)
            split = service_type_of_part(part) if part else None
            if meaning is None or split is None:
                continue
            key = (meaning.ros_name, self.owner(endpoint))
            if meaning.role == "request" and not endpoint.is_writer:
                requests[key] = split[0]
                if is_fast_dds(endpoint.participant):
                    fast_dds.add(key)
            elif meaning.role == "reply" and endpoint.is_writer:
                replies.add(key)
        servers: dict[str, RemoteService] = {}
        for (name, node), type_name in sorted(requests.items()):
            if (name, node) in replies and name not in servers:
                servers[name] = RemoteService(name, type_name, node, (name, node) not in fast_dds)
        return servers

    def actions(self) -> dict[str, RemoteAction]:
        """Action servers: whoever serves an action's `send_goal` service."""
        if self._actions is not None:
            return self._actions
        found: dict[str, RemoteAction] = {}
        for service in self.services().values():
            action = action_of_send_goal(service.name, service.type_name)
            if action is not None:
                name, type_name = action
                found[name] = RemoteAction(name, type_name, service.node, service.request_header)
        self._actions = found
        return found
