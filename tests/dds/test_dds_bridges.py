"""Two bridges in one DDS domain on the loopback: topics both ways exactly once, rosapi of
one listing the other's graph, services across, latched topics, QoS and raw CDR."""

from __future__ import annotations

import asyncio
import contextlib
import json
from collections import Counter

import pytest
import websockets

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from clients.errors import ServiceError
from schemas import codec_cbor
from schemas.codec_cdr import to_cdr
from schemas.message import normalize
from tests.receiving import collect, drain

pytestmark = pytest.mark.slow

DISCOVERY_TIMEOUT_S = 20.0


@contextlib.asynccontextmanager
async def two_bridges(domain: int):
    config = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=domain)
    async with run_bridge(config) as a, run_bridge(config) as b:
        yield a, b


async def until(predicate, timeout_s: float = DISCOVERY_TIMEOUT_S, every_s: float = 0.1):
    """Poll an async predicate until it returns something truthy; returns that."""
    async with asyncio.timeout(timeout_s):
        while not (result := await predicate()):
            await asyncio.sleep(every_s)
    return result


async def test_topics_cross_once_each_way_and_never_echo(dds_domain, registry):
    async with (
        two_bridges(dds_domain) as (a, b),
        RosbridgeClient(a.url, registry=registry) as on_a,
        RosbridgeClient(b.url, registry=registry) as on_b,
    ):
        for client in (on_a, on_b):
            await client.advertise("/chatter", "std_msgs/msg/String")
        heard_a = await on_a.subscribe("/chatter", "std_msgs/msg/String", maxsize=1000)
        heard_b = await on_b.subscribe("/chatter", "std_msgs/msg/String", maxsize=1000)

        async def crossed() -> bool:  # both directions discovered: a probe gets across
            await on_a.publish("/chatter", {"data": "probe"})
            await on_b.publish("/chatter", {"data": "probe"})
            return await drain_until_probe(heard_a) and await drain_until_probe(heard_b)

        await until(crossed, every_s=0.05)
        await drain(heard_a, 0.3)
        await drain(heard_b, 0.3)
        for n in range(20):  # paced: a burst may overflow a client's send queue (16)
            await on_a.publish("/chatter", {"data": f"a{n}"})
            await on_b.publish("/chatter", {"data": f"b{n}"})
            await asyncio.sleep(0.01)
        got_a = [m["data"] for m in await collect(heard_a, 40, grace_s=0.3)]
        got_b = [m["data"] for m in await collect(heard_b, 40, grace_s=0.3)]
    expected = Counter({f"{side}{n}": 1 for side in "ab" for n in range(20)})
    assert Counter(got_a) == expected  # its own once (locally), the other's once (over DDS)
    assert Counter(got_b) == expected
    assert [d for d in got_a if d[0] == "b"] == [f"b{n}" for n in range(20)]  # in order
    assert [d for d in got_b if d[0] == "a"] == [f"a{n}" for n in range(20)]


async def drain_until_probe(sub) -> bool:
    return any(m["data"] == "probe" for m in await drain(sub, 0.2))


async def test_rosapi_of_one_bridge_lists_the_other_bridges_graph(dds_domain, registry):
    async with (
        two_bridges(dds_domain) as (a, b),
        RosbridgeClient(a.url, registry=registry) as on_a,
        RosbridgeClient(b.url, registry=registry) as on_b,
    ):
        await on_a.advertise("/sonar", "sensor_msgs/msg/Range")
        await on_a.subscribe("/cmd_wrench", "geometry_msgs/msg/Wrench")
        node_a = a.dds.node

        async def listed():
            topics = await on_b.call_service("/rosapi/topics")
            return "/sonar" in topics["topics"] and "/cmd_wrench" in topics["topics"] and topics

        topics = await until(listed)
        raw = await on_b.call_service("/rosapi/topics_and_raw_types")
        nodes = await on_b.call_service("/rosapi/nodes")
        publishers = await on_b.call_service("/rosapi/publishers", {"topic": "/sonar"})
        subscribers = await on_b.call_service("/rosapi/subscribers", {"topic": "/cmd_wrench"})
        details = await on_b.call_service("/rosapi/node_details", {"node": node_a})
        # A client of B subscribes without naming the type: the graph knows it from DDS.
        ranges = await on_b.subscribe("/sonar")
        await until(lambda: on_b_reads(a, "/sonar"))
        await on_a.publish("/sonar", {"range": 4.5, "max_range": 10.0})
        first = await drain_first(ranges)
    sonar = topics["topics"].index("/sonar")
    assert topics["types"][sonar] == "sensor_msgs/msg/Range"
    assert "float32 max_range" in raw["typedefs_full_text"][raw["topics"].index("/sonar")]
    assert node_a in nodes["nodes"]
    assert publishers["publishers"] == [node_a]
    assert node_a in subscribers["subscribers"]
    assert details["publishing"] == ["/sonar"] and "/cmd_wrench" in details["subscribing"]
    assert first["range"] == 4.5


