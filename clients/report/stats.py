"""The latency report's statistics: join trace spans into journeys, summarise, tabulate.

Pure functions over recorded data (no sockets, no clock), so they are unit-testable on
synthetic spans. Spans are joined on ``(topic, stamp_ns)`` (docs/tracing.md); a journey is
one message's way to one subscribing process, with every stage's duration and the hops
between processes. Durations are milliseconds; byte counts are bytes.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from clients.report.thesis import FIGURES
from schemas.catalogue import TOPICS as CATALOGUE
from schemas.tracing import header_stamp_ns

# Stages in path order: recorded spans plus the two hops between processes.
STAGES = ("generate", "publish_wait", "encode", "send", "pub_to_bridge", "bridge_in", "fanout",
          "bridge_to_sub", "decode", "wait", "process")
TRANSPORT = "transport"  # publisher ready (generate.end) -> subscriber decoded (decode.end)
RESULT = "result"  # publisher ready -> processing done (scan -> boxes)
STEP_PREFIX = "process."

# The thesis's four sensor streams (schemas.catalogue): their payload, their latency.
SENSOR_TOPICS = tuple(t.name for t in CATALOGUE.values() if t.thesis_sensor)

# The thesis's overhead (tables 4.9/4.10): 1.62 MB/s of network load for 291.27 KB/s of
# sensor payload. Every other figure, with its statistic and source: clients.report.thesis.
THESIS_OVERHEAD = 1.62e6 / 291.27e3
THESIS_WIRE_BPS = 1.62e6
THESIS_PAYLOAD_BPS = 291.27e3

NS_PER_MS = 1e6


class SpanRecord(NamedTuple):
    """One TraceSpan as received, with the host of its batch."""

    topic: str
    stamp_ns: int
    stage: str
    process: str
    peer: str
    start_ns: int
    end_ns: int
    payload_bytes: int
    wire_bytes: int
    host: str = ""


def spans_of_batch(batch: Mapping[str, Any]) -> list[SpanRecord]:
    """The spans of one TraceSpanArray message (canonical dict)."""
    host = batch.get("host", "")
    return [SpanRecord(s["topic"], int(s["stamp_ns"]), s["stage"], s["process"], s["peer"],
                       int(s["start_ns"]), int(s["end_ns"]), int(s["payload_bytes"]),
                       int(s["wire_bytes"]), host) for s in batch.get("spans", [])]


@dataclass
class Journey:
    """One message to one subscribing process: stage -> duration (ms), plus byte counts."""

    topic: str
    stamp_ns: int
    subscriber: str
    durations_ms: dict[str, float] = field(default_factory=dict)
    payload_bytes: int = 0
    wire_in_bytes: int = 0
    wire_out_bytes: int = 0


def _ms(start_ns: int, end_ns: int) -> float:
    return (end_ns - start_ns) / NS_PER_MS


def _publisher_side(spans: Sequence[SpanRecord]) -> tuple[dict[str, float], dict[str, Any]]:
    """Durations up to the bridge, and the spans the hops need (first of each stage)."""
    first: dict[str, SpanRecord] = {}
    for span in spans:
        if span.stage not in ("fanout", "decode", "wait", "process") and \
                not span.stage.startswith(STEP_PREFIX):
            first.setdefault(span.stage, span)
    durations = {stage: _ms(s.start_ns, s.end_ns) for stage, s in first.items()}
    if "send" in first and "bridge_in" in first:
        durations["pub_to_bridge"] = _ms(first["send"].start_ns, first["bridge_in"].start_ns)
    if "generate" in first and "encode" in first:  # the publisher's queue and event loop
        durations["publish_wait"] = _ms(first["generate"].end_ns, first["encode"].start_ns)
    return durations, first


def _subscriber_side(spans: Sequence[SpanRecord], subscriber: str,
                     fanouts: Sequence[SpanRecord]) -> dict[str, float]:
    """Durations of `subscriber`'s stages and the bridge -> subscriber hop."""
    mine = {s.stage: s for s in spans if s.process == subscriber}
    durations = {stage: _ms(s.start_ns, s.end_ns) for stage, s in mine.items()}
    fanout = next((f for f in fanouts if f.peer == subscriber), None)
    if fanout is None and len(fanouts) == 1:
        fanout = fanouts[0]
    if fanout is not None:
        durations["fanout"] = _ms(fanout.start_ns, fanout.end_ns)
        if "decode" in mine:
            durations["bridge_to_sub"] = _ms(fanout.end_ns, mine["decode"].start_ns)
    return durations


