"""`PluginHost`: the one interface through which a plug-in meets the bridge.

A plug-in (the DDS mirror, the telemetry, the dashboard app; next a Zenoh mirror, a second
protocol, roles) reads what the host offers and changes the graph only through core calls,
whose effects the host hands to the edge at once. It never holds the `BridgeServer` nor
writes `BridgeState` (`BridgeState` is mutated only by the core), and never imports
`bridge.server` (import-linter). `bridge.compose` builds a host per bridge and gives it to
each plug-in.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Coroutine, Iterable, Mapping
from typing import Any, Protocol

from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from bridge.effects import Effect, Send
from bridge.goodput import LinkHealth
from bridge.graph import ActionEntry, ServiceEntry, TopicEntry
from bridge.http import HttpRoutes
from bridge.link import Delivered
from bridge.roles import AuditSink, PrincipalCounters, bearer_token
from bridge.rosapi.common import RosapiHandler, RosapiService
from bridge.session import ClientSession
from bridge.sinks import MessageSink
from schemas.registry import TypeRegistry
from schemas.roles_config import Action
from schemas.runtime.event_loop import cancel_and_wait
from schemas.values import JsonObject, OpId

logger = logging.getLogger("bridge.host")

Receiver = Callable[[Send], None]  # takes what the core sends an in-process client


class ProtocolConnection(Protocol):
    """One websocket client of another protocol (Foxglove's), chosen by its subprotocol: the
    edge hands it every frame the client sends, and what the core sends the client passes
    `outgoing` (which returns the sends to write, in that protocol) before the send queue."""

    def receive(self, data: bytes | str) -> None: ...

    def outgoing(self, send: Send) -> list[Send]: ...

    def close(self) -> None: ...


# (client id, already connected; the subprotocol it chose) -> its connection
ProtocolFactory = Callable[[int, str], ProtocolConnection]


class Plugin(Protocol):
    """Started after the server listens, stopped (in reverse order) before it closes."""

    async def start(self) -> None: ...

    async def stop(self) -> None: ...


class Edge(Protocol):
    """What the host needs of the asyncio edge (`BridgeServer` is one)."""

    http: HttpRoutes
    internal_clients: dict[int, Receiver]
    delivered: Delivered
    clients_changed: list[Callable[[], None]]
    protocols: dict[str, ProtocolFactory]

    def apply(self, effects: list[Effect]) -> None: ...

    def send_queue_drops(self, client_id: int) -> Mapping[str, int]: ...

    def link_health(self, client_id: int) -> LinkHealth | None: ...


class GraphView(Protocol):
    """The graph as a plug-in reads it: never written through this view."""

    @property
    def topics(self) -> Mapping[str, TopicEntry]: ...

    @property
    def services(self) -> Mapping[str, ServiceEntry]: ...

    @property
    def actions(self) -> Mapping[str, ActionEntry]: ...


class PluginHost:
    """What a plug-in may read, and the core calls through which it changes the graph."""

    def __init__(self, core: BridgeCore, edge: Edge) -> None:
        self._core = core
        self._edge = edge
        self._tasks: set[asyncio.Task[None]] = set()
        self._graph_nodes: dict[str, frozenset[str]] = {}  # source -> nodes it speaks for

    # -- what a plug-in reads ----------------------------------------------------------------

    @property
    def config(self) -> BridgeConfig:
        return self._core.state.config

    @property
    def registry(self) -> TypeRegistry:
        return self._core.state.registry

    @property
    def graph(self) -> GraphView:
        return self._core.state.graph

    @property
    def http(self) -> HttpRoutes:
        """The plain-HTTP route table of the websocket port (``/metrics``, the dashboard)."""
        return self._edge.http

    def clients(self) -> Mapping[int, ClientSession]:
        """Every connected client by id, websocket and in-process alike."""
        return self._core.state.sessions

    def subscribed(self, topic: str) -> bool:
        """Whether any client subscribes to `topic` (publish only what someone reads)."""
        return bool(self._core.state.topic_subscriptions.get(topic))

    def send_queue_drops(self, client_id: int) -> Mapping[str, int]:
        """Messages per topic a websocket client's send queue dropped (empty if none)."""
        return self._edge.send_queue_drops(client_id)

    def parameters(self) -> Mapping[str, str]:
        """The bridge's own parameters (rosapi's), name -> JSON text; read, never written."""
        return self._core.state.params

    def answered_services(self) -> Mapping[str, str]:
        """Services the bridge answers itself (rosapi, stats): name -> type."""
        return {name: service.type_name for name, service in self._core.state.rosapi.items()}

    def link_health(self, client_id: int) -> LinkHealth | None:
        """A websocket client's goodput, round trip and conflated messages (None if it is
        gone or in-process)."""
        return self._edge.link_health(client_id)

    @staticmethod
    def now_ns() -> int:
        return time.time_ns()

    # -- what a plug-in is told --------------------------------------------------------------

    def on_clients_changed(self, callback: Callable[[], None]) -> None:
        """Call `callback` after each websocket client connects or leaves."""
        self._edge.clients_changed.append(callback)

    def observe_deliveries(self, delivered: Delivered) -> None:
        """Tell `delivered` when each delivery's frames were written (one observer)."""
        self._edge.delivered = delivered

    def serve_subprotocols(self, names: Iterable[str], factory: ProtocolFactory) -> None:
        """Websocket clients offering one of `names` speak that protocol through `factory`."""
        for name in names:
            self._edge.protocols[name] = factory

    def deliver(self, send: Send) -> None:
        """Queue a frame (an `Outgoing` item) for a client, like the core's own sends."""
        self._edge.apply([send])

    def spawn(self, work: Coroutine[Any, Any, None], name: str) -> None:
        """Run `work` (periodic publishing, a reconcile loop) until the host closes."""
        task = asyncio.get_running_loop().create_task(work, name=name)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def close(self) -> None:
        """Cancel what `spawn` started and wait for it to end."""
        await cancel_and_wait(list(self._tasks))

    # -- core calls: how a plug-in changes the graph ------------------------------------------

    def publish_external(
        self,
        node: str,
        topic: str,
        type_name: str,
        msg: JsonObject,
        cdr: bytes | None = None,
        latch: bool = False,
    ) -> None:
        """Publish a message of `node` (raises BridgeError or SchemaError if it is refused)."""
        self._apply(
            self._core.publish_external(
                node, topic, type_name, msg, time.time_ns(), cdr, latch=latch
            )
        )

    def add_sink(self, sink: MessageSink) -> None:
        self._core.add_sink(sink)

    def remove_sink(self, sink: MessageSink) -> None:
        self._core.remove_sink(sink)

    def connect_internal(self, node: str, receive: Receiver, peer: str = "") -> int:
        """An in-process client named `node`; what the core sends it goes to `receive`."""
        client_id = self._core.connect(peer, node)
        self._edge.internal_clients[client_id] = receive
        return client_id

    def send_op(self, client_id: int, op: JsonObject) -> None:
        """An op of an in-process client (advertise a service, call one, answer a call)."""
        self._apply(self._core.receive_op(client_id, op, time.time_ns()))

    def disconnect_internal(self, client_id: int) -> None:
        """The in-process client leaves: what it owned is released, its callers answered."""
        self._edge.internal_clients.pop(client_id, None)
        self._apply(self._core.disconnect(client_id, time.time_ns()))

    def answer_service(self, name: str, type_name: str, handler: RosapiHandler) -> None:
        """Answer calls to `name` inside the bridge, as rosapi's services are."""
        self._core.answer_service(name, RosapiService(type_name, handler))

    def stop_answering(self, name: str) -> None:
        self._core.stop_answering(name)

    def add_remote_publisher(self, topic: str, type_name: str, node: str, advert: OpId) -> None:
        self._core.add_remote_publisher(topic, type_name, node, advert)

    def remove_remote_publisher(self, topic: str, node: str) -> None:
        self._core.remove_remote_publisher(topic, node)

    def add_remote_subscriber(self, topic: str, type_name: str, node: str) -> None:
        self._core.add_remote_subscriber(topic, type_name, node)

    def remove_remote_subscriber(self, topic: str, node: str) -> None:
        self._core.remove_remote_subscriber(topic, node)

    def set_external_nodes(self, source: str, nodes: Iterable[str]) -> None:
        """The nodes another graph (`source`: "dds", "zenoh"...) has, for rosapi's listings."""
        self._core.set_external_nodes(source, nodes)

    # -- roles: one decision for every protocol and mirror (bridge.roles) --------------------

    def authorize(self, client_id: int, action: Action | str, name: str) -> str | None:
        """May client `client_id` do `action` (`schemas.roles_config.Action`: "subscribe",
        "publish", "call_service", ...) on `name`? The refusal text (naming action, name and
        role) or None. Another protocol asks before it acts for its client, as the core does
        before every rosbridge op; a mirror acting for a client asks with that client's id."""
        return self._core.authorize(client_id, action, name)

    def set_audit(self, sink: AuditSink) -> None:
        """Where the policy writes its audit entries (`bridge.audit`, `--audit-log`)."""
        self._core.set_audit(sink)

    def principal_counters(self) -> Mapping[str, PrincipalCounters]:
        """Messages, bytes, refusals and drops per principal (for /metrics)."""
        return self._core.state.policy.counters

    def may_read_metrics(self, authorization: str | None) -> bool:
        """Whether an HTTP request with this `Authorization` header may read /metrics."""
        return self._core.may_read_metrics(bearer_token(authorization), time.time_ns())

    # -- gateways between graphs --------------------------------------------------------------

    def claim_nodes(self, source: str, nodes: Iterable[str]) -> None:
        """The nodes graph plug-in `source` ("dds", "zenoh") speaks for: their messages and
        endpoints are its graph's, so it never sends them back there."""
        self._graph_nodes[source] = frozenset(nodes)

    def gateway_nodes(self, source: str) -> frozenset[str]:
        """Nodes other graph plug-ins speak for: `source` carries their messages, endpoints
        and services into its graph as it carries the websocket clients' (a gateway), so
        each message crosses once and never comes back."""
        others = [nodes for name, nodes in self._graph_nodes.items() if name != source]
        return frozenset().union(*others)

    def _apply(self, effects: list[Effect]) -> None:
        if effects:
            self._edge.apply(effects)


__all__ = [
    "Edge",
    "GraphView",
    "Plugin",
    "PluginHost",
    "ProtocolConnection",
    "ProtocolFactory",
    "Receiver",
]
