"""The bridge's telemetry: its trace spans and ProcessStats as topics, the stats service,
``/client_count`` and ``GET /metrics`` (docs/tracing.md).

`BridgeTelemetry` attaches to a `BridgeServer`: it registers a `BridgeTracer` as a sink of the
core's graph, answers ``/riverbridge/stats`` itself (like rosapi), adds the ``/metrics`` route,
and once a second publishes its spans and stats into its own graph as an internal source
(`BridgeCore.publish_external`), so any client reads them like any other topic.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from bridge.graph import BRIDGE_NODE
from bridge.http import respond
from bridge.metrics import CONTENT_TYPE, MetricsSnapshot, render_metrics
from bridge.rosapi.common import RosapiService
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
    from bridge.effects import Effect
    from bridge.server import BridgeServer

log = logging.getLogger(__name__)

CLIENT_COUNT_TOPIC = "/client_count"  # rosbridge_server publishes it, latched, on every change
CLIENT_COUNT_TYPE = "std_msgs/msg/Int32"
PROCESS_NAME = "bridge"


class BridgeTelemetry:
    """Tracing, counters and their publication for one running `BridgeServer`."""

    def __init__(self, server: BridgeServer) -> None:
        self._server = server
        self._core = server.core
        self.tracer = BridgeTracer(self._core.state)
        self._core.add_sink(self.tracer)
        self._core.state.rosapi[STATS_SERVICE] = RosapiService(
            STATS_SERVICE_TYPE, self._answer_stats
        )
        server.http.add("/metrics", self.metrics_page)
        self._sampler = ResourceSampler()
        self._identity = this_process(PROCESS_NAME)
        self.cpu_percent = 0.0
        self._started_ns = time.time_ns()
        self._client_count: int | None = None

    # -- what is counted ---------------------------------------------------------------------

    def drops(self) -> dict[tuple[str, str], int]:
        """Messages dropped per (topic, subscriber): subscription queue plus send queue."""
        drops: dict[tuple[str, str], int] = {}
        for client_id, session in self._core.state.sessions.items():
            link = self._server.links.get(client_id)
            name = self.tracer.subscriber_name(client_id)
            for topic, subscription in session.subscriptions.items():
                count = subscription.dropped + (link.queue.dropped.get(topic, 0) if link else 0)
                if count:
                    drops[(topic, name)] = count
        return drops

    def snapshot(self) -> MetricsSnapshot:
        return MetricsSnapshot(
            dict(self.tracer.topics),
            self.drops(),
            len(self._core.state.sessions),
            self.cpu_percent,
            self._sampler.rss_bytes(),
            self.tracer.spans.discarded,
            self.restarts(),
        )

    def restarts(self) -> dict[str, int]:
        """Component restarts from the latched report of `riverbridge up`, if one runs."""
        entry = self._core.state.graph.topics.get(RESTARTS_TOPIC)
        if entry is None or entry.latched is None:
            return {}
        return restart_counts(entry.latched.msg)

    def _answer_stats(self, ctx: Context, request: dict[str, Any]) -> dict[str, Any]:
        """`/riverbridge/stats` (riverbridge_msgs/srv/BridgeStats)."""
        topics = sorted(self.tracer.topics.items())
        drops = sorted(self.drops().items())
        sessions = sorted(ctx.state.sessions.values(), key=lambda s: s.client_id)
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
        """``GET /metrics``: Prometheus text."""
        return respond(connection, 200, render_metrics(self.snapshot()), CONTENT_TYPE)

    # -- what is published -------------------------------------------------------------------

    def _listened(self, topic: str) -> bool:
        """Someone subscribes to `topic`: the bridge adds its own topics to the graph only
        then, so a bridge nobody observes shows just `/rosout` and pays nothing."""
        return bool(self._core.state.topic_subscriptions.get(topic))

    def clients_changed(self) -> list[Effect]:
        """Publish the latched `/client_count` if the number changed (or was never sent)."""
        if not self._listened(CLIENT_COUNT_TOPIC):
            self._client_count = None
            return []
        count = len(self._core.state.sessions)
        if count == self._client_count:
            return []
        self._client_count = count
        return self._core.publish_external(
            BRIDGE_NODE,
            CLIENT_COUNT_TOPIC,
            CLIENT_COUNT_TYPE,
            {"data": count},
            time.time_ns(),
            latch=True,
        )

    def publish_spans(self) -> list[Effect]:
        """The spans recorded since the last call, for whoever subscribes (drained either way)."""
        spans = self.tracer.spans.drain()
        if not spans or not self._listened(TRACE_TOPIC):
            return []
        return self._core.publish_external(
            BRIDGE_NODE,
            TRACE_TOPIC,
            TRACE_TYPE,
            span_array_msg(self._identity, spans),
            time.time_ns(),
        )

    def publish_once(self) -> list[Effect]:
        """`publish_spans`, and the bridge's ProcessStats for whoever subscribes to them."""
        now_ns = time.time_ns()
        self.cpu_percent = self._sampler.cpu_percent()
        effects = self.clients_changed() + self.publish_spans()
        if not self._listened(STATS_TOPIC):
            return effects
        traffic = self.tracer.topics.values()
        counters = {
            "messages_in": sum(t.messages_in for t in traffic),
            "messages_out": sum(t.messages_out for t in traffic),
            "bytes_in": sum(t.wire_bytes_in for t in traffic),
            "bytes_out": sum(t.wire_bytes_out for t in traffic),
            "dropped": sum(self.drops().values()),
        }
        effects += self._core.publish_external(
            BRIDGE_NODE,
            STATS_TOPIC,
            STATS_TYPE,
            process_stats_msg(
                self._identity, now_ns, self.cpu_percent, self._sampler.rss_bytes(), counters
            ),
            now_ns,
        )
        return effects

    async def run(
        self,
        apply: Callable[[list[Effect]], None],
        period_s: float = PUBLISH_PERIOD_S,
        trace_period_s: float = TRACE_PERIOD_S,
    ) -> None:
        """Publish spans every `trace_period_s` and stats every `period_s` until cancelled;
        `apply` carries out the effects."""
        apply(self.clients_changed())
        async for with_stats in telemetry_ticks(period_s, trace_period_s):
            try:
                apply(self.publish_once() if with_stats else self.publish_spans())
            except Exception:  # telemetry must never take the bridge down
                log.exception("publishing the bridge's telemetry failed")
