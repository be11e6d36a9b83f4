"""Stage-tracing pieces shared by the bridge and the clients (docs/tracing.md).

The bridge may not import `clients`, and both record spans the same way, so the recorder,
the resource sampler and the message builders live here. Recording is one tuple append per
stage; nothing here does I/O except reading this process's own /proc entries.
"""

from __future__ import annotations

import asyncio
import os
import socket
import time
from collections import deque
from collections.abc import AsyncIterator
from typing import TYPE_CHECKING, Any

from schemas.catalogue import TOPICS, period_s
from schemas.codec_cdr import _to_object

if TYPE_CHECKING:
    from schemas.registry import TypeRegistry

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
SPAN_FIELDS = ("topic", "stamp_ns", "stage", "peer", "start_ns", "end_ns", "payload_bytes",
               "wire_bytes")


def is_traced(topic: str) -> bool:
    """Telemetry topics are not traced, or tracing would trace its own batches."""
    return not topic.startswith(TELEMETRY_PREFIX)


def header_stamp_ns(msg: Any) -> int | None:
    """`header.stamp` of a canonical message in ns, or None when it has no header stamp."""
    try:
        stamp = msg["header"]["stamp"]
        return int(stamp["sec"]) * NS_PER_S + int(stamp["nanosec"])
    except (KeyError, TypeError, ValueError):
        return None


def cdr_size(registry: TypeRegistry, type_name: str, msg: dict[str, Any]) -> int:
    """Serialized ROS 2 size of `msg` in bytes (4-byte header included), without serializing.

    Uses rosbags' size function on zero-copy views of the arrays: ~10 µs for a 4 MB cloud
    where `to_cdr` takes ~2 ms.
    """
    spec = registry.message(type_name)
    store = registry.typestore
    obj = _to_object(store.types, spec, msg)
    return 4 + int(store.get_msgdef(spec.name).getsize_cdr(0, obj, store))


class SpanBuffer:
    """Spans recorded by one process, waiting for the next batch.

    Bounded: when nobody drains it, the oldest spans go and `discarded` counts them.
    """

    def __init__(self, capacity: int = SPAN_CAPACITY) -> None:
        self._spans: deque[Span] = deque(maxlen=capacity)
        self.discarded = 0

    def __len__(self) -> int:
        return len(self._spans)

    def record(self, topic: str, stamp_ns: int, stage: str, start_ns: int, end_ns: int,
               payload_bytes: int = 0, wire_bytes: int = 0, peer: str = "") -> None:
        spans = self._spans
        if len(spans) == spans.maxlen:
            self.discarded += 1
        spans.append((topic, stamp_ns, stage, peer, start_ns, end_ns, payload_bytes, wire_bytes))

    def drain(self) -> list[Span]:
        """Every span recorded since the last drain, oldest first."""
        spans = list(self._spans)
        self._spans.clear()
        return spans


def span_array_msg(process: str, spans: list[Span], host: str | None = None) -> dict[str, Any]:
    """`riverbridge_msgs/msg/TraceSpanArray` (canonical form) of `spans` recorded by `process`."""
    return {"host": host or socket.gethostname(), "spans": [
        {"topic": topic, "stamp_ns": stamp_ns, "stage": stage, "process": process, "peer": peer,
         "start_ns": start_ns, "end_ns": end_ns, "payload_bytes": payload_bytes,
         "wire_bytes": wire_bytes}
        for topic, stamp_ns, stage, peer, start_ns, end_ns, payload_bytes, wire_bytes in spans]}


class ResourceSampler:
    """CPU share since the previous sample (`os.times`) and resident memory (/proc/self/statm)."""

    def __init__(self) -> None:
        self._page_bytes = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096
        self._last_cpu_s, self._last_wall_s = self._cpu_s(), time.monotonic()

    @staticmethod
    def _cpu_s() -> float:
        times = os.times()
        return times.user + times.system

    def rss_bytes(self) -> int:
        try:
            with open("/proc/self/statm", "rb") as statm:
                return int(statm.read().split()[1]) * self._page_bytes
        except (OSError, IndexError, ValueError):
            import resource  # not Linux: peak RSS is the best available (kB on Linux/BSD)
            return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    def cpu_percent(self) -> float:
        """Percent of one core used since the previous call (100 = one core busy)."""
        cpu_s, wall_s = self._cpu_s(), time.monotonic()
        elapsed_s = wall_s - self._last_wall_s
        share = (cpu_s - self._last_cpu_s) / elapsed_s if elapsed_s > 0 else 0.0
        self._last_cpu_s, self._last_wall_s = cpu_s, wall_s
        return 100.0 * share


def process_stats_msg(process: str, now_ns: int, cpu_percent: float, rss_bytes: int,
                      counters: dict[str, int]) -> dict[str, Any]:
    """`riverbridge_msgs/msg/ProcessStats` (canonical form); `counters` names its uint64s."""
    sec, nanosec = divmod(now_ns, NS_PER_S)
    return {"header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
            "process": process, "pid": os.getpid(), "host": socket.gethostname(),
            "cpu_percent": float(cpu_percent), "rss_bytes": int(rss_bytes),
            "messages_out": counters.get("messages_out", 0),
            "messages_in": counters.get("messages_in", 0),
            "bytes_out": counters.get("bytes_out", 0), "bytes_in": counters.get("bytes_in", 0),
            "dropped": counters.get("dropped", 0)}


async def telemetry_ticks(period_s: float = PUBLISH_PERIOD_S,
                          trace_period_s: float = TRACE_PERIOD_S) -> AsyncIterator[bool]:
    """Wake every `trace_period_s` (span batches) and say whether stats are due as well (every
    `period_s`); runs until cancelled. The bridge and the client processes share the rhythm."""
    step_s = min(trace_period_s, period_s)
    ticks_per_stats = max(1, round(period_s / step_s))
    tick = 0
    while True:
        await asyncio.sleep(step_s)
        tick += 1
        yield tick % ticks_per_stats == 0
