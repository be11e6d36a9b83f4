"""`ZenohMirror`: the bridge as one rmw_zenoh node of a Zenoh graph (`--zenoh`, docs/zenoh.md).

A plug-in (`bridge.host`) like the DDS mirror: it lives on the event loop and changes the
graph only through its `PluginHost`. Zenoh calls back on threads of its own; samples are
checked and decoded there and reach the loop through `call_soon_threadsafe`.

What goes where:
- a message a websocket client publishes (or, as a gateway, one another graph plug-in
  injected: `PluginHost.gateway_nodes`) goes to Zenoh once, on the topic's one publisher;
- a sample from Zenoh is published into the bridge as its remote node's; the sink ignores what
  the mirror injected itself and what the bridge publishes on its own account, and the
  subscribers take only other sessions' samples, so nothing echoes;
- every `graph_mirror.RECONCILE_S` (and soon after a liveliness change or a first message)
  publishers, subscribers, services and the graph's remote half are brought in step.
"""

from __future__ import annotations

import asyncio
import logging
from typing import TYPE_CHECKING

import zenoh

from bridge import graph_mirror
from bridge.dds.discovery import RemoteTopic
from bridge.dds.graph_sync import GraphSync
from bridge.dds.qos import QosProfile, advertised_profile, reader_profile
from bridge.errors import ZenohStartError
from bridge.host import PluginHost
from bridge.zenoh.graph import ZenohGraph
from bridge.zenoh.liveliness import ADMIN_SPACE, TokenProblem
from bridge.zenoh.node import ZenohNode
from bridge.zenoh.problems import ProblemLog
from bridge.zenoh.services import ZenohServices
from bridge.zenoh.session import ZenohSettings, open_session
from bridge.zenoh.topics import ZenohTopics

if TYPE_CHECKING:
    from bridge.context import Context
    from bridge.graph import TopicEntry
    from bridge.outgoing import TopicMessage

logger = logging.getLogger("bridge.zenoh")

SOURCE = "zenoh"  # this graph's name in rosapi's view of other graphs and for gateways


