"""The remote half of the graph: a domain's publishers and subscribers in the bridge's graph.

Remote nodes become publishers and subscribers of the bridge's topics, by name, so rosapi
(`topics`, `publishers`, `subscribers`, `node_details`, ...) lists them and a client may
subscribe to a remote topic without naming its type. `GraphSync` remembers what it added
and takes away what the domain no longer has. Pure: it edits a `Graph` and nothing else.
"""

from __future__ import annotations

import logging

from bridge.dds.discovery import RemoteTopic
from bridge.errors import GraphConflictError
from bridge.graph import Graph

logger = logging.getLogger("bridge.dds")

# Advertisement id of a remote publisher in the graph: ids are kept per node, and a remote
# node has no websocket client choosing ids of its own.
REMOTE_ADVERTISEMENT = "dds"


class GraphSync:
    """Applies `DomainView.topics()` to a graph, again and again."""

    def __init__(self) -> None:
        self.publishers: set[tuple[str, str]] = set()  # (topic, node) added by us
        self.subscribers: set[tuple[str, str]] = set()
        self._conflicts: set[tuple[str, str]] = set()

    def apply(self, graph: Graph, topics: dict[str, RemoteTopic], local_nodes: set[str]) -> None:
        """Make the graph's remote endpoints those of `topics`; never touch `local_nodes`'."""
        wanted_pubs = {(t.name, n) for t in topics.values() for n in t.publishers}
        wanted_subs = {(t.name, n) for t in topics.values() for n in t.subscribers}
        for name, node in self.publishers - wanted_pubs:
            graph.remove_publisher(name, node)
        for name, node in self.subscribers - wanted_subs:
            graph.remove_subscriber(name, node)
        self.publishers &= wanted_pubs
        self.subscribers &= wanted_subs
        for name, node in sorted(wanted_pubs - self.publishers):
            if node not in local_nodes and self._declare(graph, topics[name]):
                graph.add_publisher(name, node, REMOTE_ADVERTISEMENT, latch=False)
                self.publishers.add((name, node))
        for name, node in sorted(wanted_subs - self.subscribers):
            if node not in local_nodes and self._declare(graph, topics[name]):
                graph.add_subscriber(name, node)
                self.subscribers.add((name, node))

    def noted_publisher(self, topic: str, node: str) -> None:
        """A message was injected for `node`: the graph has it as a publisher now."""
        self.publishers.add((topic, node))

    def _declare(self, graph: Graph, topic: RemoteTopic) -> bool:
        try:
            graph.declare_type(topic.name, topic.type_name)
        except GraphConflictError as exc:
            if (topic.name, topic.type_name) not in self._conflicts:
                self._conflicts.add((topic.name, topic.type_name))
                logger.warning("DDS: remote topic not listed: %s", exc)
            return False
        return True

    def clear(self, graph: Graph) -> None:
        self.apply(graph, {}, set())