def journeys(spans: Iterable[SpanRecord]) -> list[Journey]:
    """Join spans on (topic, stamp) into one journey per subscribing process.

    A message nobody decoded still yields one journey (subscriber "") with the publisher's
    and the bridge's stages, so rates and bytes count every message.
    """
    by_key: dict[tuple[str, int], list[SpanRecord]] = defaultdict(list)
    for span in spans:
        by_key[(span.topic, span.stamp_ns)].append(span)
    out: list[Journey] = []
    for (topic, stamp_ns), group in by_key.items():
        upstream, first = _publisher_side(group)
        fanouts = [s for s in group if s.stage == "fanout"]
        subscribers = sorted({s.process for s in group if s.stage == "decode"}) or [""]
        bridge_in = first.get("bridge_in")
        for subscriber in subscribers:
            journey = Journey(topic, stamp_ns, subscriber, dict(upstream))
            journey.durations_ms.update(_subscriber_side(group, subscriber, fanouts))
            _add_end_to_end(journey, first, group, subscriber)
            if bridge_in is not None:
                journey.payload_bytes = bridge_in.payload_bytes
                journey.wire_in_bytes = bridge_in.wire_bytes
            fanout = next((f for f in fanouts if f.peer == subscriber), None)
            journey.wire_out_bytes = fanout.wire_bytes if fanout is not None else 0
            out.append(journey)
    return out


def _add_end_to_end(journey: Journey, first: Mapping[str, SpanRecord],
                    group: Sequence[SpanRecord], subscriber: str) -> None:
    generate = first.get("generate")
    encode = first.get("encode")  # a replay (riverbridge play) has no generate: ready = encode
    if generate is None and encode is None:
        return
    ready_ns = generate.end_ns if generate is not None else encode.start_ns
    for stage, name in (("decode", TRANSPORT), ("process", RESULT)):
        end = next((s for s in group if s.stage == stage and s.process == subscriber), None)
        if end is not None:
            journey.durations_ms[name] = _ms(ready_ns, end.end_ns)


def percentiles(values_ms: Sequence[float]) -> dict[str, float]:
    """n, mean, p50, p90, p99 and max of `values_ms` (numpy's linear interpolation)."""
    if not values_ms:
        return {"n": 0}
    values = np.asarray(values_ms, dtype=np.float64)
    p50, p90, p99 = np.percentile(values, [50, 90, 99])
    return {"n": int(values.size), "mean": float(values.mean()), "p50": float(p50),
            "p90": float(p90), "p99": float(p99), "max": float(values.max())}


def median_interval_ms(stamps_ns: Sequence[int]) -> float:
    """Median spacing of distinct stamps, in ms (the sensor period as published)."""
    stamps = np.unique(np.asarray(stamps_ns, dtype=np.int64))
    return float(np.median(np.diff(stamps))) / NS_PER_MS if stamps.size > 1 else math.nan


def _median(values: Iterable[int]) -> int:
    known = [v for v in values if v > 0]
    return int(np.median(known)) if known else 0


