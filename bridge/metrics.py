"""Prometheus text exposition (format 0.0.4) of the bridge's counters, for ``GET /metrics``.

Pure rendering: `render_metrics` turns a `MetricsSnapshot` into the text a Prometheus scraper
reads; the edge builds the snapshot from the tracer and the send queues at request time.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from bridge.tracing import TopicTraffic

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


def escape_label(value: str) -> str:
    """Label values escape backslash, double quote and newline (exposition format); a string
    with no UTF-8 form (a lone surrogate) is shown with a backslash escape, not a 500."""
    if not value.isascii():
        value = value.encode("utf-8", "backslashreplace").decode("utf-8")
    return value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")


def _labels(**labels: str) -> str:
    return "{" + ",".join(f'{key}="{escape_label(value)}"' for key, value in labels.items()) + "}"


def _family(name: str, kind: str, help_text: str,
            samples: Iterable[tuple[str, float]]) -> list[str]:
    lines = [f"# HELP {name} {help_text}", f"# TYPE {name} {kind}"]
    lines += [f"{name}{labels} {value:g}" if isinstance(value, float) else
              f"{name}{labels} {value}" for labels, value in samples]
    return lines


def render_metrics(snapshot: MetricsSnapshot) -> str:
    """The exposition text, one family per counter, topics sorted."""
    topics = sorted(snapshot.topics.items())
    lines = _family(
        "riverbridge_messages_total", "counter", "Messages published into (in) or delivered "
        "out of (out) the bridge, per topic.",
        [(_labels(topic=t, direction="in"), c.messages_in) for t, c in topics]
        + [(_labels(topic=t, direction="out"), c.messages_out) for t, c in topics])
    lines += _family(
        "riverbridge_wire_bytes_total", "counter", "Websocket payload bytes per topic.",
        [(_labels(topic=t, direction="in"), c.wire_bytes_in) for t, c in topics]
        + [(_labels(topic=t, direction="out"), c.wire_bytes_out) for t, c in topics])
    lines += _family(
        "riverbridge_payload_bytes_total", "counter", "Serialized ROS 2 (CDR) bytes of the "
        "stamped messages published, per topic.",
        [(_labels(topic=t), c.payload_bytes_in) for t, c in topics])
    lines += _family(
        "riverbridge_dropped_total", "counter", "Messages dropped for a slow subscriber "
        "(send queue or subscription queue), per topic and subscriber.",
        [(_labels(topic=t, subscriber=s), n) for (t, s), n in sorted(snapshot.drops.items())])
    lines += _family("riverbridge_clients", "gauge", "Connected websocket clients.",
                     [("", snapshot.clients)])
    lines += _family("riverbridge_process_cpu_percent", "gauge", "CPU of the bridge process "
                     "over the last stats interval (100 = one core).",
                     [("", float(snapshot.cpu_percent))])
    lines += _family("riverbridge_process_resident_memory_bytes", "gauge",
                     "Resident memory of the bridge process.", [("", snapshot.rss_bytes)])
    lines += _family("riverbridge_trace_spans_discarded_total", "counter",
                     "Trace spans discarded because the bounded span buffer was full.",
                     [("", snapshot.spans_discarded)])
    if snapshot.restarts:
        lines += _family("riverbridge_component_restarts_total", "counter",
                         "Restarts of each component by riverbridge up (/riverbridge/restarts).",
                         [(_labels(component=c), n) for c, n in sorted(snapshot.restarts.items())])
    return "\n".join(lines) + "\n"
