"""Prometheus text rendering of the bridge's counters."""

from __future__ import annotations

from bridge.metrics import MetricsSnapshot, escape_label, render_metrics
from bridge.tracing import TopicTraffic


def test_counters_per_topic_and_direction_with_help_and_type():
    snapshot = MetricsSnapshot(
        topics={"/b": TopicTraffic(1, 2, 30, 40, 50), "/a": TopicTraffic(messages_in=7)},
        drops={("/b", "navigation"): 3}, clients=2, cpu_percent=12.5, rss_bytes=1000,
        spans_discarded=4)
    text = render_metrics(snapshot)
    lines = text.splitlines()
    assert 'riverbridge_messages_total{topic="/a",direction="in"} 7' in lines
    assert 'riverbridge_messages_total{topic="/b",direction="out"} 2' in lines
    assert 'riverbridge_wire_bytes_total{topic="/b",direction="out"} 50' in lines
    assert 'riverbridge_payload_bytes_total{topic="/b"} 30' in lines
    assert 'riverbridge_dropped_total{topic="/b",subscriber="navigation"} 3' in lines
    assert "riverbridge_clients 2" in lines and "riverbridge_process_cpu_percent 12.5" in lines
    assert "riverbridge_trace_spans_discarded_total 4" in lines
    assert "# TYPE riverbridge_messages_total counter" in lines
    assert lines.index('riverbridge_messages_total{topic="/a",direction="in"} 7') < lines.index(
        'riverbridge_messages_total{topic="/b",direction="in"} 1')
    assert text.endswith("\n")


def test_label_values_are_escaped():
    assert escape_label('a"b\\c\nd') == 'a\\"b\\\\c\\nd'
