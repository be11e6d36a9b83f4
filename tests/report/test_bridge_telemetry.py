"""The bridge's telemetry through real sockets: trace and stats topics, the stats service,
/client_count and /metrics."""

from __future__ import annotations

import asyncio
import time
import urllib.request
from collections.abc import AsyncIterator
from typing import Any

import pytest
from prometheus_client.parser import text_string_to_metric_families

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from clients.node.links import node_links
from clients.node.telemetry import telemetry
from clients.report.journeys import spans_of_batch
from clients.tracing import Tracer
from schemas.tracing import (
    STATS_SERVICE,
    STATS_SERVICE_TYPE,
    STATS_TOPIC,
    STATS_TYPE,
    TRACE_TOPIC,
    TRACE_TYPE,
)

IMU = ("/imu/data", "sensor_msgs/msg/Imu")


@pytest.fixture
async def bridge() -> AsyncIterator[Any]:
    async with run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as running:
        yield running


def imu_msg(stamp_ns: int) -> dict[str, Any]:
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return {"header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "imu"}}


async def collect_spans(sub, until, timeout_s: float = 8.0) -> list:
    spans: list = []
    async with asyncio.timeout(timeout_s):
        while not until(spans):
            spans += spans_of_batch((await sub.get()).msg)
    return spans


async def test_every_stage_of_a_message_reaches_a_trace_reader(bridge):
    pub_tracer, sub_tracer = Tracer("pub"), Tracer("sub")
    async with (
        RosbridgeClient(bridge.url, name="reader") as reader,
        RosbridgeClient(bridge.url, name="pub", tracer=pub_tracer) as pub,
        RosbridgeClient(bridge.url, name="sub", tracer=sub_tracer) as sub,
    ):
        trace = await reader.subscribe(TRACE_TOPIC, TRACE_TYPE, maxsize=1000)
        async with (
            telemetry(pub, pub_tracer, period_s=0.2),
            telemetry(sub, sub_tracer, period_s=0.2),
        ):
            received = await sub.subscribe(*IMU)
            await pub.advertise(*IMU)
            await asyncio.sleep(1.5)  # the bridge learns the subscriber's process name
            stamp_ns = time.time_ns()
            await pub.publish(IMU[0], imu_msg(stamp_ns))
            await received.get()

            def complete(spans):
                return {s.stage for s in spans if s.stamp_ns == stamp_ns} >= {
                    "encode",
                    "send",
                    "bridge_in",
                    "fanout",
                    "decode",
                }

            spans = await collect_spans(trace, complete)
    mine = {s.stage: s for s in spans if s.stamp_ns == stamp_ns}
    assert mine["bridge_in"].process == "bridge" and mine["bridge_in"].payload_bytes == 316
    assert mine["fanout"].peer == "sub"
    assert mine["decode"].process == "sub" and mine["encode"].process == "pub"
    assert mine["send"].start_ns <= mine["bridge_in"].start_ns <= mine["fanout"].end_ns
    assert mine["bridge_in"].wire_bytes == mine["send"].wire_bytes > 0
    assert not any(s.topic.startswith("/riverbridge/") for s in spans)


async def test_both_connections_of_a_node_are_named_after_its_process(bridge):
    fix = ("/gnss/fix", "sensor_msgs/msg/NavSatFix")
    async with (
        RosbridgeClient(bridge.url, name="reader") as reader,
        RosbridgeClient(bridge.url, name="pub") as pub,
        node_links(bridge.url, "watcher") as links,
    ):
        assert links.bulk is not links.realtime
        trace = await reader.subscribe(TRACE_TOPIC, TRACE_TYPE, maxsize=1000)
        stats = await reader.subscribe(STATS_TOPIC, STATS_TYPE, maxsize=100)
        imu = await links.realtime.subscribe(*IMU)
        fixes = await links.bulk.subscribe(*fix)
        await pub.advertise(*IMU)
        await pub.advertise(*fix)
        await asyncio.sleep(2.0)  # both connections announce the process (once a second)
        stamp_ns = time.time_ns()
        await pub.publish(IMU[0], imu_msg(stamp_ns))
        await pub.publish(fix[0], imu_msg(stamp_ns))
        await imu.get()
        await fixes.get()

        def traced(spans):
            seen = {(s.topic, s.stage) for s in spans if s.stamp_ns == stamp_ns}
            return seen >= {(t, stage) for t in (IMU[0], fix[0]) for stage in ("fanout", "decode")}

        spans = await collect_spans(trace, traced)
        announced = [m.msg for m in [await stats.get() for _ in range(4)]]
    peers = {s.topic: s.peer for s in spans if s.stamp_ns == stamp_ns and s.stage == "fanout"}
    assert peers == {IMU[0]: "watcher", fix[0]: "watcher"}
    decoded = {s.topic for s in spans if s.stamp_ns == stamp_ns and s.stage == "decode"}
    assert decoded == {IMU[0], fix[0]}, "one tracer records both connections"
    assert {m["process"] for m in announced} >= {"watcher"}


async def test_span_batches_go_out_more_often_than_stats(bridge):
    tracer = Tracer("often")
    async with (
        RosbridgeClient(bridge.url, name="reader") as reader,
        RosbridgeClient(bridge.url, name="often") as pub,
    ):
        trace = await reader.subscribe(TRACE_TOPIC, TRACE_TYPE, maxsize=1000)
        stats = await reader.subscribe(STATS_TOPIC, STATS_TYPE, maxsize=1000)
        async with telemetry(pub, tracer, period_s=1.0, trace_period_s=0.1):
            for k in range(12):  # a span for every batch
                tracer.spans.record(IMU[0], k, "generate", k, k + 1)
                await asyncio.sleep(0.1)
        await asyncio.sleep(0.5)
        batches = [
            b
            for b in (m.msg for m in _all(trace))
            if b["spans"] and b["spans"][0]["process"] == "often"
        ]
        announced = [m for m in (m.msg for m in _all(stats)) if m["process"] == "often"]
    assert len(batches) >= 6, len(batches)
    assert 1 <= len(announced) <= 3, len(announced)  # each second, and once more at the end
    assert sorted(s["stamp_ns"] for b in batches for s in b["spans"]) == list(range(12))


def _all(sub) -> list:
    items = []
    while (item := sub.get_nowait()) is not None:
        items.append(item)
    return items


async def test_stats_service_metrics_and_client_count(bridge):
    async with RosbridgeClient(bridge.url, name="watcher") as watcher:
        counts = await watcher.subscribe("/client_count", "std_msgs/msg/Int32")
        stats_topic = await watcher.subscribe(STATS_TOPIC, STATS_TYPE)
        async with asyncio.timeout(5):
            assert (await counts.get()).msg["data"] == 1
        async with RosbridgeClient(bridge.url, name="pub") as pub:
            async with asyncio.timeout(5):
                assert (await counts.get()).msg["data"] == 2
            await pub.advertise(*IMU)
            for k in range(3):
                await pub.publish(IMU[0], imu_msg(time.time_ns() + k))
            await asyncio.sleep(0.2)
            answer = await watcher.call_service(STATS_SERVICE, type=STATS_SERVICE_TYPE)
            async with asyncio.timeout(5):
                own = (await stats_topic.get()).msg
        metrics = await asyncio.to_thread(fetch, f"http://127.0.0.1:{bridge.port}/metrics")
    row = answer["topics"].index(IMU[0])
    assert answer["messages_in"][row] == 3 and answer["payload_bytes_in"][row] == 3 * 316
    assert answer["clients"] == 2 and len(answer["client_nodes"]) == 2
    assert own["process"] == "bridge" and own["rss_bytes"] > 0
    families = {f.name: f for f in text_string_to_metric_families(metrics)}
    assert {
        (s.labels["topic"], s.labels["direction"]): s.value
        for s in families["riverbridge_messages"].samples
    }[(IMU[0], "in")] == 3
    assert families["riverbridge_clients"].type == "gauge"
    assert families["riverbridge_process_resident_memory_bytes"].samples[0].value > 0
    assert families["process_cpu_seconds"].samples[0].value > 0


def fetch(url: str) -> str:
    with urllib.request.urlopen(url, timeout=5) as response:
        assert response.headers["Content-Type"].startswith("text/plain; version=0.0.4")
        return response.read().decode()
