"""Stage-tracing data shared by the bridge and the clients (docs/tracing.md).

The bridge may not import `clients`, and both record spans the same way, so the span
recorder, the telemetry topics and the message builders live here. Recording is one tuple
append per stage. Nothing here does I/O or reads a clock: what a process measures of itself
(CPU, memory, host) comes from `schemas.runtime.telemetry`.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

from schemas.catalogue import TOPICS, period_s

TRACE_TOPIC, TRACE_TYPE = TOPICS["trace"].pair
STATS_TOPIC, STATS_TYPE = TOPICS["process_stats"].pair
STATS_SERVICE = "/riverbridge/stats"
STATS_SERVICE_TYPE = "riverbridge_msgs/srv/BridgeStats"
TELEMETRY_PREFIX = "/riverbridge/"  # messages on these topics are never traced themselves
# ProcessStats about once a second, span batches four times a second (why: schemas.catalogue)
PUBLISH_PERIOD_S = period_s("process_stats")
TRACE_PERIOD_S = period_s("trace")

# Spans kept while nobody drains them: ~20 s of the whole stack's traffic (~500 spans/s);
# past it the oldest are discarded and counted, so memory stays bounded.
SPAN_CAPACITY = 10_000
NS_PER_S = 1_000_000_000

# (topic, stamp_ns, stage, peer, start_ns, end_ns, payload_bytes, wire_bytes)
Span = tuple[str, int, str, str, int, int, int, int]
SPAN_FIELDS = (
    "topic",
    "stamp_ns",
    "stage",
    "peer",
    "start_ns",
    "end_ns",
    "payload_bytes",
    "wire_bytes",
)


def is_traced(topic: str) -> bool:
    """Telemetry topics are not traced, or tracing would trace its own batches."""
    return not topic.startswith(TELEMETRY_PREFIX)


def header_stamp_ns(msg: Any) -> int | None:
    """`header.stamp` of a canonical message in ns, or None when it has no header stamp."""
    # Called for every delivery: a message without a header (std_msgs/String) is told apart
    # without raising, which cost more than the rest of the tracing of a small message.
    if isinstance(msg, dict) and "header" not in msg:
        return None
    try:
        stamp = msg["header"]["stamp"]
        return int(stamp["sec"]) * NS_PER_S + int(stamp["nanosec"])
    except (KeyError, TypeError, ValueError):
        return None


class SpanBuffer:
    """Spans recorded by one process, waiting for the next batch.

    Bounded: when nobody drains it, the oldest spans go and `discarded` counts them.
    """

    def __init__(self, capacity: int = SPAN_CAPACITY) -> None:
        self._spans: deque[Span] = deque(maxlen=capacity)
        self.discarded = 0

    def __len__(self) -> int:
        return len(self._spans)

    def record(
        self,
        topic: str,
        stamp_ns: int,
        stage: str,
        start_ns: int,
        end_ns: int,
        payload_bytes: int = 0,
        wire_bytes: int = 0,
        peer: str = "",
    ) -> None:
        spans = self._spans
        if len(spans) == spans.maxlen:
            self.discarded += 1
        spans.append((topic, stamp_ns, stage, peer, start_ns, end_ns, payload_bytes, wire_bytes))

    def drain(self) -> list[Span]:
        """Every span recorded since the last drain, oldest first."""
        spans = list(self._spans)
        self._spans.clear()
        return spans


@dataclass(frozen=True, slots=True)
class ProcessIdentity:
    """Who records: the process name the report shows, its pid and host."""

    process: str
    pid: int
    host: str


def span_array_msg(who: ProcessIdentity, spans: list[Span]) -> dict[str, Any]:
    """`riverbridge_msgs/msg/TraceSpanArray` (canonical form) of `spans` recorded by `who`."""
    process = who.process
    return {
        "host": who.host,
        "spans": [
            {
                "topic": topic,
                "stamp_ns": stamp_ns,
                "stage": stage,
                "process": process,
                "peer": peer,
                "start_ns": start_ns,
                "end_ns": end_ns,
                "payload_bytes": payload_bytes,
                "wire_bytes": wire_bytes,
            }
            for topic, stamp_ns, stage, peer, start_ns, end_ns, payload_bytes, wire_bytes in spans
        ],
    }


def process_stats_msg(
    who: ProcessIdentity, now_ns: int, cpu_percent: float, rss_bytes: int, counters: dict[str, int]
) -> dict[str, Any]:
    """`riverbridge_msgs/msg/ProcessStats` (canonical form); `counters` names its uint64s."""
    sec, nanosec = divmod(now_ns, NS_PER_S)
    return {
        "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
        "process": who.process,
        "pid": who.pid,
        "host": who.host,
        "cpu_percent": float(cpu_percent),
        "rss_bytes": int(rss_bytes),
        "messages_out": counters.get("messages_out", 0),
        "messages_in": counters.get("messages_in", 0),
        "bytes_out": counters.get("bytes_out", 0),
        "bytes_in": counters.get("bytes_in", 0),
        "dropped": counters.get("dropped", 0),
    }
