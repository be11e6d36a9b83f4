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

from schemas.tracing import header_stamp_ns

# Stages in path order: recorded spans plus the two hops between processes.
STAGES = ("generate", "publish_wait", "encode", "send", "pub_to_bridge", "bridge_in", "fanout",
          "bridge_to_sub", "decode", "wait", "process")
TRANSPORT = "transport"  # publisher ready (generate.end) -> subscriber decoded (decode.end)
RESULT = "result"  # publisher ready -> processing done (scan -> boxes)
STEP_PREFIX = "process."

SENSOR_TOPICS = ("/lidar/points", "/radar/image", "/camera/image/compressed", "/imu/data")

# Thesis chapter 4 figures (tables 4.8-4.10, figures 4.1-4.4), for side-by-side columns.
THESIS_TRANSPORT_MS = {"/lidar/points": 86.0, "/radar/image": 30.0,
                       "/camera/image/compressed": 6.0, "/imu/data": 9.0}
THESIS_NOTES = {"/imu/data": "outliers above 80 ms"}
THESIS_STEPS_MS = {"dbscan": 29.0, "boxes": 186.0}  # table 4.8: DBSCAN 29 ms, boxes 186 ms
THESIS_OVERHEAD = 5.5  # table 4.10: 1.62 MB/s on the wire for 291 KB/s of payload
THESIS_WIRE_BPS = 1.62e6
THESIS_PAYLOAD_BPS = 291e3

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
    summary: dict[str, Any] = {
        "messages": len(stamps),
        "rate_hz": len(stamps) / duration_s if duration_s > 0 else math.nan,
        "period_ms": period_ms,
        "payload_bytes": payload, "wire_in_bytes": wire_in, "wire_out_bytes": wire_out,
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
    """The thesis's figure for the same quantities (ms), where it has one."""
    figures: dict[str, Any] = {}
    if topic in THESIS_TRANSPORT_MS:
        figures[TRANSPORT] = THESIS_TRANSPORT_MS[topic]
        figures["overhead"] = THESIS_OVERHEAD
    if topic in THESIS_NOTES:
        figures["note"] = THESIS_NOTES[topic]
    if topic == "/lidar/points":
        figures.update({f"{STEP_PREFIX}{k}": v for k, v in THESIS_STEPS_MS.items()})
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


def network_summary(topics: Mapping[str, Mapping[str, Any]], loopback_bytes: int | None,
                    duration_s: float) -> dict[str, Any]:
    """Loopback load against the payload it carried, like the thesis's table 4.10.

    Payload and publisher-side wire rates sum every traced topic (bytes x rate), and again the
    four sensor streams alone: the thesis's 291 kB/s of payload (table 4.9) were those.
    """
    payload_bps = sum(t["payload_bytes"] * t["rate_hz"] for t in topics.values())
    wire_bps = sum(t["wire_in_bytes"] * t["rate_hz"] for t in topics.values())
    sensors = [t for name, t in topics.items() if name in SENSOR_TOPICS]
    sensor_payload_bps = sum(t["payload_bytes"] * t["rate_hz"] for t in sensors)
    sensor_wire_bps = sum(t["wire_in_bytes"] * t["rate_hz"] for t in sensors)
    loopback_bps = loopback_bytes / duration_s if loopback_bytes is not None else math.nan
    return {"payload_bytes_per_s": payload_bps, "wire_in_bytes_per_s": wire_bps,
            "loopback_bytes_per_s": loopback_bps,
            "wire_over_payload": wire_bps / payload_bps if payload_bps else math.nan,
            "loopback_over_payload": loopback_bps / payload_bps if payload_bps else math.nan,
            "sensor_payload_bytes_per_s": sensor_payload_bps,
            "sensor_wire_in_bytes_per_s": sensor_wire_bps,
            "sensor_wire_over_payload": (sensor_wire_bps / sensor_payload_bps
                                         if sensor_payload_bps else math.nan),
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


# -- tables -----------------------------------------------------------------------------------

ROW_ORDER = (*STAGES, TRANSPORT, RESULT)


def _fmt_bytes(count: float) -> str:
    if not count or math.isnan(count):
        return "-"
    for unit, size in (("MB", 1e6), ("kB", 1e3)):
        if count >= size:
            return f"{count / size:.2f} {unit}"
    return f"{count:.0f} B"


def _fmt_ms(value: float | None) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.2f}"


def stage_order(names: Iterable[str]) -> list[str]:
    """`names` in path order: stages, end-to-end columns, then processing sub-steps."""
    present = set(names)
    return [s for s in ROW_ORDER if s in present] + sorted(
        s for s in present if s not in ROW_ORDER)


def _stage_rows(topic: str, summary: Mapping[str, Any]) -> list[str]:
    stages = summary["stages"]
    thesis = summary["thesis"]
    names = stage_order(stages)
    rows = []
    for stage in names:
        p = stages[stage]
        if not p.get("n"):
            continue
        figure = thesis.get(stage)
        note = f"thesis {figure:g} ms" if figure is not None else ""
        if stage == TRANSPORT and "note" in thesis:
            note += f" ({thesis['note']})"
        if stage == TRANSPORT:
            note += f"; misses {summary['deadline_misses']}/{p['n']}"
        if stage == RESULT:
            note += (f"misses {summary['result_deadline_misses']}/{p['n']}, "
                     f"unprocessed {summary['unprocessed']}")
        rows.append(f"    {stage:<16}{p['n']:>6}{_fmt_ms(p['p50']):>9}{_fmt_ms(p['p90']):>9}"
                    f"{_fmt_ms(p['p99']):>9}{_fmt_ms(p['max']):>9}   {note}")
    return rows


def render_run(run: Mapping[str, Any]) -> str:
    """The human-readable report of one run (one encoding)."""
    hosts = run.get("hosts", [])
    lines = [f"== {run['encoding']}: {run['duration_s']:.1f} s measured on "
             f"{', '.join(hosts) or 'unknown host'}"
             + (" (HOSTS DIFFER: cross-process hops are not comparable)" if len(hosts) > 1
                else "")]
    machine = run.get("machine")
    if machine:
        load = machine["load_average_1_5_15"]
        lines.append(f"   machine: {machine['cpus']} CPUs, load average {load[0]:.1f} / "
                     f"{load[1]:.1f} / {load[2]:.1f} (1/5/15 min) at the window's end")
    for topic, summary in run["topics"].items():
        payload = summary["payload_bytes"]
        sample = run.get("samples", {}).get(topic, "")
        lines.append(
            f"{topic}  {summary['rate_hz']:.1f} Hz (period {_fmt_ms(summary['period_ms'])} ms)"
            f"  payload {_fmt_bytes(payload)}  wire in {_fmt_bytes(summary['wire_in_bytes'])}"
            f" / out {_fmt_bytes(summary['wire_out_bytes'])}  overhead "
            f"{summary['overhead_in']:.3f}x (thesis {THESIS_OVERHEAD:g}x)"
            + (f"  [{sample}]" if sample else ""))
        if summary["stages"]:
            lines.append(f"    {'stage (ms)':<16}{'n':>6}{'p50':>9}{'p90':>9}{'p99':>9}"
                         f"{'max':>9}")
            lines += _stage_rows(topic, summary)
    lines += _process_rows(run.get("processes", {}))
    lines += _network_rows(run.get("network", {}))
    return "\n".join(lines)


def _process_rows(processes: Mapping[str, Mapping[str, Any]]) -> list[str]:
    if not processes:
        return []
    rows = [f"  {'process':<14}{'cpu % mean':>11}{'cpu % max':>10}{'rss max':>11}"
            f"{'msgs out':>10}{'msgs in':>9}{'dropped':>9}"]
    for name, p in processes.items():
        rows.append(f"  {name:<14}{p['cpu_percent_mean']:>11.1f}{p['cpu_percent_max']:>10.1f}"
                    f"{_fmt_bytes(p['rss_bytes_max']):>11}{p['messages_out']:>10}"
                    f"{p['messages_in']:>9}{p['dropped']:>9}")
    return rows


def _network_rows(network: Mapping[str, Any]) -> list[str]:
    if not network:
        return []
    return [f"  network: payload {_fmt_bytes(network['payload_bytes_per_s'])}/s, wire "
            f"{_fmt_bytes(network['wire_in_bytes_per_s'])}/s "
            f"({network['wire_over_payload']:.3f}x), loopback "
            f"{_fmt_bytes(network['loopback_bytes_per_s'])}/s "
            f"({network['loopback_over_payload']:.2f}x); thesis 1.62 MB/s wire for 291 kB/s "
            f"payload ({THESIS_OVERHEAD:g}x)",
            f"  sensor streams ({', '.join(SENSOR_TOPICS)}): payload "
            f"{_fmt_bytes(network.get('sensor_payload_bytes_per_s', math.nan))}/s, wire "
            f"{_fmt_bytes(network.get('sensor_wire_in_bytes_per_s', math.nan))}/s "
            f"({network.get('sensor_wire_over_payload', math.nan):.3f}x)"]


def render_comparison(runs: Sequence[Mapping[str, Any]]) -> str:
    """One table comparing the runs' transport latency and overhead per sensor topic."""
    header = f"{'topic':<26}{'quantity':<18}" + "".join(f"{r['encoding']:>12}" for r in runs)
    lines = [header + f"{'thesis':>12}"]
    topics = [t for t in SENSOR_TOPICS if any(t in r["topics"] for r in runs)]
    for topic in topics:
        for quantity, pick in (("transport p50 ms", ("p50", TRANSPORT)),
                               ("transport p99 ms", ("p99", TRANSPORT)),
                               ("transport max ms", ("max", TRANSPORT)),
                               ("result p50 ms", ("p50", RESULT))):
            key, stage = pick
            cells = [r["topics"].get(topic, {}).get("stages", {}).get(stage, {}).get(key)
                     for r in runs]
            if all(c is None for c in cells):
                continue
            figure = THESIS_TRANSPORT_MS.get(topic) if stage == TRANSPORT and key == "p50" \
                else None
            lines.append(f"{topic:<26}{quantity:<18}" + "".join(f"{_fmt_ms(c):>12}" for c in cells)
                         + f"{(f'{figure:g} avg' if figure else ''):>12}")
        overheads = [r["topics"].get(topic, {}).get("overhead_in", math.nan) for r in runs]
        lines.append(f"{topic:<26}{'wire/payload':<18}"
                     + "".join(f"{o:>12.3f}" for o in overheads) + f"{THESIS_OVERHEAD:>12g}")
    for label, key in (("sensor streams", "sensor_wire_over_payload"),
                       ("all topics", "wire_over_payload")):
        ratios = [r.get("network", {}).get(key, math.nan) for r in runs]
        lines.append(f"{label:<26}{'wire/payload':<18}"
                     + "".join(f"{o:>12.3f}" for o in ratios) + f"{THESIS_OVERHEAD:>12g}")
    return "\n".join(lines)
