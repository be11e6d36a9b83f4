"""Stage tracing for client processes: record spans cheaply, to be published in small batches.

A :class:`Tracer` is handed to :class:`clients.RosbridgeClient` (``tracer=``), which records
``encode`` and ``send`` for every publish and ``decode`` for every received message that has a
``header.stamp``; the simulator and navigation record their own stages (``generate``,
``wait``, ``process``...) into the same tracer (``tracer.spans.record`` or
:meth:`Tracer.processed`); :mod:`clients.node.telemetry` publishes
them (docs/tracing.md). Recording costs a few ``time.time_ns()`` calls and one tuple append;
it never waits.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any

from clients.events import Received
from schemas.runtime.telemetry import ResourceSampler, this_process
from schemas.tracing import (
    SPAN_CAPACITY,
    SpanBuffer,
    header_stamp_ns,
    is_traced,
    process_stats_msg,
    span_array_msg,
)

# Decode times remembered for `decoded_ns`: a second of every subscribed stamped topic.
DECODED_MEMORY = 256


class Tracer:
    """Spans and counters of one process (``process`` names it in every span and stats)."""

    def __init__(self, process: str, capacity: int = SPAN_CAPACITY) -> None:
        self.process = process
        self.spans = SpanBuffer(capacity)
        self.counters = {"messages_out": 0, "messages_in": 0, "bytes_out": 0, "bytes_in": 0}
        self._sampler = ResourceSampler()
        self._identity = this_process(process)
        self._decoded: OrderedDict[tuple[str, int], int] = OrderedDict()

    def published(
        self,
        topic: str,
        msg: dict[str, Any],
        encode_start_ns: int,
        ready_ns: int,
        sent_ns: int,
        wire_bytes: int,
    ) -> None:
        """A publish went out: ``encode`` (start → frame ready) and ``send`` (→ send returned)."""
        counters = self.counters
        counters["messages_out"] += 1
        counters["bytes_out"] += wire_bytes
        stamp_ns = header_stamp_ns(msg)
        if stamp_ns is None or not is_traced(topic):
            return
        self.spans.record(topic, stamp_ns, "encode", encode_start_ns, ready_ns, 0, wire_bytes)
        self.spans.record(topic, stamp_ns, "send", ready_ns, sent_ns, 0, wire_bytes)

    def received(self, received: Received, decoded_ns: int) -> None:
        """A message arrived: ``decode`` (frame received → decoded, handed to subscribers)."""
        counters = self.counters
        counters["messages_in"] += 1
        counters["bytes_in"] += received.wire_bytes
        stamp_ns = header_stamp_ns(received.msg)
        if stamp_ns is None or not is_traced(received.topic):
            return
        self.spans.record(
            received.topic, stamp_ns, "decode", received.recv_ns, decoded_ns, 0, received.wire_bytes
        )
        self._decoded[(received.topic, stamp_ns)] = decoded_ns
        if len(self._decoded) > DECODED_MEMORY:
            self._decoded.popitem(last=False)

    def decoded_ns(self, topic: str, stamp_ns: int, default: int) -> int:
        """When the message ``(topic, stamp_ns)`` was decoded (the start of its ``wait``),
        or ``default`` if it is no longer remembered."""
        return self._decoded.pop((topic, stamp_ns), default)

    def processed(
        self,
        topic: str,
        stamp_ns: int | None,
        start_ns: int,
        end_ns: int,
        queued_ns: int,
        steps: dict[str, tuple[int, int]] | None = None,
    ) -> None:
        """A consumer processed ``(topic, stamp_ns)``: ``wait`` (decoded → start; ``queued_ns``
        if the decode time is forgotten), ``process`` (start → end) and ``process.<step>``."""
        if stamp_ns is None:
            return
        record = self.spans.record
        record(topic, stamp_ns, "wait", self.decoded_ns(topic, stamp_ns, queued_ns), start_ns)
        record(topic, stamp_ns, "process", start_ns, end_ns)
        for step, (step_start_ns, step_end_ns) in (steps or {}).items():
            record(topic, stamp_ns, f"process.{step}", step_start_ns, step_end_ns)

    def batch_msg(self) -> dict[str, Any] | None:
        """The spans recorded since the last batch as a TraceSpanArray, or None if none."""
        spans = self.spans.drain()
        return span_array_msg(self._identity, spans) if spans else None

    def stats_msg(self, now_ns: int, dropped: int) -> dict[str, Any]:
        """This process's ProcessStats now; ``dropped`` counts messages its queues dropped."""
        return process_stats_msg(
            self._identity,
            now_ns,
            self._sampler.cpu_percent(),
            self._sampler.rss_bytes(),
            {**self.counters, "dropped": dropped},
        )
