"""The connection graph as Foxglove's `connectionGraphUpdate` sees it, and its changes.

Pure: `connection_graph` snapshots who publishes, subscribes to and provides what (node
names as ids); `graph_changes` is the update that takes a client from one snapshot to the
next (None when nothing changed), the full graph when the first snapshot is empty.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from bridge.foxglove import wire
from bridge.graph import ServiceEntry, TopicEntry

Snapshot = dict[str, Any]


def connection_graph(
    topics: Mapping[str, TopicEntry], services: Mapping[str, ServiceEntry]
) -> Snapshot:
    """Who publishes, subscribes to and provides what (`bridge.host.GraphView`'s parts)."""
    return {
        "published": {t.name: sorted(t.publishers) for t in topics.values() if t.publishers},
        "subscribed": {t.name: sorted(t.subscribers) for t in topics.values() if t.subscribers},
        "services": {s.name: [s.provider] for s in services.values()},
    }


def graph_changes(before: Snapshot, after: Snapshot) -> bytes | None:
    def changed(key: str) -> dict[str, list[str]]:
        old = before.get(key, {})
        return {name: ids for name, ids in after[key].items() if old.get(name) != ids}

    published, subscribed, services = (
        changed("published"),
        changed("subscribed"),
        changed("services"),
    )
    topics_after = after["published"].keys() | after["subscribed"].keys()
    topics_before = before.get("published", {}).keys() | before.get("subscribed", {}).keys()
    removed_topics = sorted(topics_before - topics_after)
    removed_services = sorted(before.get("services", {}).keys() - after["services"].keys())
    if before and not (published or subscribed or services or removed_topics or removed_services):
        return None
    return wire.json_frame(
        "connectionGraphUpdate",
        publishedTopics=[{"name": n, "publisherIds": ids} for n, ids in published.items()],
        subscribedTopics=[{"name": n, "subscriberIds": ids} for n, ids in subscribed.items()],
        advertisedServices=[{"name": n, "providerIds": ids} for n, ids in services.items()],
        removedTopics=removed_topics,
        removedServices=removed_services,
    )
