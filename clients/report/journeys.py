"""Trace spans joined into journeys: one message's way to one subscribing process.

Pure functions over recorded data (no sockets, no clock), so they are unit-testable on
synthetic spans. Spans are joined on ``(topic, stamp_ns)`` (docs/tracing.md); a journey has
every stage's duration and the hops between processes. Durations are milliseconds; byte
counts are bytes.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

# Stages in path order: recorded spans plus the two hops between processes.
STAGES = (
    "generate",
    "publish_wait",
    "encode",
    "send",
    "pub_to_bridge",
    "bridge_in",
    "fanout",
    "bridge_to_sub",
    "decode",
    "wait",
    "process",
)
TRANSPORT = "transport"  # publisher ready (generate.end) -> subscriber decoded (decode.end)
RESULT = "result"  # publisher ready -> processing done (scan -> boxes)
STEP_PREFIX = "process."
ROW_ORDER = (*STAGES, TRANSPORT, RESULT)

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
    return [
        SpanRecord(
            s["topic"],
            int(s["stamp_ns"]),
            s["stage"],
            s["process"],
            s["peer"],
            int(s["start_ns"]),
            int(s["end_ns"]),
            int(s["payload_bytes"]),
            int(s["wire_bytes"]),
            host,
        )
        for s in batch.get("spans", [])
    ]


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


def _publisher_side(spans: Sequence[SpanRecord]) -> tuple[dict[str, float], dict[str, SpanRecord]]:
    """Durations up to the bridge, and the spans the hops need (first of each stage)."""
    first: dict[str, SpanRecord] = {}
    for span in spans:
        if span.stage not in ("fanout", "decode", "wait", "process") and not span.stage.startswith(
            STEP_PREFIX
        ):
            first.setdefault(span.stage, span)
    durations = {stage: _ms(s.start_ns, s.end_ns) for stage, s in first.items()}
    if "send" in first and "bridge_in" in first:
        durations["pub_to_bridge"] = _ms(first["send"].start_ns, first["bridge_in"].start_ns)
    if "generate" in first and "encode" in first:  # the publisher's queue and event loop
        durations["publish_wait"] = _ms(first["generate"].end_ns, first["encode"].start_ns)
    return durations, first


def _subscriber_side(
    spans: Sequence[SpanRecord], subscriber: str, fanouts: Sequence[SpanRecord]
) -> dict[str, float]:
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


def _add_end_to_end(
    journey: Journey, first: Mapping[str, SpanRecord], group: Sequence[SpanRecord], subscriber: str
) -> None:
    generate = first.get("generate")
    encode = first.get("encode")  # a replay (riverbridge play) has no generate: ready = encode
    if generate is not None:
        ready_ns = generate.end_ns
    elif encode is not None:
        ready_ns = encode.start_ns
    else:
        return
    for stage, name in (("decode", TRANSPORT), ("process", RESULT)):
        end = next((s for s in group if s.stage == stage and s.process == subscriber), None)
        if end is not None:
            journey.durations_ms[name] = _ms(ready_ns, end.end_ns)


def by_topic(items: Iterable[Journey]) -> dict[str, list[Journey]]:
    """Journeys grouped by topic, topics sorted."""
    grouped: dict[str, list[Journey]] = defaultdict(list)
    for journey in items:
        grouped[journey.topic].append(journey)
    return dict(sorted(grouped.items()))


def stage_values(items: Iterable[Journey]) -> dict[str, list[float]]:
    """Every duration (ms) of each stage over `items`, for statistics and box plots."""
    values: dict[str, list[float]] = defaultdict(list)
    for journey in items:
        for stage, value in journey.durations_ms.items():
            values[stage].append(value)
    return dict(values)


def hosts_of(spans: Iterable[SpanRecord]) -> list[str]:
    """Recording hosts; more than one means cross-process hops are not comparable."""
    return sorted({s.host for s in spans if s.host})


def stage_order(names: Iterable[str]) -> list[str]:
    """`names` in path order: stages, end-to-end columns, then processing sub-steps."""
    present = set(names)
    return [s for s in ROW_ORDER if s in present] + sorted(s for s in present if s not in ROW_ORDER)
