"""`DdsMirror`: the bridge as one ROS 2 node of a DDS domain (`--dds`, docs/ros2.md).

The mirror is a plug-in (`bridge.host`): it lives on the event loop and changes the graph
only through its `PluginHost`'s core calls: `publish_external` for samples from the domain,
in-process clients for services, remote endpoints for remote publishers and subscribers.
Cyclone's side runs on two threads of its own: the pump (takes and decodes samples, reads
discovery) and the writer (encodes and writes); both reach the loop only through
`call_soon_threadsafe`.

What goes where:
- a message a websocket client publishes goes to DDS once, on the topic's one writer;
- a sample from DDS is published into the bridge as its remote node's; the mirror's sink
  ignores what it injected itself and whatever the bridge publishes on its own account, and
  its readers ignore the participant's own writers, so nothing echoes and a message crosses
  each bridge once however many bridges share a domain;
- every `graph_mirror.RECONCILE_S` (and soon after a discovery change or a first message)
  the endpoints are brought in step with the graph: topics clients publish get writers,
  topics clients subscribe to get readers, client-provided services get DDS servers, remote
  services get stand-ins, remote endpoints appear in the graph.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

from bridge import graph_mirror
from bridge.dds.action_mirror import ActionMirror
from bridge.dds.announce import Announcer
from bridge.dds.cyclone_xml import CycloneSettings
from bridge.dds.discovery import (
    DiscoveryDelta,
    DomainView,
    NodeEntities,
    RemoteTopic,
    participant_node,
)
from bridge.dds.graph_sync import GraphSync
from bridge.dds.outbox import Outbox, WriterThread
from bridge.dds.param_node import ParamNode
from bridge.dds.participant import DdsParticipant, DdsPlumbing, Pump
from bridge.dds.qos import QosError, QosProfile, advertised_profile, reader_profile
from bridge.dds.service_mirror import ServiceMirror
from bridge.dds.topic_mirror import TopicMirror
from bridge.errors import DdsStartError
from bridge.host import PluginHost

if TYPE_CHECKING:
    from bridge.context import Context
    from bridge.graph import TopicEntry
    from bridge.outgoing import TopicMessage

logger = logging.getLogger("bridge.dds")

EXTERNAL_SOURCE = "dds"  # the name of the domain's nodes in rosapi's view of other graphs
# A participant announces its endpoints one by one: discovery changes within this window
# cost one reconcile.
DISCOVERY_COALESCE_S = 0.03
# A participant that writes ros_discovery_info but whose sample has not come: the topic is
# read again with a new reader after NODE_INFO_RETRY_S (doubling up to the cap), and its
# endpoints are held back from the graph for NODE_INFO_HOLD_S (then named after it).
NODE_INFO_RETRY_S, NODE_INFO_RETRY_MAX_S, NODE_INFO_HOLD_S = 0.25, 30.0, 3.0


class DdsMirror:
    """Joins the host's graph to DDS domain `config.dds_domain`; `start()`, then `stop()`."""

    def __init__(self, host: PluginHost) -> None:
        self.host = host
        self.config = host.config
        self.registry = host.registry
        self.view = DomainView()
        self.graph_sync = GraphSync()
        self._injection = graph_mirror.Injection(host)
        self._waiting_first: dict[str, TopicMessage] = {}
        self._qos_warned: set[tuple[str, str]] = set()
        self._reconciler = graph_mirror.Reconciler(self.reconcile, logger, "DDS")
        self._wake_pending: asyncio.TimerHandle | None = None
        self._silent_since: dict[bytes, float] = {}  # participant: loop time
        self._renewal: tuple[float, float] | None = None  # (when, wait)

    async def start(self) -> None:
        loop = self._loop = asyncio.get_running_loop()
        settings = CycloneSettings(
            self.config.dds_interface, self.config.dds_peers, self.config.dds_multicast
        )
        try:
            self.participant = DdsParticipant(
                self.config.dds_domain, settings, self.config.dds_tuned
            )
        except Exception as exc:  # Cyclone says little more than "non-specific error"
            raise DdsStartError(
                f"cannot join DDS domain {self.config.dds_domain} on interface "
                f"{settings.interface!r} (does it exist and have an address?): {exc}"
            ) from exc
        try:
            self._assemble(loop)
        except Exception as exc:  # e.g. a type Cyclone refuses: leave the domain again
            self.participant.close()
            raise DdsStartError(f"cannot set up the DDS mirror: {exc!r}") from exc
        self.host.add_sink(self)
        self.writer.start()
        self.pump.start()
        self._reconciler.start("bridge-dds")
        logger.info(
            "DDS: domain %d on interface %s (peers %s, multicast %s) as node %s",
            self.config.dds_domain,
            settings.interface,
            ", ".join(settings.effective_peers()) or "none",
            settings.multicast,
            self.node,
        )

    def _assemble(self, loop: asyncio.AbstractEventLoop) -> None:
        """The mirror's parts on the joined participant (no thread started yet)."""
        node = self.config.dds_node or f"riverbridge_{self.participant.short_id()}"
        self.node = node if node.startswith("/") else "/" + node
        self.outbox = Outbox()
        self.writer = WriterThread(self.outbox)
        self.pump = Pump(self.participant)
        to_loop = loop.call_soon_threadsafe
        dds = DdsPlumbing(
            self.participant, self.pump, self.outbox, self.registry, self.config.distro
        )
        self.topics = TopicMirror(dds, lambda arrivals: to_loop(self._inject, arrivals))
        self.services = ServiceMirror(self.host, dds, self.node, to_loop)
        self.actions = ActionMirror(self.host, self.node, self.services.client_ids, dds, to_loop)
        self.params = (
            ParamNode(self.host, dds, self.node, self.services.client_ids, to_loop)
            if self.config.dds_parameters
            else None
        )
        self.announcer = Announcer(dds, self.node, lambda p, n: to_loop(self._nodes_seen, p, n))
        for condition in self.participant.discovery_conditions:
            self.pump.watch(condition, self._take_discovery)

    async def stop(self) -> None:
        if self._wake_pending is not None:
            self._wake_pending.cancel()
        await self._reconciler.stop()
        self.host.remove_sink(self)
        self.pump.stop()
        self.writer.stop()
        self.actions.close()
        if self.params is not None:
            self.params.close()
        self.services.close()
        self.topics.close()
        self.announcer.close()
        self.graph_sync.clear(self.host)
        self.host.set_external_nodes(EXTERNAL_SOURCE, ())
        self.participant.close()

    # -- the sink: local messages out --------------------------------------------------------

    def accept(self, ctx: Context, message: TopicMessage, origin_node: str) -> None:
        """Every message published in the graph: send those of websocket clients to DDS."""
        if self._injection.active or origin_node not in self.local_nodes():
            return
        if not self.topics.send(message) and not self.topics.refused(message.topic):
            self._waiting_first[message.topic] = message  # its writer is made next
            self._reconciler.wake()

    def local_nodes(self) -> set[str]:
        """Nodes of the websocket clients (not the mirror's own in-process clients) and, as a
        gateway, those other graphs' plug-ins speak for (`PluginHost.gateway_nodes`)."""
        return graph_mirror.mirrored_nodes(self.host, self.services.client_ids, EXTERNAL_SOURCE)

    # -- the domain's messages in ------------------------------------------------------------

    def _inject(self, arrivals: list[graph_mirror.Arrival]) -> None:
        local = self.local_nodes()
        for arrival in arrivals:
            reader = self.topics.readers.get(arrival.topic)
            node = self.view.writer_node(arrival.sender_gid)
            if node is None or node in local:
                node = participant_node(arrival.sender_gid or b"")
            latch = reader is not None and reader.wanted.profile.transient_local
            problem = self._injection.publish(node, arrival, latch)
            if problem is not None:
                logger.warning("DDS: sample on %s not published: %s", arrival.topic, problem)
                continue
            self.graph_sync.noted_publisher(arrival.topic, node)

    # -- discovery ---------------------------------------------------------------------------

    def _take_discovery(self) -> Callable[[], None] | None:
        delta = self.participant.discovery_changes()
        if not delta:
            return None

        def seen() -> None:
            self._loop.call_soon_threadsafe(self._discovered, delta)

        return seen

    def _discovered(self, delta: DiscoveryDelta) -> None:
        if self.view.apply(delta):
            self._wake_soon()

    def _nodes_seen(self, participant: bytes, nodes: tuple[NodeEntities, ...]) -> None:
        if self.view.update_nodes(participant, nodes):
            self._wake_soon()

    def _wake_soon(self) -> None:
        """One reconcile for the discovery changes of the next `DISCOVERY_COALESCE_S`."""
        if self._wake_pending is None:
            self._wake_pending = self._loop.call_later(DISCOVERY_COALESCE_S, self._wake_now)

    def _wake_now(self) -> None:
        self._wake_pending = None
        self._reconciler.wake()

    # -- keeping DDS in step with the graph --------------------------------------------------

    def reconcile(self) -> None:
        """Bring writers, readers, services and the graph's remote half in step."""
        self._ask_again_for_nodes()
        graph = self.host.graph
        local = self.local_nodes()
        remote_topics = self.view.topics()
        writers, readers = graph_mirror.wanted_topics(
            graph.topics.values(),
            local,
            remote_topics,
            self._advertised,
            self._reading,
            readers_for=local | {self.actions.node},
        )
        self.topics.sync(writers, readers)
        for message in self._waiting_first.values():
            self.topics.send(message)
        self._waiting_first.clear()
        self.graph_sync.apply(self.host, remote_topics, local)
        self.host.set_external_nodes(EXTERNAL_SOURCE, self.view.announced_nodes())
        self.host.claim_nodes(EXTERNAL_SOURCE, self._domain_nodes(remote_topics, local))
        self.services.sync(graph_mirror.provided_by(graph.services, local), self.view.services())
        local_actions = graph_mirror.provided_by(graph.actions, local)
        self.actions.sync(self.view.actions(), set(self.services.clients), set(local_actions))
        self.actions.sync_local(local_actions)
        topic_readers, topic_writers = self.topics.endpoint_guids()
        service_readers, service_writers = self.services.guids()
        action_readers, action_writers = self.actions.guids()
        param_readers, param_writers = self.params.guids() if self.params else ([], [])
        self.announcer.announce(
            topic_readers + service_readers + action_readers + param_readers,
            topic_writers + service_writers + action_writers + param_writers,
        )

    def _ask_again_for_nodes(self) -> None:
        """Hold back, and read `ros_discovery_info` again for, participants that write it
        but whose sample has not come (`Announcer.renew_reader`)."""
        silent, now = self.view.unannounced(), self._loop.time()
        for participant in set(self._silent_since) - silent:
            del self._silent_since[participant]
        fresh = silent - self._silent_since.keys()
        for participant in fresh:
            self._silent_since[participant] = now
        self.view.hold(
            frozenset(p for p, t in self._silent_since.items() if now - t < NODE_INFO_HOLD_S)
        )
        if not silent:
            self._renewal = None
        elif fresh or self._renewal is None:
            self._renewal = (now + NODE_INFO_RETRY_S, NODE_INFO_RETRY_S)
        elif now >= self._renewal[0]:
            wait = min(2 * self._renewal[1], NODE_INFO_RETRY_MAX_S)
            self._renewal = (now + wait, wait)
            if not self.announcer.hears_from(silent):
                return
            logger.info(
                "DDS: no ros_discovery_info from %s yet; reading it again",
                ", ".join(sorted(participant_node(p) for p in silent)),
            )
            self.announcer.renew_reader()

    def _domain_nodes(self, remote_topics: dict[str, RemoteTopic], local: set[str]) -> set[str]:
        """The nodes this mirror speaks for: the domain's (what it injected, what it lists)."""
        listed = {n for t in remote_topics.values() for n in (*t.publishers, *t.subscribers)}
        injected = {node for _, node in self.graph_sync.publishers}
        serving = {s.node for s in self.view.services().values()}
        return (listed | injected | serving | set(self.view.announced_nodes())) - local

    def _reading(self, entry: TopicEntry, offered: list[QosProfile]) -> QosProfile:
        """The reader profile: adapted to the writers, or as the subscribers' `qos` asks."""
        try:
            return reader_profile(offered, entry.subscriber_qos.values())
        except QosError as exc:
            if (entry.name, "subscribe") not in self._qos_warned:
                self._qos_warned.add((entry.name, "subscribe"))
                logger.warning(
                    "[%s] op=subscribe topic=%s: %s; the DDS reader adapts to the writers",
                    ", ".join(sorted(entry.subscriber_qos)),
                    entry.name,
                    exc,
                )
            return reader_profile(offered)

    def _advertised(self, entry: TopicEntry, node: str) -> QosProfile:
        profile, problem = advertised_profile(node in entry.latching, entry.qos.get(node))
        if problem and (entry.name, node) not in self._qos_warned:
            self._qos_warned.add((entry.name, node))
            logger.warning(
                "[%s] op=advertise topic=%s: %s; the DDS writer takes ROS 2's default QoS",
                node,
                entry.name,
                problem,
            )
        return profile
