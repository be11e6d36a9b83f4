"""Perception -> actuation from trace spans: scan stamp -> the command it caused, applied.

Joins four recorders' spans (docs/guidance.md): navigation's `process` of the scan (topic =
the sensor, key = the scan's stamp), guidance's `decode` of navigation's result (same stamp,
the result's topic), guidance's `guide` span (sensor topic and scan stamp; it ends at the
stamp of the first command that used the result) and the simulator's `actuate` span (the
command's topic and stamp; it ends when a physics step applied it). Pure: no sockets, no clock.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clients.report.journeys import NS_PER_MS, SpanRecord
from clients.report.results import ClosedLoop, Latency
from schemas.catalogue import TOPICS, consumed_by

COMMAND = TOPICS["guidance_cmd"].name
# sensor topic -> navigation's result of it that guidance reads (its first-use span's cause)
RESULTS = {t.follows: t.name for t in consumed_by("guidance", "output") if t.follows}
HOPS = ("navigation", "to_guidance", "guidance", "to_actuation")


def latency(values_ms: Sequence[float] | np.ndarray) -> Latency:
    values = np.asarray(values_ms, dtype=np.float64)
    if not len(values):
        return Latency()
    p50, p99 = np.percentile(values, [50, 99])
    return Latency(float(values.mean()), float(p50), float(p99), float(values.max()), len(values))


def closed_loop(spans: Sequence[SpanRecord]) -> ClosedLoop | None:
    """The closed-loop figures of a window, or None when no autopilot command was applied."""
    applied = {s.stamp_ns: s.end_ns for s in spans if s.topic == COMMAND and s.stage == "actuate"}
    if not applied:
        return None
    ends = {
        (s.topic, s.stamp_ns, s.stage): s.end_ns
        for s in spans
        if (s.stage, s.process) in (("process", "navigation"), ("decode", "guidance"))
    }
    totals: dict[str, list[float]] = {}
    hops: dict[str, dict[str, list[float]]] = {}
    for span in spans:
        if span.stage != "guide" or span.end_ns not in applied:
            continue
        stamp, actuated = span.stamp_ns, applied[span.end_ns]
        totals.setdefault(span.topic, []).append((actuated - stamp) / NS_PER_MS)
        processed = ends.get((span.topic, stamp, "process"))
        decoded = ends.get((RESULTS.get(span.topic, ""), stamp, "decode"))
        if processed is not None and decoded is not None:
            steps = np.diff([stamp, processed, decoded, span.end_ns, actuated]) / NS_PER_MS
            for hop, ms in zip(HOPS, steps, strict=True):
                hops.setdefault(span.topic, {}).setdefault(hop, []).append(float(ms))
    stamps = np.unique(
        [s.stamp_ns for s in spans if s.topic == COMMAND and s.process == "guidance"]
    )
    periods_ms = np.diff(stamps) / NS_PER_MS
    return ClosedLoop(
        perception_to_actuation_ms={topic: latency(v) for topic, v in sorted(totals.items())},
        hops_ms={
            topic: {hop: float(np.mean(v)) for hop, v in by_hop.items()}
            for topic, by_hop in sorted(hops.items())
        },
        control_period_ms=latency(periods_ms),
        control_jitter_ms=float(periods_ms.std()) if len(periods_ms) else float("nan"),
        commands=len(stamps),
    )