async def on_b_reads(a, topic: str) -> bool:
    """A's mirror sees a DDS reader of `topic` (B made it for its subscriber)."""
    seen = a.dds.view.topics().get(topic)
    return seen is not None and bool(seen.subscribers)


async def drain_first(sub, timeout_s: float = 10.0) -> dict:
    async with asyncio.timeout(timeout_s):
        async for item in sub:
            return item.msg
    raise AssertionError("no message")


async def test_a_service_provided_on_one_bridge_answers_calls_made_on_the_other(
    dds_domain, registry
):
    async with (
        two_bridges(dds_domain) as (a, b),
        RosbridgeClient(a.url, registry=registry) as caller,
        RosbridgeClient(b.url, registry=registry) as provider,
    ):
        requests = []

        async def gate(args):
            requests.append(args)
            state = "open" if args["data"] else "shut"
            return {"success": args["data"], "message": f"gate {state}"}

        await provider.advertise_service("/lock_gate", "std_srvs/srv/SetBool", gate)

        async def answered():
            with contextlib.suppress(ServiceError):
                return await caller.call_service("/lock_gate", {"data": True})
            return None

        first = await until(answered)
        second = await caller.call_service(
            "/lock_gate", {"data": False}, type="std_srvs/srv/SetBool"
        )
        provider_node = (
            await caller.call_service("/rosapi/service_node", {"service": "/lock_gate"})
        )["node"]
        await provider.unadvertise_service("/lock_gate")

        async def withdrawn():
            try:
                await caller.call_service("/lock_gate", {"data": True}, timeout=2.0)
            except ServiceError as exc:
                return "does not exist" in str(exc)
            return False

        assert await until(withdrawn)
    assert first == {"success": True, "message": "gate open"}
    assert second == {"success": False, "message": "gate shut"}
    assert provider_node == b.dds.node
    assert requests[:2] == [{"data": True}, {"data": False}]


async def test_latched_topic_reaches_a_late_subscriber_of_the_other_bridge(dds_domain, registry):
    async with (
        two_bridges(dds_domain) as (a, b),
        RosbridgeClient(a.url, registry=registry) as on_a,
        RosbridgeClient(b.url, registry=registry) as on_b,
    ):
        await on_a.advertise("/map_origin", "geometry_msgs/msg/Point", latch=True)
        await on_a.publish("/map_origin", {"x": 1.0, "y": 2.0, "z": 3.0})

        async def discovered():
            return "/map_origin" in (await on_b.call_service("/rosapi/topics"))["topics"]

        await until(discovered)
        late = await on_b.subscribe("/map_origin", "geometry_msgs/msg/Point")
        first = await drain_first(late)
        profile = b.dds.view.topics()["/map_origin"].publishers[a.dds.node][0]
    assert first == {"x": 1.0, "y": 2.0, "z": 3.0}
    assert profile.transient_local and profile.depth == 1


async def test_best_effort_qos_from_advertise_and_cdr_through_cbor_raw(dds_domain, registry):
    imu = {
        "header": {"stamp": {"sec": 5, "nanosec": 6}, "frame_id": "imu"},
        "linear_acceleration": {"x": 0.0, "y": 0.0, "z": 9.81},
    }
    async with (
        two_bridges(dds_domain) as (a, b),
        websockets.connect(a.url) as publisher,
        websockets.connect(b.url) as subscriber,
    ):
        await publisher.send(
            json.dumps(
                {
                    "op": "advertise",
                    "topic": "/imu/data",
                    "type": "sensor_msgs/msg/Imu",
                    "qos": {"reliability": "best_effort", "depth": 5},
                }
            )
        )
        await subscriber.send(
            json.dumps(
                {
                    "op": "subscribe",
                    "topic": "/imu/data",
                    "type": "sensor_msgs/msg/Imu",
                    "compression": "cbor-raw",
                }
            )
        )

        async def arrived():
            await publisher.send(json.dumps({"op": "publish", "topic": "/imu/data", "msg": imu}))
            with contextlib.suppress(TimeoutError):
                return await asyncio.wait_for(subscriber.recv(), 0.2)
            return None

        frame = await until(arrived)
        offered = b.dds.view.topics()["/imu/data"].publishers[a.dds.node][0]
        reader = b.dds.topics.readers["/imu/data"].wanted.profile
    message = codec_cbor.loads(frame)
    spec = registry.message("sensor_msgs/msg/Imu")
    assert message["msg"]["bytes"] == to_cdr(registry, spec.name, normalize(spec, imu, now_ns=0))
    assert not offered.reliable and offered.depth == 5
    assert not reader.reliable  # adapted to the best-effort writer
