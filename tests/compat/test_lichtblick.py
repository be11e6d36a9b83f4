"""Lichtblick / Foxglove rosbridge player, reproduced frame by frame (it is an app, not a
library): topic discovery through `/rosapi/topics_and_raw_types` with a ROS 1 style `type`,
ROS 2 detection from `/rosout`, and `cbor-raw` subscriptions without a type whose CDR bytes
the player deserializes itself. rosbags plays the player's CDR reader here.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from .bridge_process import BridgeEndpoint
from .messages import STAMP_NANOSEC, STAMP_SEC, imu, point_cloud
from .node_runner import publish_while_running
from .wire import WirePeer, wire_peer

SEPARATOR = "=" * 80
# CDR encapsulation header: representation identifier CDR_LE (0x0001), options 0.
CDR_LE_HEADER = b"\x00\x01\x00\x00"


def definition_sections(full_text: str) -> list[tuple[str | None, list[str]]]:
    """Split a gendeps-style text into (dependency name or None for the top type, field names).

    Constants (`byte DEBUG=10`) and comments are not fields.
    """
    sections = []
    for block in full_text.split(f"\n{SEPARATOR}\n"):
        lines = [line.split("#", 1)[0].strip() for line in block.strip("\n").split("\n")]
        name = None
        if lines and lines[0].startswith("MSG: "):
            name, lines = lines[0].removeprefix("MSG: ").strip(), lines[1:]
        fields = [line.split()[1] for line in lines if line and "=" not in line.split()[1]]
        sections.append((name, fields))
    return sections


async def discover(studio: WirePeer) -> dict[str, tuple[str, str]]:
    """The player's discovery call, exactly as it sends it; returns {topic: (type, text)}."""
    response = await studio.call_service(
        "/rosapi/topics_and_raw_types", {}, type="rosapi/TopicsAndRawTypes"
    )
    assert response["result"] is True, response
    values = response["values"]
    assert len(values["topics"]) == len(values["types"]) == len(values["typedefs_full_text"])
    return {
        topic: (type_name, text)
        for topic, type_name, text in zip(
            values["topics"], values["types"], values["typedefs_full_text"], strict=True
        )
    }


async def advertise(publisher: WirePeer, topic: str, type_name: str) -> None:
    await publisher.send(
        {
            "op": "advertise",
            "id": publisher.next_id("advertise"),
            "topic": topic,
            "type": type_name,
            "latch": False,
            "queue_size": 100,
        }
    )
    await publisher.call_service("/rosapi/get_time")


async def test_discovery_detects_ros2_and_serves_gendeps_definitions(
    bridge: BridgeEndpoint,
) -> None:
    async with wire_peer(bridge.url) as publisher, wire_peer(bridge.url) as studio:
        await advertise(publisher, "/compat/imu", "sensor_msgs/msg/Imu")
        catalogue = await discover(studio)

    rosout_type, rosout_text = catalogue["/rosout"]
    assert rosout_type == "rcl_interfaces/msg/Log"
    (_, log_fields), *_ = definition_sections(rosout_text)
    assert {"stamp", "level", "name", "msg", "file", "function", "line"} <= set(log_fields)

    imu_type, imu_text = catalogue["/compat/imu"]
    assert imu_type == "sensor_msgs/msg/Imu"
    (top_name, top_fields), *dependencies = definition_sections(imu_text)
    assert top_name is None
    assert top_fields == [
        "header",
        "orientation",
        "orientation_covariance",
        "angular_velocity",
        "angular_velocity_covariance",
        "linear_acceleration",
        "linear_acceleration_covariance",
    ]
    dependency_names = {name for name, _ in dependencies}
    assert {"std_msgs/Header", "geometry_msgs/Quaternion", "geometry_msgs/Vector3"} <= (
        dependency_names
    )
    assert all(name and "/msg/" not in name for name in dependency_names), dependency_names
    assert dict(dependencies)["geometry_msgs/Quaternion"] == ["x", "y", "z", "w"]


async def test_node_graph_queries_answer_for_every_node(bridge: BridgeEndpoint) -> None:
    async with wire_peer(bridge.url) as publisher, wire_peer(bridge.url) as studio:
        await advertise(publisher, "/compat/imu", "sensor_msgs/msg/Imu")
        nodes = await studio.call_service("/rosapi/nodes")
        assert nodes["result"] is True and nodes["values"]["nodes"], nodes
        details = [
            await studio.call_service("/rosapi/node_details", {"node": node})
            for node in nodes["values"]["nodes"]
        ]

    assert all(detail["result"] is True for detail in details), details
    assert any("/compat/imu" in detail["values"]["publishing"] for detail in details), details


def assert_imu_matches(decoded: Any, published: dict[str, Any]) -> None:
    assert decoded.header.stamp.sec == STAMP_SEC
    assert decoded.header.stamp.nanosec == STAMP_NANOSEC
    assert decoded.header.frame_id == published["header"]["frame_id"]
    for part in ("orientation", "angular_velocity", "linear_acceleration"):
        for axis, value in published[part].items():
            assert getattr(getattr(decoded, part), axis) == value, (part, axis)
        covariance = getattr(decoded, f"{part}_covariance")
        np.testing.assert_array_equal(covariance, published[f"{part}_covariance"])


