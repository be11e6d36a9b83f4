"""The bridge's telemetry: its trace spans and ProcessStats as topics, the stats service,
``/client_count`` and ``GET /metrics`` (docs/tracing.md).

`BridgeTelemetry` is a plug-in (`bridge.host`): through its `PluginHost` it registers a
`BridgeTracer` as a sink of the graph and as the observer of deliveries, answers
``/riverbridge/stats`` itself (like rosapi), adds the ``/metrics`` route, and once a second
publishes its spans and stats into the graph as an internal source (`publish_external`), so
any client reads them like any other topic.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from bridge.goodput import LinkHealth
from bridge.graph import BRIDGE_NODE
from bridge.host import PluginHost
from bridge.http import respond
from bridge.metrics import CONTENT_TYPE, MetricsSnapshot, render_metrics
from bridge.tracing import BridgeTracer
from schemas.runtime.telemetry import ResourceSampler, telemetry_ticks, this_process
from schemas.supervision import RESTARTS_TOPIC, restart_counts
from schemas.tracing import (
    PUBLISH_PERIOD_S,
    STATS_SERVICE,
    STATS_SERVICE_TYPE,
    STATS_TOPIC,
    STATS_TYPE,
    TRACE_PERIOD_S,
    TRACE_TOPIC,
    TRACE_TYPE,
    process_stats_msg,
    span_array_msg,
)

if TYPE_CHECKING:
    from bridge.context import Context

log = logging.getLogger(__name__)

CLIENT_COUNT_TOPIC = "/client_count"  # rosbridge_server publishes it, latched, on every change
CLIENT_COUNT_TYPE = "std_msgs/msg/Int32"
PROCESS_NAME = "bridge"


class BridgeTelemetry:
    """Tracing, counters and their publication for one running bridge."""

    def __init__(
        self,
        host: PluginHost,
        period_s: float = PUBLISH_PERIOD_S,
        trace_period_s: float = TRACE_PERIOD_S,
    ) -> None:
        self._host = host
        self._periods_s = (period_s, trace_period_s)
        self.tracer = BridgeTracer(host.clients())
        self._sampler = ResourceSampler()
        self._identity = this_process(PROCESS_NAME)
        self.cpu_percent = 0.0
        self._started_ns = host.now_ns()
        self._client_count: int | None = None

    async def start(self) -> None:
        host = self._host
        host.add_sink(self.tracer)
        host.observe_deliveries(self.tracer.delivered)
        host.answer_service(STATS_SERVICE, STATS_SERVICE_TYPE, self._answer_stats)
        host.http.add("/metrics", self.metrics_page)
        host.on_clients_changed(self.clients_changed)
        self.clients_changed()
        host.spawn(self._publish_forever(*self._periods_s), name="bridge-telemetry")

    async def stop(self) -> None:
        """Nothing to undo: the host cancels the publishing, the bridge closes after it."""

    # -- what is counted ---------------------------------------------------------------------

    def drops(self) -> dict[tuple[str, str], int]:
        """Messages dropped per (topic, subscriber): subscription queue plus send queue."""
        drops: dict[tuple[str, str], int] = {}
        for client_id, session in self._host.clients().items():
            queue_drops = self._host.send_queue_drops(client_id)
            name = self.tracer.subscriber_name(client_id)
            for topic, subscription in session.subscriptions.items():
                count = subscription.dropped + queue_drops.get(topic, 0)
                if count:
                    drops[(topic, name)] = count
        return drops

    def links(self) -> dict[str, LinkHealth]:
        """Each websocket client's link health, by subscriber name."""
        links: dict[str, LinkHealth] = {}
        for client_id in self._host.clients():
            health = self._host.link_health(client_id)
            if health is not None:
                links[self.tracer.subscriber_name(client_id)] = health
        return links

    def snapshot(self) -> MetricsSnapshot:
        return MetricsSnapshot(
            dict(self.tracer.topics),
            self.drops(),
            len(self._host.clients()),
            self.cpu_percent,
            self._sampler.rss_bytes(),
            self.tracer.spans.discarded,
            self.restarts(),
            dict(self._host.principal_counters()),
            self.links(),
        )

    def restarts(self) -> dict[str, int]:
        """Component restarts from the latched report of `riverbridge up`, if one runs."""
        entry = self._host.graph.topics.get(RESTARTS_TOPIC)
        if entry is None or entry.latched is None:
            return {}
        return restart_counts(entry.latched.msg)

    def _answer_stats(self, ctx: Context, request: dict[str, Any]) -> dict[str, Any]:
        """`/riverbridge/stats` (riverbridge_msgs/srv/BridgeStats)."""
        topics = sorted(self.tracer.topics.items())
        drops = sorted(self.drops().items())
        sessions = sorted(self._host.clients().values(), key=lambda s: s.client_id)
        return {
            "topics": [name for name, _ in topics],
            "messages_in": [t.messages_in for _, t in topics],
            "messages_out": [t.messages_out for _, t in topics],
            "payload_bytes_in": [t.payload_bytes_in for _, t in topics],
            "wire_bytes_in": [t.wire_bytes_in for _, t in topics],
            "wire_bytes_out": [t.wire_bytes_out for _, t in topics],
            "drop_subscribers": [subscriber for (_, subscriber), _ in drops],
            "drop_topics": [topic for (topic, _), _ in drops],
            "drops": [count for _, count in drops],
            "clients": len(sessions),
            "client_nodes": [s.node for s in sessions],
            "client_names": [self.tracer.names.get(s.node, "") for s in sessions],
            "cpu_percent": self.cpu_percent,
            "rss_bytes": self._sampler.rss_bytes(),
            "uptime_ns": ctx.now_ns - self._started_ns,
        }

    def metrics_page(self, connection: ServerConnection, request: Request) -> Response:
        """``GET /metrics``: Prometheus text (with the roles file's `metrics_role_only`, only
        for `Authorization: Bearer` with a token of a role that has `metrics = true`)."""
        if not self._host.may_read_metrics(request.headers.get("Authorization")):
            text = "/metrics needs a bearer token of a role with metrics = true\n"
            return respond(connection, 401, text, "text/plain; charset=utf-8")
        return respond(connection, 200, render_metrics(self.snapshot()), CONTENT_TYPE)

    # -- what is published -------------------------------------------------------------------

    # The bridge adds its own topics to the graph only while someone subscribes to them, so a
    # bridge nobody observes shows just `/rosout` and pays nothing.

    def clients_changed(self) -> None:
        """Publish the latched `/client_count` if the number changed (or was never sent)."""
        if not self._host.subscribed(CLIENT_COUNT_TOPIC):
            self._client_count = None
            return
        count = len(self._host.clients())
        if count == self._client_count:
            return
        self._client_count = count
        self._host.publish_external(
            BRIDGE_NODE, CLIENT_COUNT_TOPIC, CLIENT_COUNT_TYPE, {"data": count}, latch=True
        )

    def publish_spans(self) -> None:
        """The spans recorded since the last call, for whoever subscribes (drained either way)."""
        spans = self.tracer.spans.drain()
        if spans and self._host.subscribed(TRACE_TOPIC):
            self._host.publish_external(
                BRIDGE_NODE, TRACE_TOPIC, TRACE_TYPE, span_array_msg(self._identity, spans)
            )

    def publish_once(self) -> None:
        """`publish_spans`, and the bridge's ProcessStats for whoever subscribes to them."""
        now_ns = self._host.now_ns()
        self.cpu_percent = self._sampler.cpu_percent()
        self.clients_changed()
        self.publish_spans()
        if not self._host.subscribed(STATS_TOPIC):
            return
        traffic = self.tracer.topics.values()
        counters = {
            "messages_in": sum(t.messages_in for t in traffic),
            "messages_out": sum(t.messages_out for t in traffic),
            "bytes_in": sum(t.wire_bytes_in for t in traffic),
            "bytes_out": sum(t.wire_bytes_out for t in traffic),
            "dropped": sum(self.drops().values()),
        }
        self._host.publish_external(
            BRIDGE_NODE,
            STATS_TOPIC,
            STATS_TYPE,
            process_stats_msg(
                self._identity, now_ns, self.cpu_percent, self._sampler.rss_bytes(), counters
            ),
        )

    async def _publish_forever(self, period_s: float, trace_period_s: float) -> None:
        """Publish spans every `trace_period_s` and stats every `period_s` until cancelled."""
        async for with_stats in telemetry_ticks(period_s, trace_period_s):
            try:
                if with_stats:
                    self.publish_once()
                else:
                    self.publish_spans()
            except Exception:  # telemetry must never take the bridge down
                log.exception("publishing the bridge's telemetry failed")
