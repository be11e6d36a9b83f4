"""The bridge's /metrics exposition, read back with prometheus-client's own parser."""

from __future__ import annotations

from prometheus_client.parser import text_string_to_metric_families

from bridge.metrics import MetricsSnapshot, render_metrics
from bridge.tracing import TopicTraffic


def parse(text: str) -> dict[str, dict[tuple[tuple[str, str], ...], float]]:
    """Sample name -> sorted label pairs -> value, and each family's type under '#type'."""
    samples: dict[str, dict[tuple[tuple[str, str], ...], float]] = {}
    for family in text_string_to_metric_families(text):
        samples.setdefault("#type", {})[(("name", family.name),)] = family.type
        for sample in family.samples:
            samples.setdefault(sample.name, {})[tuple(sorted(sample.labels.items()))] = sample.value
    return samples


def test_counters_per_topic_and_direction_with_help_and_type() -> None:
    snapshot = MetricsSnapshot(
        topics={"/b": TopicTraffic(1, 2, 30, 40, 50), "/a": TopicTraffic(messages_in=7)},
        drops={("/b", "navigation"): 3},
        clients=2,
        cpu_percent=12.5,
        rss_bytes=1000,
        spans_discarded=4,
    )
    text = render_metrics(snapshot)
    metrics = parse(text)
    messages = metrics["riverbridge_messages_total"]
    assert messages[(("direction", "in"), ("topic", "/a"))] == 7
    assert messages[(("direction", "out"), ("topic", "/b"))] == 2
    assert metrics["riverbridge_wire_bytes_total"][(("direction", "out"), ("topic", "/b"))] == 50
    assert metrics["riverbridge_payload_bytes_total"][(("topic", "/b"),)] == 30
    assert (
        metrics["riverbridge_dropped_total"][(("subscriber", "navigation"), ("topic", "/b"))] == 3
    )
    assert metrics["riverbridge_clients"][()] == 2
    assert metrics["riverbridge_process_cpu_percent"][()] == 12.5
    assert metrics["riverbridge_process_resident_memory_bytes"][()] == 1000
    assert metrics["riverbridge_trace_spans_discarded_total"][()] == 4
    types = metrics["#type"]
    assert types[(("name", "riverbridge_messages"),)] == "counter"
    assert types[(("name", "riverbridge_clients"),)] == "gauge"
    lines = text.splitlines()
    assert "# TYPE riverbridge_messages_total counter" in lines
    assert lines.index('riverbridge_messages_total{direction="in",topic="/a"} 7.0') < lines.index(
        'riverbridge_messages_total{direction="in",topic="/b"} 1.0'
    )
    assert text.endswith("\n")


def test_process_collector_reports_this_process() -> None:
    metrics = parse(render_metrics(MetricsSnapshot({}, {}, 0, 0.0, 0)))
    assert metrics["process_resident_memory_bytes"][()] > 1_000_000
    assert metrics["process_cpu_seconds_total"][()] > 0
    assert metrics["process_open_fds"][()] >= 3
    assert "python_info" in metrics


def test_label_values_are_escaped() -> None:
    topic = 'a"b\\c\nd'
    text = render_metrics(MetricsSnapshot({topic: TopicTraffic(messages_in=1)}, {}, 0, 0.0, 0))
    assert 'topic="a\\"b\\\\c\\nd"' in text
    assert parse(text)["riverbridge_payload_bytes_total"][(("topic", topic),)] == 0