class ZenohMirror:
    """Joins the host's graph to the Zenoh graph of domain `config.dds_domain`."""

    def __init__(self, host: PluginHost) -> None:
        self.host = host
        self.config = host.config
        self.problems = ProblemLog(logger)
        self.graph_sync = GraphSync()
        self._injection = graph_mirror.Injection(host)
        self._injected_nodes: set[str] = set()
        self._waiting_first: dict[str, TopicMessage] = {}
        self._remote_topics: dict[str, RemoteTopic] = {}  # as of the last reconcile
        self._reconciler = graph_mirror.Reconciler(self.reconcile, logger, "Zenoh")

    async def start(self) -> None:
        loop = self._loop = asyncio.get_running_loop()
        config = self.config
        settings = ZenohSettings(config.zenoh_listen, config.zenoh_connect, config.zenoh_config)
        try:
            session = await asyncio.to_thread(open_session, settings)
        except ValueError as exc:
            raise ZenohStartError(str(exc)) from exc
        self.session = session
        distro = config.zenoh_keys_distro()
        self.node = ZenohNode(session, config.dds_domain, distro, config.dds_node)
        self.graph = ZenohGraph(config.dds_domain, self.node.zid)
        to_loop = loop.call_soon_threadsafe
        self.topics = ZenohTopics(
            self.node, self.host.registry, lambda a: to_loop(self._inject, a), self.problems
        )
        self.services = ZenohServices(self.host, self.node, to_loop, self.problems)
        self._liveliness = session.liveliness().declare_subscriber(
            f"{ADMIN_SPACE}/{config.dds_domain}/**",
            lambda sample: to_loop(self._token, sample.kind, str(sample.key_expr)),
            history=True,
        )
        self.host.add_sink(self)
        self._reconciler.start("bridge-zenoh")
        logger.info(
            "Zenoh: domain %d as node %s (session %s, distro %s), listening on %s, connecting "
            "to %s",
            config.dds_domain,
            self.node.fqn,
            self.node.zid,
            config.zenoh_keys_distro(),
            ", ".join(settings.listen) or "the default",
            ", ".join(settings.connect) or "the default",
        )

    async def stop(self) -> None:
        await self._reconciler.stop()
        self.host.remove_sink(self)
        self._liveliness.undeclare()
        self.services.close()
        self.topics.close()
        self.graph_sync.clear(self.host)
        self.host.set_external_nodes(SOURCE, ())
        self.host.claim_nodes(SOURCE, ())
        self.node.close()
        await asyncio.to_thread(self.session.close)

    # -- the sink: local messages out --------------------------------------------------------

    def accept(self, ctx: Context, message: TopicMessage, origin_node: str) -> None:
        """Every message published in the graph: send clients' (and other graphs') out."""
        if self._injection.active or origin_node not in self.local_nodes():
            return
        if not self.topics.send(message):
            self._waiting_first[message.topic] = message  # its publisher is made next
            self._reconciler.wake()

    def local_nodes(self) -> set[str]:
        """Nodes whose endpoints and messages go to Zenoh: the websocket clients' and those
        other graphs' plug-ins speak for (not the mirror's own in-process clients)."""
        return graph_mirror.mirrored_nodes(self.host, self.services.client_ids, SOURCE)

    # -- Zenoh's messages and tokens in ------------------------------------------------------

    def _inject(self, arrival: graph_mirror.Arrival) -> None:
        node = self._publisher_node(arrival)
        subscriber = self.topics.subscribers.get(arrival.topic)
        latch = subscriber is not None and subscriber.wanted.profile.transient_local
        problem = self._injection.publish(node, arrival, latch)
        if problem is not None:
            self.problems.dropped(arrival.topic, "sample not published", problem)
            return
        self.graph_sync.noted_publisher(arrival.topic, node)
        if node not in self._injected_nodes:
            self._injected_nodes.add(node)
            self._reconciler.wake()

    def _publisher_node(self, arrival: graph_mirror.Arrival) -> str:
        """The remote node that published `arrival`: the topic's one remote publisher, else a
        name made from the sample's source GID."""
        topic = self._remote_topics.get(arrival.topic)
        nodes = list(topic.publishers) if topic is not None else []
        if len(nodes) == 1 and nodes[0] not in self.local_nodes():
            return nodes[0]
        return f"/zenoh_participant_{(arrival.sender_gid or b'')[:4].hex()}"

    def _token(self, kind: zenoh.SampleKind, key: str) -> None:
        try:
            if kind == zenoh.SampleKind.DELETE:
                self.graph.delete(key)
            else:
                self.graph.put(key)
        except TokenProblem as exc:
            self.problems.dropped("liveliness", "malformed token", str(exc))
            return
        self._reconciler.wake()

    # -- keeping Zenoh in step with the graph ------------------------------------------------

    def reconcile(self) -> None:
        """Bring publishers, subscribers, services and the graph's remote half in step."""
        local = self.local_nodes()
        remote_topics = self._remote_topics = self.graph.topics()
        publishers, subscribers = graph_mirror.wanted_topics(
            self.host.graph.topics.values(), local, remote_topics, _advertised, _reading
        )
        self.topics.sync(publishers, subscribers)
        for message in self._waiting_first.values():
            self.topics.send(message)
        self._waiting_first.clear()
        self.graph_sync.apply(self.host, remote_topics, local)
        remote_nodes = self.graph.nodes()
        self.host.set_external_nodes(SOURCE, remote_nodes)
        self.host.claim_nodes(SOURCE, (remote_nodes | self._injected_nodes) - local)
        self.services.sync(
            graph_mirror.provided_by(self.host.graph.services, local), self.graph.services()
        )


def _advertised(entry: TopicEntry, node: str) -> QosProfile:
    """The publisher's profile: as the node advertised it (ROS 2's default if it cannot be)."""
    return advertised_profile(node in entry.latching, entry.qos.get(node))[0]


def _reading(entry: TopicEntry, offered: list[QosProfile]) -> QosProfile:
    """The subscriber's profile: adapted to the remote publishers'."""
    return reader_profile(offered)
