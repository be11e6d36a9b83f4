"""The Foxglove plug-in: Foxglove WebSocket clients on the bridge's own port (the shell).

`FoxglovePlugin` registers the subprotocols with the host, so the edge's handshake gives a
client offering `foxglove.websocket.v1` (or the SDK's `foxglove.sdk.v1`) a
`FoxgloveConnection` instead of rosbridge's reader. Everything a client does goes through the
same handshake (TLS, Origin allow-list, client limit), the same core calls and the same send
queue as a rosbridge client. A watcher keeps the shared channel and service tables in step
with the graph and tells clients what changed: channels, services, connection graph,
parameters, and the player's state and time (`bridge.foxglove.playback`).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Coroutine
from typing import Any

from bridge.effects import Send
from bridge.foxglove import wire
from bridge.foxglove.assets import AssetDirectory
from bridge.foxglove.channels import ChannelTable, published_topics
from bridge.foxglove.graph_view import connection_graph, graph_changes
from bridge.foxglove.node_parameters import parameter_nodes, service_nodes, split_name
from bridge.foxglove.param_calls import NodeParameterCalls, Outcome
from bridge.foxglove.param_events import ParameterEvents
from bridge.foxglove.playback import STATE_TOPIC, PlaybackWatch
from bridge.foxglove.session import FoxgloveSession, Permit, Reply, allow_all
from bridge.host import PluginHost
from bridge.outgoing import ControlMessage
from bridge.problems import ProblemLog
from schemas.roles_config import Action
from schemas.safety import safe_text

logger = logging.getLogger("bridge.foxglove")

WATCH_S = 0.1  # how often the graph, parameters and player are compared with what clients know
SERVER_NAME = "riverbridge"
# The translator's actions (bridge.foxglove.session.Permit) as the roles' (schemas.roles_config).
ROLE_ACTIONS = {
    "subscribe": Action.SUBSCRIBE,
    "publish": Action.PUBLISH,
    "call": Action.CALL_SERVICE,
    "playback": Action.CALL_SERVICE,
    "get_param": Action.GET_PARAM,
    "set_param": Action.SET_PARAM,
}
GRAPH_OPS = frozenset({"advertise", "unadvertise", "subscribe", "unsubscribe"})


class FoxglovePlugin:
    """Foxglove clients of one bridge: the shared tables, the watcher, the connections."""

    def __init__(self, host: PluginHost, permit: Permit = allow_all) -> None:
        self.host = host
        self.permit = permit
        self.table = ChannelTable(host.registry)
        self.assets = AssetDirectory(host.config.asset_dirs)
        self.connections: dict[int, FoxgloveConnection] = {}
        self.playback = PlaybackWatch(host)
        self.graph: dict[str, Any] = connection_graph(host.graph.topics, host.graph.services)
        self._params: dict[str, str] = {}
        self.parameter_events = ParameterEvents(host, self.tell_node_parameters)

    async def start(self) -> None:
        self.reconcile()
        self.playback.start(self.broadcast)
        self.host.serve_subprotocols(wire.SUBPROTOCOLS, self._connect)
        self.host.spawn(self._watch(), "foxglove watcher")

    async def stop(self) -> None:
        self.playback.stop()
        self.parameter_events.follow(False)

    def _connect(self, client_id: int, subprotocol: str) -> FoxgloveConnection:
        self.reconcile()
        connection = FoxgloveConnection(self, client_id, subprotocol == wire.SDK_V1)
        self.connections[client_id] = connection
        return connection

    async def _watch(self) -> None:
        """Compare while Foxglove clients are connected (a new one starts with a fresh look)."""
        while True:
            await asyncio.sleep(WATCH_S)
            if self.connections:
                self.reconcile()

    def reconcile(self) -> None:
        """Tell clients what changed since the last look (channels first: a client may
        subscribe to a new channel as soon as it is advertised)."""
        published = published_topics(self.host.graph.topics.values())
        if STATE_TOPIC not in published:
            self.playback.forget()
        topics = self.table.reconcile_topics(published)
        provided = {e.name: e.type_name for e in self.host.graph.services.values() if e.type_name}
        services = self.table.reconcile_services({**self.host.answered_services(), **provided})
        if topics.removed:
            self.broadcast(wire.json_frame("unadvertise", channelIds=topics.removed))
        if topics.added:
            self.broadcast(wire.json_frame("advertise", channels=topics.added))
        if services.removed:
            self.broadcast(wire.json_frame("unadvertiseServices", serviceIds=services.removed))
        if services.added:
            self.broadcast(wire.json_frame("advertiseServices", services=services.added))
        graph = connection_graph(self.host.graph.topics, self.host.graph.services)
        update = graph_changes(self.graph, graph)
        self.graph = graph
        if update is not None:
            self.broadcast(update, lambda c: c.session.graph_subscribed)
        self._tell_parameters()

    def _tell_parameters(self) -> None:
        params = dict(self.host.parameters())
        if params == self._params:
            return
        changed = [n for n in params.keys() | self._params if params.get(n) != self._params.get(n)]
        self._params = params
        for connection in list(self.connections.values()):
            names = [n for n in changed if n in connection.session.parameter_names]
            if names:
                connection.send(connection.session.parameter_values(names, params, None))

    def follow_parameter_events(self) -> None:
        """Follow `/parameter_events` while a client subscribes to a ROS 2 node's parameter."""
        self.parameter_events.follow(
            any(
                c.session.node_param(name) is not None
                for c in self.connections.values()
                for name in c.session.parameter_names
            )
        )

    def watched(self, name: str) -> bool:
        """Whether a Foxglove client subscribed to updates of parameter `name`."""
        return any(name in c.session.parameter_names for c in self.connections.values())

    def tell_node_parameters(self, parameters: list[dict[str, Any]]) -> None:
        """ROS 2 nodes' parameters a Foxglove client set: to the clients subscribed to them."""
        for connection in list(self.connections.values()):
            wanted = connection.session.parameter_names
            chosen = [p for p in parameters if p["name"] in wanted]
            if chosen:
                connection.send(wire.json_frame("parameterValues", parameters=chosen))

    def broadcast(self, data: bytes, wanted: Any = None, drop_key: str | None = None) -> None:
        for connection in list(self.connections.values()):
            if wanted is None or wanted(connection):
                connection.send(data, drop_key)

    def server_info(self, playback_control: bool) -> bytes:
        capabilities = [
            "clientPublish",
            "parameters",
            "parametersSubscribe",
            "services",
            "connectionGraph",
            "assets",
        ]
        fields: dict[str, Any] = {
            "name": SERVER_NAME,
            "capabilities": capabilities,
            "supportedEncodings": ["cdr", "json"],
            "metadata": {"ROS_DISTRO": self.host.config.distro},
        }
        window = self.playback.window()
        if window is not None:
            capabilities += ["time", "playbackControl"] if playback_control else ["time"]
            fields["dataStartTime"], fields["dataEndTime"] = (wire.stamp(ns) for ns in window)
        return wire.json_frame("serverInfo", **fields)