def assert_cloud_matches(decoded: Any, published: dict[str, Any], points: np.ndarray) -> None:
    assert decoded.header.stamp.sec == STAMP_SEC
    assert decoded.width == points.shape[0] and decoded.height == 1
    assert [field.name for field in decoded.fields] == ["x", "y", "z", "intensity"]
    assert decoded.point_step == published["point_step"]
    np.testing.assert_array_equal(
        np.frombuffer(decoded.data.tobytes(), dtype="<f4").reshape(-1, 4), points
    )


@pytest.mark.parametrize("kind", ["imu", "pointcloud2"])
async def test_cbor_raw_subscription_without_type_carries_cdr(
    bridge: BridgeEndpoint, kind: str
) -> None:
    cloud = point_cloud(10_000)
    topic, type_name, published = {
        "imu": ("/compat/imu", "sensor_msgs/msg/Imu", imu()),
        "pointcloud2": ("/compat/cloud", "sensor_msgs/msg/PointCloud2", cloud.message),
    }[kind]
    async with wire_peer(bridge.url) as publisher, wire_peer(bridge.url) as studio:
        await advertise(publisher, topic, type_name)
        assert (await discover(studio))[topic][0] == type_name
        await studio.send(
            {
                "op": "subscribe",
                "id": f"subscribe:{topic}:2",
                "topic": topic,
                "compression": "cbor-raw",
                "throttle_rate": 0,
                "queue_length": 0,
            }
        )
        await studio.call_service("/rosapi/get_time")
        await publisher.send(
            {
                "op": "publish",
                "id": publisher.next_id("publish"),
                "topic": topic,
                "msg": published,
                "latch": False,
            }
        )
        frame = await studio.expect_op("publish", topic=topic)

    assert frame.binary, "cbor-raw must arrive in a binary frame"
    raw = frame.message["msg"]
    assert isinstance(raw["secs"], int) and isinstance(raw["nsecs"], int)
    assert isinstance(raw["bytes"], bytes) and raw["bytes"][:4] == CDR_LE_HEADER
    decoded = get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(raw["bytes"], type_name)
    if kind == "imu":
        assert_imu_matches(decoded, published)
    else:
        assert_cloud_matches(decoded, published, cloud.points)


async def test_lichtblick_libraries_decode_cbor_raw_imu(bridge: BridgeEndpoint) -> None:
    """The player's own libraries under Node: the roslibjs fork discovers and subscribes,
    @lichtblick/rosmsg parses the definition text, @lichtblick/rosmsg2-serialization reads
    the CDR bytes."""
    published = imu()
    async with wire_peer(bridge.url) as publisher:
        result = await publish_while_running(
            publisher,
            "/compat/imu",
            "sensor_msgs/msg/Imu",
            published,
            "lichtblick_player.mjs",
            bridge.url,
            "/compat/imu",
        )

    assert result["ros_version"] == 2
    assert result["topic_type"] == "sensor_msgs/msg/Imu"
    assert {"std_msgs/Header", "geometry_msgs/Quaternion"} <= set(result["definition_names"])
    assert result["raw_keys"] == ["bytes", "nsecs", "secs"]
    message = result["message"]
    stamp = message["header"]["stamp"]
    # A `time` field reads as {sec, nsec}; builtin_interfaces/Time as {sec, nanosec}.
    assert (stamp["sec"], stamp.get("nanosec", stamp.get("nsec"))) == (STAMP_SEC, STAMP_NANOSEC)
    assert message["header"]["frame_id"] == published["header"]["frame_id"]
    for key in ("orientation", "angular_velocity", "linear_acceleration"):
        assert message[key] == published[key], key
        assert message[f"{key}_covariance"] == published[f"{key}_covariance"], key


async def test_cbor_raw_json_and_cbor_subscribers_share_a_topic(bridge: BridgeEndpoint) -> None:
    """Lichtblick (cbor-raw) next to a dashboard (JSON) and a CBOR client on one topic:
    rosbridge broke here because the first subscriber fixed the raw flag (issue #610)."""
    topic, published = "/compat/imu", imu()
    async with (
        wire_peer(bridge.url) as publisher,
        wire_peer(bridge.url) as dashboard,
        wire_peer(bridge.url) as studio,
        wire_peer(bridge.url) as cbor_client,
    ):
        await advertise(publisher, topic, "sensor_msgs/msg/Imu")
        for peer, compression in ((dashboard, "none"), (studio, "cbor-raw"), (cbor_client, "cbor")):
            await peer.send(
                {
                    "op": "subscribe",
                    "id": f"{compression}:1",
                    "topic": topic,
                    "compression": compression,
                }
            )
            await peer.call_service("/rosapi/get_time")
        await publisher.send({"op": "publish", "topic": topic, "msg": published})
        as_json = await dashboard.expect_op("publish", topic=topic)
        as_raw = await studio.expect_op("publish", topic=topic)
        as_cbor = await cbor_client.expect_op("publish", topic=topic)

    assert not as_json.binary and as_json.message["msg"] == published
    assert as_cbor.binary and as_cbor.message["msg"] == published
    assert as_raw.binary
    decoded = get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(
        as_raw.message["msg"]["bytes"], "sensor_msgs/msg/Imu"
    )
    assert_imu_matches(decoded, published)
