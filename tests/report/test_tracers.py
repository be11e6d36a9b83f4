"""Span recording in the clients and the bridge, and its bounded memory."""

from __future__ import annotations

import numpy as np
import pytest

from clients.events import Received
from clients.tracing import Tracer
from schemas.codec_cdr import cdr_size, to_cdr
from schemas.message import normalize
from schemas.registry import TypeRegistry
from schemas.runtime.telemetry import telemetry_ticks, this_process
from schemas.tracing import (
    TRACE_TOPIC,
    SpanBuffer,
    header_stamp_ns,
    span_array_msg,
)

STAMPED = {"header": {"stamp": {"sec": 3, "nanosec": 5}, "frame_id": "imu"}}
STAMP_NS = 3_000_000_005


@pytest.fixture(scope="module")
def registry() -> TypeRegistry:
    return TypeRegistry.with_defaults()


def test_buffer_is_bounded_and_counts_what_it_discards():
    buffer = SpanBuffer(capacity=3)
    for k in range(5):
        buffer.record("/t", k, "encode", k, k + 1)
    assert len(buffer) == 3 and buffer.discarded == 2
    assert [span[1] for span in buffer.drain()] == [2, 3, 4]
    assert len(buffer) == 0


def test_publish_records_encode_and_send_with_wire_bytes():
    tracer = Tracer("simulator")
    tracer.published("/imu/data", STAMPED, 10, 20, 35, wire_bytes=400)
    spans = tracer.spans.drain()
    assert [(s[0], s[1], s[2], s[4], s[5], s[7]) for s in spans] == [
        ("/imu/data", STAMP_NS, "encode", 10, 20, 400),
        ("/imu/data", STAMP_NS, "send", 20, 35, 400),
    ]
    assert tracer.counters["messages_out"] == 1 and tracer.counters["bytes_out"] == 400


def test_no_spans_for_telemetry_topics_or_unstamped_messages():
    tracer = Tracer("navigation")
    tracer.published(TRACE_TOPIC, STAMPED, 1, 2, 3, 10)
    tracer.published("/tf", {"transforms": []}, 1, 2, 3, 10)
    tracer.received(Received("/riverbridge/process_stats", STAMPED, 1, 10), 2)
    assert len(tracer.spans) == 0
    assert tracer.counters["messages_out"] == 2 and tracer.counters["messages_in"] == 1


def test_wait_starts_when_the_message_was_decoded():
    tracer = Tracer("navigation")
    tracer.received(Received("/lidar/points", STAMPED, 100, 4000), 150)
    tracer.processed(
        "/lidar/points", STAMP_NS, 170, 300, queued_ns=100, steps={"dbscan": (180, 250)}
    )
    stages = {s[2]: (s[4], s[5]) for s in tracer.spans.drain()}
    assert stages == {
        "decode": (100, 150),
        "wait": (150, 170),
        "process": (170, 300),
        "process.dbscan": (180, 250),
    }


def test_batch_message_carries_process_and_host():
    tracer = Tracer("simulator")
    assert tracer.batch_msg() is None
    tracer.spans.record("/radar/image", 7, "generate", 1, 2)
    batch = tracer.batch_msg()
    assert batch["host"] and batch["spans"][0]["process"] == "simulator"
    assert batch["spans"][0]["stage"] == "generate"


def test_batches_and_stats_are_valid_messages(registry):
    batch = span_array_msg(this_process("bridge"), [("/t", 1, "fanout", "navigation", 2, 3, 0, 99)])
    normalize(registry.message("riverbridge_msgs/msg/TraceSpanArray"), batch, now_ns=0)
    stats = Tracer("x").stats_msg(10**18, dropped=4)
    checked = normalize(registry.message("riverbridge_msgs/msg/ProcessStats"), stats, now_ns=0)
    assert checked["dropped"] == 4 and checked["rss_bytes"] > 0


@pytest.mark.parametrize(
    "type_name, msg",
    [
        ("sensor_msgs/msg/Imu", {"header": {"frame_id": "imu"}}),
        (
            "sensor_msgs/msg/PointCloud2",
            {
                "header": {"frame_id": "lidar"},
                "width": 1000,
                "height": 1,
                "point_step": 16,
                "row_step": 16000,
                "data": bytes(16000),
                "fields": [{"name": "x", "offset": 0, "datatype": 7, "count": 1}],
            },
        ),
        (
            "riverbridge_msgs/msg/RadarImage",
            {
                "header": {"frame_id": "radar"},
                "num_beams": 3,
                "num_cells": 5,
                "reflectance": np.ones(15, np.float32),
            },
        ),
    ],
)
def test_cdr_size_equals_the_serialized_length(registry, type_name, msg):
    canonical = normalize(registry.message(type_name), msg, now_ns=0)
    assert cdr_size(registry, type_name, canonical) == len(to_cdr(registry, type_name, canonical))


def test_header_stamp_of_canonical_messages():
    assert header_stamp_ns(STAMPED) == STAMP_NS
    assert header_stamp_ns({"data": 1}) is None


async def test_telemetry_ticks_carry_stats_every_period_and_spans_in_between():
    ticks = telemetry_ticks(period_s=0.04, trace_period_s=0.01)
    pattern = [await anext(ticks) for _ in range(8)]
    await ticks.aclose()
    assert pattern == [False, False, False, True] * 2
