"""The report's statistics on synthetic spans: joins, hops, percentiles, misses, bytes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from clients.report.journeys import RESULT, TRANSPORT, SpanRecord, journeys, spans_of_batch
from clients.report.results import Run, TopicSummary
from clients.report.sockets import SocketTraffic
from clients.report.stats import (
    loopback_tx_bytes,
    median_interval_ms,
    network_summary,
    percentiles,
    process_summary,
    summarise,
)
from clients.report.text import render_comparison, render_run

MS = 1_000_000
TOPIC = "/lidar/points"


def path_spans(
    stamp_ns: int,
    topic: str = TOPIC,
    transport_extra_ms: float = 0.0,
    subscriber: str = "navigation",
) -> list[SpanRecord]:
    """One message's full path; every stage 1 ms, hops 1 ms (plus extra before decode)."""
    t = stamp_ns
    extra = int(transport_extra_ms * MS)

    def span(stage, process, start_ms, end_ms, peer="", payload=0, wire=0, late_ns=0):
        return SpanRecord(
            topic,
            stamp_ns,
            stage,
            process,
            peer,
            t + int(start_ms * MS) + late_ns,
            t + int(end_ms * MS) + late_ns,
            payload,
            wire,
            "host",
        )

    return [
        span("generate", "simulator", 0, 10),
        span("encode", "simulator", 10, 11, wire=1010),
        span("send", "simulator", 11, 12, wire=1010),
        span("bridge_in", "bridge", 13, 14, payload=1000, wire=1010),
        span("fanout", "bridge", 14, 15, peer=subscriber, wire=1020),
        span("decode", subscriber, 16, 17, wire=1020, late_ns=extra),
        span("wait", subscriber, 17, 18, late_ns=extra),
        span("process", subscriber, 18, 30, late_ns=extra),
        span("process.dbscan", subscriber, 18, 25, late_ns=extra),
    ]


def stats_msg(sec: int, process: str, cpu_percent: float, rss_bytes: int, pid: int = 1) -> dict:
    """A ProcessStats of `process` at `sec` with fixed counters."""
    return {
        "header": {"stamp": {"sec": sec, "nanosec": 0}, "frame_id": ""},
        "process": process,
        "cpu_percent": cpu_percent,
        "rss_bytes": rss_bytes,
        "pid": pid,
        "host": "h",
        "messages_out": 1,
        "messages_in": 2,
        "bytes_out": 3,
        "bytes_in": 4,
        "dropped": 0,
    }


def test_a_journey_has_every_stage_and_both_hops():
    (journey,) = journeys(path_spans(10**18))
    d = journey.durations_ms
    assert d["generate"] == pytest.approx(10.0)
    assert d["publish_wait"] == pytest.approx(0.0)  # generate.end (10) -> encode.start (10)
    assert d["pub_to_bridge"] == pytest.approx(2.0)  # send.start (11) -> bridge_in.start (13)
    assert d["bridge_to_sub"] == pytest.approx(1.0)  # fanout.end (15) -> decode.start (16)
    assert d[TRANSPORT] == pytest.approx(7.0)  # generate.end (10) -> decode.end (17)
    assert d[RESULT] == pytest.approx(20.0)  # generate.end (10) -> process.end (30)
    assert d["process.dbscan"] == pytest.approx(7.0)
    assert (journey.payload_bytes, journey.wire_in_bytes, journey.wire_out_bytes) == (
        1000,
        1010,
        1020,
    )


def test_two_subscribers_pair_with_their_own_fanout():
    spans = path_spans(10**18, subscriber="navigation")
    other = [
        s
        for s in path_spans(10**18, subscriber="dashboard", transport_extra_ms=5.0)
        if s.stage in ("fanout", "decode")
    ]
    by_subscriber = {j.subscriber: j for j in journeys(spans + other)}
    assert set(by_subscriber) == {"navigation", "dashboard"}
    assert by_subscriber["dashboard"].durations_ms["bridge_to_sub"] == pytest.approx(6.0)
    assert by_subscriber["navigation"].durations_ms["bridge_to_sub"] == pytest.approx(1.0)
    assert RESULT not in by_subscriber["dashboard"].durations_ms