def topic_summary(topic: str, items: Sequence[Journey], duration_s: float) -> dict[str, Any]:
    """Rate, bytes, overhead, per-stage percentiles and deadline misses of one topic."""
    stamps = sorted({j.stamp_ns for j in items})
    period_ms = median_interval_ms(stamps)
    stages = stage_values(items)
    payload = _median(j.payload_bytes for j in items)
    wire_in = _median(j.wire_in_bytes for j in items)
    wire_out = _median(j.wire_out_bytes for j in items)
    transport = stages.get(TRANSPORT, [])
    result = stages.get(RESULT, [])
    payloads = {j.stamp_ns: j.payload_bytes for j in items if j.payload_bytes > 0}
    summary: dict[str, Any] = {
        "messages": len(stamps),
        "rate_hz": len(stamps) / duration_s if duration_s > 0 else math.nan,
        "period_ms": period_ms,
        "payload_bytes": payload, "wire_in_bytes": wire_in, "wire_out_bytes": wire_out,
        # the thesis's table 4.9 averages 100 messages: the mean, once per message
        "payload_bytes_mean": float(np.mean(list(payloads.values()))) if payloads else 0.0,
        "overhead_in": wire_in / payload if payload else math.nan,
        "overhead_out": wire_out / payload if payload else math.nan,
        "subscribers": sorted({j.subscriber for j in items if j.subscriber}),
        "stages": {stage: percentiles(values) for stage, values in sorted(stages.items())},
        "deadline_misses": int(sum(v > period_ms for v in transport)),
        "result_deadline_misses": int(sum(v > period_ms for v in result)),
        "unprocessed": unprocessed(items),
        "thesis": thesis_figures(topic),
    }
    return summary


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


def thesis_figures(topic: str) -> dict[str, Any]:
    """The thesis's mean (Ø, table A.1) of a stage of ``topic``, per stage (ms), and where it
    comes from: ``{"transport": 86.0, "sources": {"transport": "table A.1 5b"}, ...}``.
    Stages whose thesis figure measured something else are listed under ``not_comparable``."""
    figures: dict[str, Any] = {"statistic": "mean", "sources": {}, "not_comparable": []}
    for figure in FIGURES:
        if figure.topic == topic and figure.stage and figure.statistic == "mean":
            figures[figure.stage] = figure.thesis
            figures["sources"][figure.stage] = figure.source
            if not figure.comparable:
                figures["not_comparable"].append(figure.stage)
    return figures


def by_topic(items: Iterable[Journey]) -> dict[str, list[Journey]]:
    """Journeys grouped by topic, topics sorted."""
    grouped: dict[str, list[Journey]] = defaultdict(list)
    for journey in items:
        grouped[journey.topic].append(journey)
    return dict(sorted(grouped.items()))


def summarise(spans: Iterable[SpanRecord], duration_s: float) -> dict[str, dict[str, Any]]:
    """Per topic summaries of every traced topic, topics sorted."""
    return {topic: topic_summary(topic, items, duration_s)
            for topic, items in by_topic(journeys(spans)).items()}


def stage_values(items: Iterable[Journey]) -> dict[str, list[float]]:
    """Every duration (ms) of each stage over `items`, for box plots."""
    values: dict[str, list[float]] = defaultdict(list)
    for journey in items:
        for stage, value in journey.durations_ms.items():
            values[stage].append(value)
    return dict(values)


