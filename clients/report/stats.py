"""The report's statistics: journeys summarised per topic, processes, the network.

Pure functions over recorded data (no sockets, no clock) that build the dataclasses of
:mod:`clients.report.results`. Durations are milliseconds; byte counts are bytes.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from clients.report.journeys import RESULT, TRANSPORT, Journey, SpanRecord, by_topic, journeys
from clients.report.journeys import stage_values as journey_stage_values
from clients.report.results import (
    NetworkSummary,
    ProcessSummary,
    StageStats,
    ThesisMeans,
    TopicSummary,
)
from clients.report.sockets import SocketTraffic
from clients.report.thesis import FIGURES
from schemas.catalogue import TOPICS as CATALOGUE
from schemas.tracing import header_stamp_ns

# The thesis's four sensor streams (schemas.catalogue): their payload, their latency.
SENSOR_TOPICS = tuple(t.name for t in CATALOGUE.values() if t.thesis_sensor)

NS_PER_MS = 1e6


def percentiles(values_ms: Sequence[float]) -> StageStats:
    """n, mean, p50, p90, p99 and max of `values_ms` (numpy's linear interpolation)."""
    if not values_ms:
        return StageStats(0)
    values = np.asarray(values_ms, dtype=np.float64)
    p50, p90, p99 = np.percentile(values, [50, 90, 99])
    return StageStats(
        int(values.size),
        float(values.mean()),
        float(p50),
        float(p90),
        float(p99),
        float(values.max()),
    )


def median_interval_ms(stamps_ns: Sequence[int]) -> float:
    """Median spacing of distinct stamps, in ms (the sensor period as published)."""
    stamps = np.unique(np.asarray(stamps_ns, dtype=np.int64))
    return float(np.median(np.diff(stamps))) / NS_PER_MS if stamps.size > 1 else math.nan


def _median(values: Iterable[int]) -> int:
    known = [v for v in values if v > 0]
    return int(np.median(known)) if known else 0


def topic_summary(topic: str, items: Sequence[Journey], duration_s: float) -> TopicSummary:
    """Rate, bytes, overhead, per-stage percentiles and deadline misses of one topic."""
    stamps = sorted({j.stamp_ns for j in items})
    period_ms = median_interval_ms(stamps)
    stages = journey_stage_values(items)
    payload = _median(j.payload_bytes for j in items)
    wire_in = _median(j.wire_in_bytes for j in items)
    wire_out = _median(j.wire_out_bytes for j in items)
    payloads = {j.stamp_ns: j.payload_bytes for j in items if j.payload_bytes > 0}
    return TopicSummary(
        messages=len(stamps),
        rate_hz=len(stamps) / duration_s if duration_s > 0 else math.nan,
        period_ms=period_ms,
        payload_bytes=payload,
        wire_in_bytes=wire_in,
        wire_out_bytes=wire_out,
        # the thesis's table 4.9 averages 100 messages: the mean, once per message
        payload_bytes_mean=float(np.mean(list(payloads.values()))) if payloads else 0.0,
        overhead_in=wire_in / payload if payload else math.nan,
        overhead_out=wire_out / payload if payload else math.nan,
        subscribers=tuple(sorted({j.subscriber for j in items if j.subscriber})),
        stages={stage: percentiles(values) for stage, values in sorted(stages.items())},
        deadline_misses=sum(v > period_ms for v in stages.get(TRANSPORT, [])),
        result_deadline_misses=sum(v > period_ms for v in stages.get(RESULT, [])),
        unprocessed=unprocessed(items),
        thesis=thesis_figures(topic),
    )


def unprocessed(items: Sequence[Journey]) -> int:
    """Messages that reached the bridge but were never processed (skipped scans), not
    counting the last two periods, whose processing may still be under way when the run ends.
    Zero for topics nobody processes."""
    processed = {j.stamp_ns for j in items if "process" in j.durations_ms}
    if not processed:
        return 0
    stamps = sorted({j.stamp_ns for j in items if "bridge_in" in j.durations_ms})
    if len(stamps) < 3:
        return 0
    cutoff = stamps[-3]
    return sum(1 for s in stamps if s <= cutoff and s not in processed)


def thesis_figures(topic: str) -> ThesisMeans:
    """The thesis's mean (Ø, table A.1) of each stage of ``topic`` (ms) and its source;
    stages whose thesis figure measured something else are listed as not comparable."""
    means: dict[str, float] = {}
    sources: dict[str, str] = {}
    not_comparable: list[str] = []
    for figure in FIGURES:
        if figure.topic == topic and figure.stage and figure.statistic == "mean":
            means[figure.stage] = figure.thesis
            sources[figure.stage] = figure.source
            if not figure.comparable:
                not_comparable.append(figure.stage)
    return ThesisMeans("mean", sources, tuple(not_comparable), means)


def summarise(spans: Iterable[SpanRecord], duration_s: float) -> dict[str, TopicSummary]:
    """Per topic summaries of every traced topic, topics sorted."""
    return {
        topic: topic_summary(topic, items, duration_s)
        for topic, items in by_topic(journeys(spans)).items()
    }


def process_summary(stats: Iterable[Mapping[str, Any]]) -> dict[str, ProcessSummary]:
    """Per process (ProcessStats messages): mean and max CPU %, max RSS, last counters.

    A process with several connections announces each sample on all of them; it counts once.
    """
    by_process: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    seen: set[tuple[str, int | None]] = set()
    for message in stats:
        key = (message["process"], header_stamp_ns(message))
        if key[1] is None or key not in seen:
            seen.add(key)
            by_process[message["process"]].append(message)
    out = {}
    for process, items in sorted(by_process.items()):
        cpu = [float(m["cpu_percent"]) for m in items]
        last = items[-1]
        out[process] = ProcessSummary(
            process=process,
            samples=len(items),
            cpu_percent_mean=float(np.mean(cpu)),
            cpu_percent_max=float(np.max(cpu)),
            rss_bytes_max=max(int(m["rss_bytes"]) for m in items),
            pid=int(last["pid"]),
            host=str(last["host"]),
            messages_out=int(last["messages_out"]),
            messages_in=int(last["messages_in"]),
            bytes_out=int(last["bytes_out"]),
            bytes_in=int(last["bytes_in"]),
            dropped=int(last["dropped"]),
        )
    return out


def _per_s(count: float | None, duration_s: float) -> float:
    return count / duration_s if count is not None and duration_s > 0 else math.nan


def _over(num: float, den: float) -> float:
    return num / den if den else math.nan


def _bytes_per_s(topics: Iterable[TopicSummary]) -> tuple[float, float]:
    """(payload, websocket) bytes per second of ``topics``: per-message bytes x rate."""
    items = list(topics)
    return (
        sum(t.payload_bytes * t.rate_hz for t in items),
        sum(t.wire_in_bytes * t.rate_hz for t in items),
    )


def network_summary(
    topics: Mapping[str, TopicSummary],
    loopback_bytes: int | None,
    duration_s: float,
    sockets: SocketTraffic | None = None,
) -> NetworkSummary:
    """The network load the thesis's way (table 4.10 over table 4.9) and the encoding ratio.

    * ``stack_over_sensor_payload``: every byte the stack's TCP sockets sent in the window
      (``sockets``, clients.report.sockets: each hop once, every op and telemetry batch, not
      the report's own connection) over the payload of the four sensor streams (CDR bytes x
      rate): the thesis's 1.62 MB/s over 291.27 KB/s. ``loopback_over_sensor_payload`` is
      the same with ``lo``'s transmit counter, which also counts every other program here.
    * ``sensor_wire_over_payload`` / ``wire_over_payload``: the encoding ratio, one hop's
      websocket bytes over CDR bytes, for the four sensor streams and for all topics.
    """
    payload_bps, wire_bps = _bytes_per_s(topics.values())
    sensor_payload_bps, sensor_wire_bps = _bytes_per_s(
        t for name, t in topics.items() if name in SENSOR_TOPICS
    )
    loopback_bps = _per_s(loopback_bytes, duration_s)
    stack_bps = _per_s(sockets.stack_bytes if sockets else None, duration_s)
    return NetworkSummary(
        payload_bytes_per_s=payload_bps,
        wire_in_bytes_per_s=wire_bps,
        loopback_bytes_per_s=loopback_bps,
        wire_over_payload=_over(wire_bps, payload_bps),
        loopback_over_payload=_over(loopback_bps, payload_bps),
        sensor_payload_bytes_per_s=sensor_payload_bps,
        sensor_wire_in_bytes_per_s=sensor_wire_bps,
        sensor_wire_over_payload=_over(sensor_wire_bps, sensor_payload_bps),
        stack_bytes_per_s=stack_bps,
        stack_over_sensor_payload=_over(stack_bps, sensor_payload_bps),
        loopback_over_sensor_payload=_over(loopback_bps, sensor_payload_bps),
        stack_bytes_per_s_by_process={
            name: _per_s(count, duration_s)
            for name, count in (sockets.by_process if sockets else {}).items()
        },
        report_connection_bytes_per_s=_per_s(
            sockets.instrument_bytes if sockets else None, duration_s
        ),
    )


def loopback_tx_bytes(proc_net_dev: str, interface: str = "lo") -> int | None:
    """Transmitted bytes of `interface` from /proc/net/dev text (every loopback byte is sent
    once and received once; counting one side is the traffic)."""
    for line in proc_net_dev.splitlines():
        name, sep, counters = line.partition(":")
        if sep and name.strip() == interface:
            return int(counters.split()[8])
    return None