def test_percentiles_are_ordered_and_match_numpy():
    values = list(np.random.default_rng(1).exponential(5.0, 1000))
    p = percentiles(values)
    assert p.n == 1000
    assert p.p50 <= p.p90 <= p.p99 <= p.max
    assert p.p99 == pytest.approx(np.percentile(values, 99))
    assert percentiles([]).n == 0 and math.isnan(percentiles([]).mean)


def test_summary_counts_rate_misses_bytes_and_thesis():
    period_ns = 500 * MS
    spans = []
    for k in range(10):
        spans += path_spans(10**18 + k * period_ns, transport_extra_ms=600.0 if k == 3 else 0)
    topic = summarise(spans, duration_s=5.0)[TOPIC]
    assert topic.messages == 10
    assert topic.rate_hz == pytest.approx(2.0)
    assert topic.period_ms == pytest.approx(500.0)
    assert topic.deadline_misses == 1
    assert topic.result_deadline_misses == 1
    assert topic.overhead_in == pytest.approx(1.01)
    thesis = topic.thesis
    assert thesis.means[TRANSPORT] == 86.0 and thesis.means["process.boxes"] == 186.0
    assert thesis.statistic == "mean"  # appendix A's Ø
    assert thesis.sources[TRANSPORT] == "table A.1 5b"
    assert thesis.not_comparable == ("process.dbscan", "process.boxes")
    assert topic.payload_bytes_mean == pytest.approx(1000.0)
    assert topic.unprocessed == 0


def test_messages_never_processed_count_as_unprocessed_except_the_last_ones():
    spans = []
    for k in range(10):
        full = path_spans(10**18 + k * 500 * MS)
        spans += [s for s in full if s.stage != "process"] if k in (2, 9) else full
    assert summarise(spans, 5.0)[TOPIC].unprocessed == 1  # k=9 may still be in progress


def test_batches_unpack_into_records():
    batch = {
        "host": "h",
        "spans": [
            {
                "topic": "/t",
                "stamp_ns": 5,
                "stage": "encode",
                "process": "p",
                "peer": "",
                "start_ns": 1,
                "end_ns": 2,
                "payload_bytes": 0,
                "wire_bytes": 9,
            }
        ],
    }
    assert spans_of_batch(batch) == [SpanRecord("/t", 5, "encode", "p", "", 1, 2, 0, 9, "h")]


def test_median_interval_ignores_duplicates():
    assert median_interval_ms([0, 20 * MS, 20 * MS, 40 * MS]) == pytest.approx(20.0)
    assert math.isnan(median_interval_ms([7]))


def test_loopback_counters_are_read_from_proc_net_dev_text():
    text = (
        "Inter-|   Receive  |  Transmit\n face |bytes packets errs drop fifo frame "
        "compressed multicast|bytes packets\n"
        "    lo: 1000 10 0 0 0 0 0 0 2000 20 0 0 0 0 0 0\n"
        "  eth0: 5 1 0 0 0 0 0 0 6 1 0 0 0 0 0 0\n"
    )
    assert loopback_tx_bytes(text) == 2000
    assert loopback_tx_bytes(text, "wlan0") is None


def test_process_and_network_summaries():
    samples = ((1, 10.0, 100), (2, 30.0, 300), (3, 50.0, 200))
    stats = [stats_msg(sec, "bridge", cpu, rss) for sec, cpu, rss in samples]
    # A process with two connections announces its third sample on both.
    bridge = process_summary([*stats, stats[2]])["bridge"]
    assert bridge.samples == 3
    assert bridge.cpu_percent_mean == pytest.approx(30.0)
    assert bridge.rss_bytes_max == 300
    topics = {"/a": a_topic(1000, 1100, 2.0)}
    network = network_summary(topics, loopback_bytes=44_000, duration_s=10.0)
    assert network.wire_over_payload == pytest.approx(1.1)
    assert network.loopback_over_payload == pytest.approx(2.2)
    assert math.isnan(network.sensor_wire_over_payload), "no sensor stream among them"
    topics["/lidar/points"] = a_topic(10_000, 10_100, 2.0)
    topics["/imu/data"] = a_topic(100, 190, 10.0)
    network = network_summary(topics, loopback_bytes=None, duration_s=10.0)
    assert network.sensor_wire_over_payload == pytest.approx((20_200 + 1900) / 21_000)
    assert network.wire_over_payload == pytest.approx((22_100 + 2200) / 23_000)
    assert math.isnan(network.stack_over_sensor_payload), "no socket counters given"


