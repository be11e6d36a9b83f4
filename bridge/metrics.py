"""Prometheus exposition of the bridge's counters for ``GET /metrics``, by prometheus-client.

The bridge already counts everything (`BridgeTracer`, the send queues), so nothing is
incremented here: at request time the edge builds a `MetricsSnapshot`, and `render_metrics`
exposes it through a custom collector in a registry of its own (no process-global registry),
next to prometheus-client's standard process, platform and GC collectors (``process_*``,
``python_*``). Metric names are those of the earlier hand-written exposition
(``riverbridge_messages_total`` ...); values are now written as floats (``7.0``) and labels
in name order.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

from prometheus_client import (
    CollectorRegistry,
    GCCollector,
    PlatformCollector,
    ProcessCollector,
    generate_latest,
)
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric

from bridge.goodput import LinkHealth
from bridge.roles import PrincipalCounters
from bridge.tracing import TopicTraffic

# Text exposition format 0.0.4, which generate_latest writes and every scraper reads.
CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"


@dataclass(frozen=True)
class MetricsSnapshot:
    """Everything /metrics reports; `drops` is keyed by (topic, subscriber)."""

    topics: Mapping[str, TopicTraffic]
    drops: Mapping[tuple[str, str], int]
    clients: int
    cpu_percent: float
    rss_bytes: int
    spans_discarded: int = 0
    # Restarts per component as `riverbridge up` reports them (schemas.supervision).
    restarts: Mapping[str, int] = field(default_factory=dict)
    # What each principal (a token's subject) did, with --roles or --audit-log (bridge.roles).
    principals: Mapping[str, PrincipalCounters] = field(default_factory=dict)
    # Each websocket client's link (goodput, round trip, conflation), by subscriber name.
    links: Mapping[str, LinkHealth] = field(default_factory=dict)


def safe_label(value: str) -> str:
    """A label value that has a UTF-8 form: a lone surrogate (a client's odd topic name) is
    shown backslash-escaped instead of failing the whole page with a 500."""
    if value.isascii():
        return value
    return value.encode("utf-8", "backslashreplace").decode("utf-8")


class SnapshotCollector:
    """A prometheus-client collector of one snapshot: counters per topic, a few gauges."""

    def __init__(self, snapshot: MetricsSnapshot) -> None:
        self._snapshot = snapshot

    def collect(self) -> Iterator[Metric]:
        snapshot = self._snapshot
        topics = sorted(snapshot.topics.items())
        messages = CounterMetricFamily(
            "riverbridge_messages",
            "Messages published into (in) or delivered out of (out) the bridge, per topic.",
            labels=["topic", "direction"],
        )
        wire = CounterMetricFamily(
            "riverbridge_wire_bytes",
            "Websocket payload bytes per topic.",
            labels=["topic", "direction"],
        )
        for direction in ("in", "out"):
            for topic, traffic in topics:
                labels = [safe_label(topic), direction]
                messages.add_metric(labels, getattr(traffic, f"messages_{direction}"))
                wire.add_metric(labels, getattr(traffic, f"wire_bytes_{direction}"))
        payload = CounterMetricFamily(
            "riverbridge_payload_bytes",
            "Serialized ROS 2 (CDR) bytes of the stamped messages published, per topic.",
            labels=["topic"],
        )
        for topic, traffic in topics:
            payload.add_metric([safe_label(topic)], traffic.payload_bytes_in)
        dropped = CounterMetricFamily(
            "riverbridge_dropped",
            "Messages dropped for a slow subscriber (send queue or "
            "subscription queue), per topic and subscriber.",
            labels=["topic", "subscriber"],
        )
        for (topic, subscriber), count in sorted(snapshot.drops.items()):
            dropped.add_metric([safe_label(topic), safe_label(subscriber)], count)
        yield from (messages, wire, payload, dropped)
        yield from link_metrics(snapshot.links)
        yield GaugeMetricFamily(
            "riverbridge_clients", "Connected websocket clients.", value=snapshot.clients
        )
        yield GaugeMetricFamily(
            "riverbridge_process_cpu_percent",
            "CPU of the bridge process over the last stats interval (100 = one core).",
            value=snapshot.cpu_percent,
        )
        yield GaugeMetricFamily(
            "riverbridge_process_resident_memory_bytes",
            "Resident memory of the bridge process.",
            value=snapshot.rss_bytes,
        )
        yield CounterMetricFamily(
            "riverbridge_trace_spans_discarded",
            "Trace spans discarded because the bounded span buffer was full.",
            value=snapshot.spans_discarded,
        )
        yield from principal_metrics(snapshot.principals)
        if snapshot.restarts:
            restarts = CounterMetricFamily(
                "riverbridge_component_restarts",
                "Restarts of each component by riverbridge up (/riverbridge/restarts).",
                labels=["component"],
            )
            for component, count in sorted(snapshot.restarts.items()):
                restarts.add_metric([safe_label(component)], count)
            yield restarts


PRINCIPAL_COUNTERS = {
    "messages": "Messages a principal published (within its quota).",
    "bytes": "Websocket bytes of the messages a principal published (within its quota).",
    "refusals": "Ops of a principal its role refused.",
    "dropped": "Messages of a principal dropped past its quota (messages/s, bytes/s).",
}


def principal_metrics(principals: Mapping[str, PrincipalCounters]) -> Iterator[Metric]:
    """``riverbridge_principal_<counter>{principal=...}``, one family per counter."""
    if not principals:
        return
    for counter, text in PRINCIPAL_COUNTERS.items():
        family = CounterMetricFamily(f"riverbridge_principal_{counter}", text, labels=["principal"])
        for principal, counters in sorted(principals.items()):
            family.add_metric([safe_label(principal)], getattr(counters, counter))
        yield family


def link_metrics(links: Mapping[str, LinkHealth]) -> Iterator[Metric]:
    """Per client: goodput, round trip, unsent bytes; per topic and client: conflated and
    reduced messages."""
    conflated = CounterMetricFamily(
        "riverbridge_conflated",
        "Messages a subscription's queue_length replaced by newer ones while its client "
        "could not take more, per topic and subscriber.",
        labels=["topic", "subscriber"],
    )
    reduced = CounterMetricFamily(
        "riverbridge_reduced",
        "Point clouds thinned to fit a subscriber's link (reduce), per topic and subscriber.",
        labels=["topic", "subscriber"],
    )
    goodput = GaugeMetricFamily(
        "riverbridge_client_goodput_bytes_per_second",
        "A client's link goodput, measured while its socket was backed up.",
        labels=["subscriber"],
    )
    rtt = GaugeMetricFamily(
        "riverbridge_client_rtt_seconds",
        "Round trip of the client's last websocket keepalive ping.",
        labels=["subscriber"],
    )
    unsent = GaugeMetricFamily(
        "riverbridge_client_unsent_bytes",
        "Bytes handed to a client's socket and not yet sent.",
        labels=["subscriber"],
    )
    for subscriber, health in sorted(links.items()):
        label = safe_label(subscriber)
        for topic, count in sorted(health.conflated.items()):
            conflated.add_metric([safe_label(topic), label], count)
        for topic, count in sorted(health.reduced.items()):
            reduced.add_metric([safe_label(topic), label], count)
        if health.goodput_bytes_per_s is not None:
            goodput.add_metric([label], health.goodput_bytes_per_s)
        rtt.add_metric([label], health.rtt_s)
        unsent.add_metric([label], health.unsent_bytes)
    yield from (conflated, reduced, goodput, rtt, unsent)


def render_metrics(snapshot: MetricsSnapshot) -> str:
    """The exposition text of `snapshot` and of this process (CPU seconds, memory, fds, GC)."""
    registry = CollectorRegistry(auto_describe=False)
    registry.register(SnapshotCollector(snapshot))
    ProcessCollector(registry=registry)
    PlatformCollector(registry=registry)
    GCCollector(registry=registry)
    return generate_latest(registry).decode("utf-8")
