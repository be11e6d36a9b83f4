"""The Zenoh graph as rmw_zenoh's graph cache sees it, built from liveliness tokens. Pure.

`ZenohGraph` is told each token that appears or disappears (`put`, `delete`) and answers in
the terms the bridge's graph uses: topics with their publishing and subscribing nodes
(`bridge.dds.discovery.RemoteTopic`, so `bridge.dds.graph_sync.GraphSync` lists them), the
services other nodes provide, and the nodes. Entities of the bridge's own session are left
out.
"""

from __future__ import annotations

from dataclasses import dataclass

from bridge.dds.discovery import RemoteTopic
from bridge.zenoh.liveliness import Entity, EntityKind, parse_token


@dataclass(frozen=True)
class RemoteZenohService:
    """A service server seen on Zenoh: name, ROS service type, its node, its type hash."""

    name: str
    type_name: str
    node: str
    type_hash: str


class ZenohGraph:
    """Every live entity of one domain, by liveliness key, except those of `own_zid`."""

    def __init__(self, domain: int, own_zid: str) -> None:
        self.domain = domain
        self.own_zid = own_zid
        self.entities: dict[str, Entity] = {}

    def put(self, key: str) -> Entity | None:
        """A token appeared; returns its entity (None if it is ours or another domain's).
        Raises TokenProblem for a malformed token."""
        entity = parse_token(key)
        if entity.domain != self.domain or entity.zid == self.own_zid:
            return None
        self.entities[key] = entity
        return entity

    def delete(self, key: str) -> bool:
        return self.entities.pop(key, None) is not None

    def drop_session(self, zid: str) -> None:
        """Forget every entity of session `zid` (it left without withdrawing its tokens)."""
        self.entities = {k: e for k, e in self.entities.items() if e.zid != zid}

    def nodes(self) -> set[str]:
        return {e.node for e in self.entities.values()}

    def topics(self) -> dict[str, RemoteTopic]:
        """Remote publishers and subscribers by topic; a topic takes its first type seen."""
        topics: dict[str, RemoteTopic] = {}
        for entity in sorted(self.entities.values(), key=lambda e: (e.zid, e.entity_id)):
            endpoint = entity.endpoint
            if endpoint is None or entity.kind not in (
                EntityKind.PUBLISHER,
                EntityKind.SUBSCRIPTION,
            ):
                continue
            topic = topics.setdefault(endpoint.name, RemoteTopic(endpoint.name, endpoint.type_name))
            if topic.type_name != endpoint.type_name:
                continue
            if entity.kind is EntityKind.PUBLISHER:
                topic.publishers.setdefault(entity.node, []).append(endpoint.qos)
            else:
                topic.subscribers.add(entity.node)
        return topics

    def services(self) -> dict[str, RemoteZenohService]:
        found: dict[str, RemoteZenohService] = {}
        for entity in sorted(self.entities.values(), key=lambda e: (e.zid, e.entity_id)):
            if entity.kind is EntityKind.SERVICE and entity.endpoint is not None:
                endpoint = entity.endpoint
                found.setdefault(
                    endpoint.name,
                    RemoteZenohService(
                        endpoint.name, endpoint.type_name, entity.node, endpoint.type_hash
                    ),
                )
        return found