def a_topic(payload_bytes: int, wire_in_bytes: int, rate_hz: float) -> TopicSummary:
    """A topic summary with the bytes and rate the network figures read."""
    spans = path_spans(10**18)
    summary = summarise(spans, 1.0)[TOPIC]
    return replace(
        summary, payload_bytes=payload_bytes, wire_in_bytes=wire_in_bytes, rate_hz=rate_hz
    )


def test_the_network_overhead_the_thesis_way_counts_every_socket_byte_over_sensor_payload():
    """Table 4.10 over 4.9: all the stack sent (every hop) / the four streams' payload."""
    topics = {"/lidar/points": a_topic(10_000, 10_100, 2.0), "/nav/boxes": a_topic(500, 900, 2.0)}
    sockets = SocketTraffic(
        stack_bytes=600_000,
        instrument_bytes=5_000,
        sockets=6,
        by_process={"bridge": 250_000, "simulator": 300_000, "navigation": 50_000},
    )
    network = network_summary(topics, loopback_bytes=1_000_000, duration_s=10.0, sockets=sockets)
    assert network.stack_bytes_per_s == pytest.approx(60_000.0)
    assert network.stack_over_sensor_payload == pytest.approx(3.0)  # 60 kB/s / 20 kB/s
    assert network.loopback_over_sensor_payload == pytest.approx(5.0)
    assert network.stack_bytes_per_s_by_process["simulator"] == pytest.approx(30_000.0)
    assert network.report_connection_bytes_per_s == pytest.approx(500.0)
    assert network.thesis.overhead == pytest.approx(1.62e6 / 291.27e3)


def test_tables_render_every_stage_and_the_comparison():
    spans = [s for k in range(5) for s in path_spans(10**18 + k * 500 * MS)]
    run = Run(
        "cbor",
        2.5,
        hosts=("host",),
        topics=summarise(spans, 2.5),
        samples={TOPIC: "10 points x 16 B"},
    )
    text = render_run(run)
    for stage in (
        "generate",
        "bridge_to_sub",
        "process.dbscan",
        TRANSPORT,
        "thesis Ø 86 ms (table A.1 5b)",
        "mean",
        "encoding ratio",
    ):
        assert stage in text
    assert "thesis Ø 29 ms (table A.1 3f) NOT COMPARABLE" in text
    assert "10 points x 16 B" in text
    comparison = render_comparison(
        [run, replace(run, encoding="json"), replace(run, profile="thesis")]
    )
    header = comparison.splitlines()[0]
    assert "cbor" in header and "json" in header and "thesis/cbor" in header
    assert "transport mean ms" in comparison and "table A.1 5b" in comparison
    assert "network overhead" in comparison and "5.56x" in comparison


def test_plots_are_written_per_run_and_topic(tmp_path):
    from clients.report.journeys import by_topic, stage_values
    from clients.report.plots import write_plots

    spans = [s for k in range(5) for s in path_spans(10**18 + k * 500 * MS)]
    values = {t: stage_values(items) for t, items in by_topic(journeys(spans)).items()}
    run = Run("cbor", 2.5, topics=summarise(spans, 2.5), stage_values=values)
    written = write_plots([run, replace(run, profile="thesis")], tmp_path)
    names = sorted(p.name for p in written)
    assert names == ["bytes.png", "cbor_lidar_points.png", "thesis-cbor_lidar_points.png"]
    assert all(p.stat().st_size > 1000 for p in written)
