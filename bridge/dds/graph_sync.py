"""The remote half of the graph: a domain's publishers and subscribers in the bridge's graph.

Remote nodes become publishers and subscribers of the bridge's topics, by name, so rosapi
(`topics`, `publishers`, `subscribers`, `node_details`, ...) lists them and a client may
subscribe to a remote topic without naming its type. `GraphSync` remembers what it added
and takes away what the domain no longer has. Pure: it changes the graph only through the
core calls of `RemoteGraph` (a `PluginHost`, or the `BridgeCore` itself in tests).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from functools import partial
from typing import Protocol

from bridge.dds.discovery import RemoteTopic
from bridge.errors import GraphConflictError
from schemas.values import OpId

logger = logging.getLogger("bridge.dds")

# Advertisement id of a remote publisher in the graph: ids are kept per node, and a remote
# node has no websocket client choosing ids of its own.
REMOTE_ADVERTISEMENT = "dds"


class RemoteGraph(Protocol):
    """The core calls that list another graph's endpoints in the bridge's graph."""

    def add_remote_publisher(self, topic: str, type_name: str, node: str, advert: OpId) -> None:
        """Raises GraphConflictError if the topic has another type."""

    def remove_remote_publisher(self, topic: str, node: str) -> None: ...

    def add_remote_subscriber(self, topic: str, type_name: str, node: str) -> None:
        """Raises GraphConflictError if the topic has another type."""

    def remove_remote_subscriber(self, topic: str, node: str) -> None: ...


class GraphSync:
    """Applies `DomainView.topics()` to a graph, again and again."""

    def __init__(self) -> None:
        self.publishers: set[tuple[str, str]] = set()  # (topic, node) added by us
        self.subscribers: set[tuple[str, str]] = set()
        self._conflicts: set[tuple[str, str]] = set()
        # What the graph was last made of: `DomainView.topics()` returns the same object
        # until discovery changes, so an unchanged domain costs one comparison per reconcile.
        self._applied: tuple[dict[str, RemoteTopic], frozenset[str]] | None = None

    def apply(
        self, graph: RemoteGraph, topics: dict[str, RemoteTopic], local_nodes: set[str]
    ) -> None:
        """Make the graph's remote endpoints those of `topics`; never touch `local_nodes`'."""
        local = frozenset(local_nodes)
        if self._applied is not None and self._applied[0] is topics and self._applied[1] == local:
            return
        self._applied = (topics, local)
        wanted_pubs = {(t.name, n) for t in topics.values() for n in t.publishers}
        wanted_subs = {(t.name, n) for t in topics.values() for n in t.subscribers}
        for name, node in self.publishers - wanted_pubs:
            graph.remove_remote_publisher(name, node)
        for name, node in self.subscribers - wanted_subs:
            graph.remove_remote_subscriber(name, node)
        self.publishers &= wanted_pubs
        self.subscribers &= wanted_subs
        for name, node in sorted(wanted_pubs - self.publishers):
            topic = topics[name]
            add = partial(
                graph.add_remote_publisher, name, topic.type_name, node, REMOTE_ADVERTISEMENT
            )
            if node not in local_nodes and self._listed(topic, add):
                self.publishers.add((name, node))
        for name, node in sorted(wanted_subs - self.subscribers):
            topic = topics[name]
            add = partial(graph.add_remote_subscriber, name, topic.type_name, node)
            if node not in local_nodes and self._listed(topic, add):
                self.subscribers.add((name, node))

    def noted_publisher(self, topic: str, node: str) -> None:
        """A message was injected for `node`: the graph has it as a publisher now."""
        if (topic, node) not in self.publishers:
            self.publishers.add((topic, node))
            self._applied = None  # the next apply decides whether it stays listed

    def _listed(self, topic: RemoteTopic, add: Callable[[], None]) -> bool:
        """`add()` the endpoint; a topic whose type clashes is warned about once."""
        try:
            add()
        except GraphConflictError as exc:
            if (topic.name, topic.type_name) not in self._conflicts:
                self._conflicts.add((topic.name, topic.type_name))
                logger.warning("DDS: remote topic not listed: %s", exc)
            return False
        return True

    def clear(self, graph: RemoteGraph) -> None:
        self.apply(graph, {}, set())
