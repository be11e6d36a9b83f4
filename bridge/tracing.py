"""The bridge's stage recorder: `bridge_in` per publish, `fanout` per delivery, and counters.

`BridgeTracer` is a `MessageSink` (bridge.sinks): the core hands it every message published
in the graph, after the local fan-out has queued the deliveries, with the call's `Context`:
the frame that carried the publish (`ctx.frame`: when it was read, its size) and the time the
core handled it (`ctx.now_ns`). The edge tells it when each delivery's frames were written
(`delivered`). It never touches the protocol or the clock: it only counts and appends span
tuples (docs/tracing.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from bridge.outgoing import Delivery, TopicMessage
from schemas.codec_cdr import cdr_size
from schemas.errors import SchemaError
from schemas.tracing import (
    SPAN_CAPACITY,
    STATS_TOPIC,
    SpanBuffer,
    header_stamp_ns,
    is_traced,
)

if TYPE_CHECKING:
    from bridge.context import Context
    from bridge.session import ClientSession


@dataclass(slots=True)
class TopicTraffic:
    """Counters of one topic since the bridge started (bytes are websocket payload bytes,
    except `payload_bytes_in`, the messages' CDR size)."""

    messages_in: int = 0
    messages_out: int = 0
    payload_bytes_in: int = 0
    wire_bytes_in: int = 0
    wire_bytes_out: int = 0


class BridgeTracer:
    """Spans and per-topic traffic of the bridge; `names` maps client nodes to the process
    names they announce in their ProcessStats (so fanout spans name the subscriber)."""

    def __init__(
        self, sessions: Mapping[int, ClientSession], capacity: int = SPAN_CAPACITY
    ) -> None:
        self._sessions = sessions  # the core's, read only
        self.spans = SpanBuffer(capacity)
        self.topics: dict[str, TopicTraffic] = {}
        self.names: dict[str, str] = {}

    def traffic(self, topic: str) -> TopicTraffic:
        entry = self.topics.get(topic)
        if entry is None:
            entry = self.topics[topic] = TopicTraffic()
        return entry

    def accept(self, ctx: Context, message: TopicMessage, origin_node: str) -> None:
        """Sink: count the publish and record its `bridge_in` span (frame read → handled)."""
        traffic = self.traffic(message.topic)
        traffic.messages_in += 1
        if message.topic == STATS_TOPIC:
            self._learn_name(origin_node, message)
        frame = ctx.frame
        if frame is None:  # published from inside (telemetry, a middleware source)
            return
        traffic.wire_bytes_in += frame.wire_bytes
        stamp_ns = header_stamp_ns(message.msg)
        if stamp_ns is None or not is_traced(message.topic):
            return
        payload_bytes = message.cdr_bytes
        if payload_bytes is None:
            try:
                payload_bytes = cdr_size(message.registry, message.type_name, message.msg)
            except (SchemaError, KeyError, TypeError, ValueError, AttributeError):
                payload_bytes = 0
        traffic.payload_bytes_in += payload_bytes
        self.spans.record(
            message.topic,
            stamp_ns,
            "bridge_in",
            frame.arrived_ns,
            ctx.now_ns,
            payload_bytes,
            frame.wire_bytes,
        )

    def _learn_name(self, node: str, message: TopicMessage) -> None:
        process = message.msg.get("process")
        if isinstance(process, str) and process:
            self.names[node] = process

    def subscriber_name(self, client_id: int) -> str:
        """The process name a client announced, else its node name."""
        session = self._sessions.get(client_id)
        node = session.node if session is not None else f"/rosbridge_client_{client_id}"
        return self.names.get(node, node)

    def delivered(
        self, client_id: int, delivery: Delivery, wire_bytes: int, written_ns: int
    ) -> None:
        """A delivery's last frame was handed to the socket at `written_ns`: `fanout` runs
        from the message entering the graph to then."""
        message = delivery.message
        traffic = self.traffic(message.topic)
        traffic.messages_out += 1
        traffic.wire_bytes_out += wire_bytes
        if not is_traced(message.topic):
            return
        stamp_ns = header_stamp_ns(message.msg)
        if stamp_ns is not None:
            self.spans.record(
                message.topic,
                stamp_ns,
                "fanout",
                message.stamp_ns,
                written_ns,
                0,
                wire_bytes,
                self.subscriber_name(client_id),
            )