def process_summary(stats: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per process (ProcessStats messages): mean and max CPU %, max RSS, last counters.

    A process with several connections announces each sample on all of them; it counts once.
    """
    by_process: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    seen: set[tuple[str, Any]] = set()
    for message in stats:
        key = (message["process"], header_stamp_ns(message))
        if key[1] is None or key not in seen:
            seen.add(key)
            by_process[message["process"]].append(message)
    out = {}
    for process, items in sorted(by_process.items()):
        cpu = [float(m["cpu_percent"]) for m in items]
        last = items[-1]
        out[process] = {"samples": len(items), "cpu_percent_mean": float(np.mean(cpu)),
                        "cpu_percent_max": float(np.max(cpu)),
                        "rss_bytes_max": max(int(m["rss_bytes"]) for m in items),
                        "pid": int(last["pid"]), "host": last["host"],
                        **{k: int(last[k]) for k in ("messages_out", "messages_in",
                                                     "bytes_out", "bytes_in", "dropped")}}
    return out


def _per_s(count: float | None, duration_s: float) -> float:
    return count / duration_s if count is not None and duration_s > 0 else math.nan


def _over(num: float, den: float) -> float:
    return num / den if den else math.nan


def network_summary(topics: Mapping[str, Mapping[str, Any]], loopback_bytes: int | None,
                    duration_s: float, sockets: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The network load the thesis's way (table 4.10 over table 4.9) and the encoding ratio.

    * ``stack_over_sensor_payload``: every byte the stack's TCP sockets sent in the window
      (``sockets``, clients.report.sockets: each hop once, every op and telemetry batch, not the
      report's own connection) over the payload of the four sensor streams (CDR bytes x
      rate): the thesis's 1.62 MB/s over 291.27 KB/s. ``loopback_over_sensor_payload`` is
      the same with ``lo``'s transmit counter, which also counts every other program here.
    * ``sensor_wire_over_payload`` / ``wire_over_payload``: the encoding ratio, one hop's
      websocket bytes over CDR bytes, for the four sensor streams and for all topics.
    """
    payload_bps = sum(t["payload_bytes"] * t["rate_hz"] for t in topics.values())
    wire_bps = sum(t["wire_in_bytes"] * t["rate_hz"] for t in topics.values())
    sensors = [t for name, t in topics.items() if name in SENSOR_TOPICS]
    sensor_payload_bps = sum(t["payload_bytes"] * t["rate_hz"] for t in sensors)
    sensor_wire_bps = sum(t["wire_in_bytes"] * t["rate_hz"] for t in sensors)
    loopback_bps = _per_s(loopback_bytes, duration_s)
    stack_bps = _per_s(sockets["stack_bytes"] if sockets else None, duration_s)
    return {"payload_bytes_per_s": payload_bps, "wire_in_bytes_per_s": wire_bps,
            "loopback_bytes_per_s": loopback_bps,
            "wire_over_payload": _over(wire_bps, payload_bps),
            "loopback_over_payload": _over(loopback_bps, payload_bps),
            "sensor_payload_bytes_per_s": sensor_payload_bps,
            "sensor_wire_in_bytes_per_s": sensor_wire_bps,
            "sensor_wire_over_payload": _over(sensor_wire_bps, sensor_payload_bps),
            "stack_bytes_per_s": stack_bps,
            "stack_over_sensor_payload": _over(stack_bps, sensor_payload_bps),
            "loopback_over_sensor_payload": _over(loopback_bps, sensor_payload_bps),
            "stack_bytes_per_s_by_process": {
                name: _per_s(count, duration_s)
                for name, count in (sockets or {}).get("by_process", {}).items()},
            "report_connection_bytes_per_s": _per_s(
                sockets["instrument_bytes"] if sockets else None, duration_s),
            "thesis": {"wire_bytes_per_s": THESIS_WIRE_BPS,
                       "payload_bytes_per_s": THESIS_PAYLOAD_BPS, "overhead": THESIS_OVERHEAD}}


def hosts_of(spans: Iterable[SpanRecord]) -> list[str]:
    """Recording hosts; more than one means cross-process hops are not comparable."""
    return sorted({s.host for s in spans if s.host})


def loopback_tx_bytes(proc_net_dev: str, interface: str = "lo") -> int | None:
    """Transmitted bytes of `interface` from /proc/net/dev text (every loopback byte is sent
    once and received once; counting one side is the traffic)."""
    for line in proc_net_dev.splitlines():
        name, sep, counters = line.partition(":")
        if sep and name.strip() == interface:
            return int(counters.split()[8])
    return None


# -- order of stages -------------------------------------------------------------------------

ROW_ORDER = (*STAGES, TRANSPORT, RESULT)


def stage_order(names: Iterable[str]) -> list[str]:
    """`names` in path order: stages, end-to-end columns, then processing sub-steps."""
    present = set(names)
    return [s for s in ROW_ORDER if s in present] + sorted(
        s for s in present if s not in ROW_ORDER)
