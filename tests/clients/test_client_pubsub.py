"""Publish/subscribe through a real bridge, in JSON and in CBOR."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from clients import ConnectionClosed, ConnectionFailed, RosbridgeClient
from tests.clients.client_messages import imu, pointcloud, publish_until_received

ENCODINGS = ["json", "cbor"]


@pytest.mark.parametrize(
    ("encoding", "offload_bytes"),
    [("json", None), ("cbor", None), ("cbor", 64 * 1024)],
    ids=["json", "cbor", "cbor-worker-threads"],
)
async def test_pointcloud_4mb_arrives_byte_identical(
    bridge, make_client, registry, encoding, offload_bytes
):
    publisher = await make_client(
        bridge.url, encoding=encoding, name="sim", offload_bytes=offload_bytes
    )
    subscriber = await make_client(
        bridge.url, encoding=encoding, name="nav", offload_bytes=offload_bytes
    )
    await publisher.advertise("/lidar", "sensor_msgs/msg/PointCloud2")
    sub = await subscriber.subscribe("/lidar", "sensor_msgs/msg/PointCloud2")
    small = pointcloud(registry, 4)
    await publish_until_received(publisher, "/lidar", small, sub)

    cloud = pointcloud(registry, 262_144, seed=7)  # 4 MiB of XYZI float32
    assert len(cloud["data"]) == 4 * 1024 * 1024
    await publisher.publish("/lidar", cloud)
    got = await asyncio.wait_for(sub.get(), 20)
    while got.msg["width"] != cloud["width"]:
        got = await asyncio.wait_for(sub.get(), 20)
    assert got.msg["data"] == cloud["data"]
    assert got.msg["header"] == cloud["header"]
    assert got.msg["fields"] == cloud["fields"]
    assert got.wire_bytes >= len(cloud["data"])
    assert publisher.publish_stats("/lidar").sent >= 2


@pytest.mark.parametrize("encoding", ENCODINGS)
async def test_imu_with_covariances(bridge, make_client, registry, encoding):
    publisher = await make_client(bridge.url, encoding=encoding)
    subscriber = await make_client(bridge.url, encoding=encoding)
    await publisher.advertise("/imu", "sensor_msgs/Imu")
    sub = await subscriber.subscribe("/imu", "sensor_msgs/msg/Imu")
    sent = imu(registry)
    got = await publish_until_received(publisher, "/imu", sent, sub)
    assert got.topic == "/imu"
    for key in (
        "orientation_covariance",
        "angular_velocity_covariance",
        "linear_acceleration_covariance",
    ):
        assert got.msg[key] == pytest.approx(sent[key])
        assert isinstance(got.msg[key], list) and len(got.msg[key]) == 9
    assert got.msg["linear_acceleration"] == pytest.approx(sent["linear_acceleration"])
    assert got.msg["header"] == sent["header"]
    assert got.recv_ns > 0 and got.wire_bytes > 0


async def test_json_publisher_cbor_subscriber_interoperate(bridge, make_client, registry):
    publisher = await make_client(bridge.url, encoding="json")
    subscriber = await make_client(bridge.url, encoding="cbor")
    await publisher.advertise("/scan", "sensor_msgs/msg/LaserScan")
    sub = await subscriber.subscribe("/scan", "sensor_msgs/msg/LaserScan")
    ranges = np.linspace(1.0, 50.0, 360, dtype=np.float32)
    got = await publish_until_received(
        publisher, "/scan", {"ranges": ranges, "range_max": 80.0}, sub
    )
    assert got.msg["ranges"].dtype == np.float32
    np.testing.assert_array_equal(got.msg["ranges"], ranges)


async def test_untyped_subscription_and_numpy_views(bridge, make_client, registry):
    publisher = await make_client(bridge.url, encoding="cbor")
    subscriber = await make_client(bridge.url, encoding="cbor")
    await publisher.advertise("/lidar", "sensor_msgs/msg/PointCloud2")
    sub = await subscriber.subscribe("/lidar", bytes_as_numpy=True)
    cloud = pointcloud(registry, 1000)
    got = await publish_until_received(publisher, "/lidar", cloud, sub)
    points = got.msg["data"].view(np.float32).reshape(-1, 4)
    np.testing.assert_array_equal(points, np.frombuffer(cloud["data"], np.float32).reshape(-1, 4))


async def test_subscribe_before_the_publisher_exists(bridge, make_client, registry):
    subscriber = await make_client(bridge.url)
    sub = await subscriber.subscribe("/later", "std_msgs/msg/String")
    await asyncio.sleep(0.2)
    publisher = await make_client(bridge.url)
    await publisher.advertise("/later", "std_msgs/msg/String")
    got = await publish_until_received(publisher, "/later", {"data": "finally"}, sub)
    assert got.msg == {"data": "finally"}


async def test_unsubscribe_stops_delivery_and_ends_iteration(bridge, make_client):
    publisher = await make_client(bridge.url)
    subscriber = await make_client(bridge.url)
    await publisher.advertise("/chatter", "std_msgs/msg/String")
    sub = await subscriber.subscribe("/chatter", "std_msgs/msg/String")
    other = await subscriber.subscribe("/chatter", "std_msgs/msg/String")
    await publish_until_received(publisher, "/chatter", {"data": "a"}, sub)
    await sub.unsubscribe()
    leftovers = [item.msg async for item in sub]
    assert all(msg == {"data": "a"} for msg in leftovers)
    while other.get_nowait() is not None:
        pass
    await publisher.publish("/chatter", {"data": "b"})
    assert (await asyncio.wait_for(other.get(), 5)).msg == {"data": "b"}
    assert sub.qsize() == 0 and sub.closed


async def test_slow_consumer_drops_oldest_and_counts(bridge, make_client):
    publisher = await make_client(bridge.url)
    subscriber = await make_client(bridge.url)
    await publisher.advertise("/count", "std_msgs/msg/Int32")
    sub = await subscriber.subscribe("/count", "std_msgs/msg/Int32", maxsize=4)
    await publish_until_received(publisher, "/count", {"data": -1}, sub)
    while sub.get_nowait() is not None:
        pass
    received_before, dropped_before = sub.received, sub.dropped
    for n in range(40):  # the bridge delivers all 40 to a client that reads; its queue drops
        await publisher.publish("/count", {"data": n})
    async with asyncio.timeout(10):
        while sub.received < received_before + 40:
            await asyncio.sleep(0.01)
    assert sub.dropped - dropped_before == 40 - 4
    assert [(await sub.get()).msg["data"] for _ in range(4)] == [36, 37, 38, 39]


async def test_connect_times_out_without_a_bridge(unused_tcp_port):
    client = RosbridgeClient(f"ws://127.0.0.1:{unused_tcp_port}", connect_timeout=0.5)
    with pytest.raises(ConnectionFailed):
        await client.connect()
    await client.close()


async def test_registrations_made_before_connect_are_sent_on_connect(bridge, make_client, registry):
    early = RosbridgeClient(bridge.url, registry=registry)
    sub = await early.subscribe("/early", "std_msgs/msg/String")
    await early.advertise("/early_out", "std_msgs/msg/String")
    with pytest.raises(ConnectionClosed):
        await early.publish("/early_out", {"data": "too soon"})
    await early.connect()
    try:
        publisher = await make_client(bridge.url)
        await publisher.advertise("/early", "std_msgs/msg/String")
        got = await publish_until_received(publisher, "/early", {"data": "x"}, sub)
        assert got.msg == {"data": "x"}
        listener = await make_client(bridge.url)
        echo = await listener.subscribe("/early_out", "std_msgs/msg/String")
        assert (await publish_until_received(early, "/early_out", {"data": "y"}, echo)).msg == {
            "data": "y"
        }
    finally:
        await early.close()
