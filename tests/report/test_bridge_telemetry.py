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


async def publish_until_named(pub, trace, peers: dict[str, str], complete):
    """Publish a freshly stamped message on every topic of ``peers`` (one IMU-shaped message
    each) until the trace shows one whose fan-out names each topic's expected peer and which
    ``complete(stamp_ns, spans)`` accepts (its decode span says it was received); (stamp_ns,
    its spans). A publish before the subscription is routed is lost: the next one is not.
    The bridge learns a peer's process name from its telemetry, once a second: this waits
    for exactly that."""
    async with asyncio.timeout(15.0):
        while True:
            stamp_ns = time.time_ns()
            for topic in peers:
                await pub.publish(topic, imu_msg(stamp_ns))

            def done(spans: list, stamp_ns: int = stamp_ns) -> bool:
                return complete(stamp_ns, spans)

            try:  # a publish before the subscription was routed never completes
                spans = await collect_spans(trace, done, timeout_s=1.0)
            except TimeoutError:
                continue
            named = {
                s.topic: s.peer for s in spans if s.stamp_ns == stamp_ns and s.stage == "fanout"
            }
            if named == peers:
                return stamp_ns, spans


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
            await sub.subscribe(*IMU)
            await pub.advertise(*IMU)

            def complete(stamp_ns: int, spans: list) -> bool:
                stages = {s.stage: s for s in spans if s.stamp_ns == stamp_ns}
                return set(stages) >= {"encode", "send", "bridge_in", "fanout", "decode"}

            # the bridge names a peer once its telemetry has announced the process: publish
            # until a message's fan-out names the subscriber (the condition, not a sleep)
            stamp_ns, spans = await publish_until_named(pub, trace, {IMU[0]: "sub"}, complete)
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
        await links.realtime.subscribe(*IMU)
        await links.bulk.subscribe(*fix)
        await pub.advertise(*IMU)
        await pub.advertise(*fix)

        def traced(stamp_ns: int, spans: list) -> bool:
            seen = {(s.topic, s.stage) for s in spans if s.stamp_ns == stamp_ns}
            return seen >= {(t, stage) for t in (IMU[0], fix[0]) for stage in ("fanout", "decode")}

        # both connections announce the process (once a second): until both fan-outs name it
        stamp_ns, spans = await publish_until_named(
            pub, trace, {IMU[0]: "watcher", fix[0]: "watcher"}, traced
        )
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
        batches: list = []

        def every_span_arrived() -> bool:
            batches.extend(
                b
                for b in (m.msg for m in _all(trace))
                if b["spans"] and b["spans"][0]["process"] == "often"
            )
            return sum(len(b["spans"]) for b in batches) >= 12

        await until(every_span_arrived, 8.0)  # the last batch goes out as telemetry stops
        announced = [m for m in (m.msg for m in _all(stats)) if m["process"] == "often"]
    assert len(batches) >= 6, len(batches)
    assert 1 <= len(announced) <= 3, len(announced)  # each second, and once more at the end
    assert sorted(s["stamp_ns"] for b in batches for s in b["spans"]) == list(range(12))


async def until(condition, timeout_s: float) -> None:
    async with asyncio.timeout(timeout_s):
        while not condition():
            await asyncio.sleep(0.02)


def _all(sub) -> list:
    items = []
    while (item := sub.get_nowait()) is not None:
        items.append(item)
    return items


async def stats_once_counted(client, topic: str, count: int) -> dict[str, Any]:
    """The stats service's answer once it counts ``count`` messages in on ``topic`` (the
    publishes are in flight until then: the condition, not a sleep)."""
    async with asyncio.timeout(5.0):
        while True:
            answer = await client.call_service(STATS_SERVICE, type=STATS_SERVICE_TYPE)
            if topic in answer["topics"]:
                seen = answer["messages_in"][answer["topics"].index(topic)]
                assert seen <= count, answer
                if seen == count:
                    return dict(answer)
            await asyncio.sleep(0.02)


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
            answer = await stats_once_counted(watcher, IMU[0], 3)
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