class FoxgloveConnection:
    """One Foxglove client: runs its session's ops as core calls, sends its frames."""

    def __init__(self, plugin: FoxglovePlugin, client_id: int, playback_control: bool) -> None:
        self.plugin = plugin
        # Playback control (PlaybackState frames) is the SDK's foxglove.sdk.v1 only: a
        # foxglove.websocket.v1 client does not know its opcode.
        self.playback_control = playback_control
        self.host = plugin.host
        self.client_id = client_id
        self.session = FoxgloveSession(client_id, plugin.table, self.host.registry, self.permit)
        self.session.clock = plugin.playback.message_time
        self.session.node_param = lambda name: split_name(name, self.host.graph.services)
        self.node_calls = NodeParameterCalls(self.host, client_id)
        session = self.host.clients().get(client_id)
        self.node = session.node if session is not None else f"client {client_id}"
        self._problems = ProblemLog()  # bad input: logged per line up to a rate, then counted
        # Problems with its ops come back as rosbridge `status`, turned into Foxglove ones.
        self.host.send_op(client_id, {"op": "set_level", "level": "warning"})
        self.send(plugin.server_info(playback_control))
        if plugin.table.by_id:
            self.send(wire.json_frame("advertise", channels=plugin.table.channel_adverts()))
        if plugin.table.services_by_id:
            services = plugin.table.service_adverts()
            self.send(wire.json_frame("advertiseServices", services=services))

    def permit(self, action: str, name: str) -> str | None:
        """Whether this client may do `action` on `name` (None: yes, else why not). With an
        auth secret it must have presented a bridge token at the handshake (`?token=` or
        `Authorization: Bearer`; Foxglove's protocol has no `auth` op), and its role (`--roles`)
        decides as for a rosbridge client (`host.authorize`, bridge.roles)."""
        session = self.host.clients().get(self.client_id)
        if session is None or not session.authenticated:
            return "not authenticated: connect with ?token=TOKEN (riverbridge token)"
        role_action = ROLE_ACTIONS.get(action)
        if role_action is not None:
            for one in name.split(",") if action == "get_param" else [name]:
                why = self.host.authorize(self.client_id, role_action, one)
                if why is not None:
                    return why
        return self.plugin.permit(action, name)

    def send(self, data: bytes, drop_key: str | None = None) -> None:
        text = data[:1] == b"{"
        self.host.deliver(self.session.frame(data, text=text, drop_key=drop_key))

    def receive(self, data: bytes | str) -> None:
        """One frame of the client; a bug costs that frame (a status), never the connection."""
        try:
            self._receive(data)
        except Exception as exc:
            logger.exception("[%s] Foxglove frame failed", self.node)
            self.send(wire.status(wire.ERROR, f"internal error: {safe_text(str(exc), 200)}"))

    def _receive(self, data: bytes | str) -> None:
        reply = self.session.receive(data)
        for problem in reply.problems:
            self._log_problem(reply.op, problem)
        for frame in reply.frames:
            self.send(frame)
        for op in reply.ops:
            self.host.send_op(self.client_id, op)
        if reply.node_sets or self._asks_nodes(reply):
            self.host.spawn(self._guarded(self._node_parameters(reply)), "foxglove parameters")
        elif reply.parameters_after is not None:
            names, request_id = reply.parameters_after
            self.send(self.session.parameter_values(names, self.host.parameters(), request_id))
        if reply.asset is not None:
            self.host.spawn(self._fetch(reply.asset), "foxglove fetchAsset")
        if reply.op in ("subscribeParameterUpdates", "unsubscribeParameterUpdates"):
            self.plugin.follow_parameter_events()
        if any(op["op"] in GRAPH_OPS for op in reply.ops):
            self.plugin.reconcile()  # its advertisements are channels for the others at once
        if self.session.graph_subscribed and not self.session.graph_sent:
            self.session.graph_sent = True
            self.send(graph_changes({}, self.plugin.graph) or b"")

    async def _guarded(self, work: Coroutine[Any, Any, None]) -> None:
        """Run `work` for this client; a bug costs that request (a status), as in `receive`."""
        try:
            await work
        except Exception as exc:
            logger.exception("[%s] Foxglove parameters failed", self.node)
            self.send(wire.status(wire.ERROR, f"internal error: {safe_text(str(exc), 200)}"))

    def _asks_nodes(self, reply: Reply) -> bool:
        """Whether the parameters to send back include ROS 2 nodes' (all of them: none named)."""
        if reply.parameters_after is None:
            return False
        names = reply.parameters_after[0]
        if not names:
            return bool(self._parameter_nodes())
        return any(self.session.node_param(name) is not None for name in names)

    def _parameter_nodes(self) -> list[str]:
        services = self.host.graph.services
        return parameter_nodes(services, service_nodes(services))

    async def _node_parameters(self, reply: Reply) -> None:
        """Set ROS 2 nodes' parameters, then answer with the values asked for (nodes' read
        afresh); a node that fails or does not answer in time is a status, not a stall."""
        taken, problems = await self.node_calls.set(reply.node_sets)
        watched = [n for n in taken if self.plugin.watched(n)]
        if watched:
            named = [self.session.node_param(name) for name in watched]
            now = await self.node_calls.get([pair for pair in named if pair is not None])
            self.plugin.tell_node_parameters(now.parameters)
        if reply.parameters_after is not None:
            names, request_id = reply.parameters_after
            outcome = await self._read_parameters(names)
            problems += outcome.problems
            own = [n for n in names if self.session.node_param(n) is None]
            params = self.host.parameters() if own or not names else {}
            self.send(self.session.parameter_values(own, params, request_id, outcome.parameters))
        for problem in problems:
            self._log_problem("parameters", problem)
            self.send(wire.status(wire.ERROR, problem))

    async def _read_parameters(self, names: list[str]) -> Outcome:
        """The ROS 2 nodes' parameters among `names`; every node's when `names` is empty."""
        if not names:
            return await self.node_calls.get_all(self._parameter_nodes())
        named = [self.session.node_param(name) for name in names]
        return await self.node_calls.get([pair for pair in named if pair is not None])

    async def _fetch(self, request: wire.FetchAsset) -> None:
        """Read the asset on a worker thread (a terrain mesh may be megabytes)."""
        self.send(await asyncio.to_thread(self.plugin.assets.answer, request))

    def outgoing(self, send: Send) -> list[Send]:
        if isinstance(send.item, ControlMessage) and self.node_calls.answered(send.item.payload):
            return []
        return self.session.outgoing(send)

    def _log_problem(self, op: str, problem: str) -> None:
        """One line per problem naming client, op and problem; past 20 in 10 s, a summary."""
        now_ns = self.host.now_ns()
        summary = self._problems.expired_summary(now_ns, self.node, "Foxglove problems")
        if summary is not None:
            logger.warning("%s", summary)
        if self._problems.note(now_ns)[0]:
            logger.warning("[%s] Foxglove op=%s: %s", self.node, safe_text(op, 60), problem)

    def close(self) -> None:
        self.node_calls.close()
        self.plugin.connections.pop(self.client_id, None)
        self.plugin.follow_parameter_events()
        summary = self._problems.summary(self.node, self.host.now_ns(), "Foxglove problems")
        if summary is not None:
            logger.warning("%s", summary)


def plugin(host: PluginHost) -> FoxglovePlugin:
    """The plug-in `bridge.compose.plugin_table` builds."""
    return FoxglovePlugin(host)
