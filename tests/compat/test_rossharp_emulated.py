"""An emulation of ROS#'s (siemens/ros-sharp) wire habits against the bridge.

ROS# is a .NET library and .NET does not run here, so these tests are not ROS# itself: a raw
websocket peer sends and reads frames the way ROS#'s source and docs (reference/
rosbridge-clients.md) say it does, and each test checks the bridge copes with that habit.

ROS# serializes with System.Text.Json and sends every op as JSON in BINARY websocket frames,
split into 1024-byte continuation fragments, with the op-specific fields first and `op`, `id`
last; it adds `fragment_size: 2147483647` ("never fragment") to subscribe and call_service and
`"id": null` to advertise_service. It decodes replies as ASCII and is strict about integers.
"""

from __future__ import annotations

import json
from typing import Any

from .bridge_process import BridgeEndpoint
from .messages import STAMP_NANOSEC, STAMP_SEC, imu
from .wire import WirePeer, wait_until_listed, wire_peer

ROSSHARP_FRAGMENT_BYTES = 1024
NEVER_FRAGMENT = 2_147_483_647


async def send_like_rossharp(peer: WirePeer, fields: dict[str, Any], op: str, op_id: Any) -> None:
    """Op-specific fields first, then op and id; binary frames of 1024-byte fragments."""
    text = json.dumps({**fields, "op": op, "id": op_id}, separators=(",", ":"))
    await peer.send_fragmented_binary(text, ROSSHARP_FRAGMENT_BYTES)


def assert_plain_json_text(raw: str | bytes) -> None:
    """What ROS# can read: one unfragmented JSON text message, ASCII only."""
    assert isinstance(raw, str), "replies to a JSON client must be text frames"
    assert raw.isascii(), "ROS# decodes with Encoding.ASCII: non-ASCII must be \\u-escaped"
    assert json.loads(raw)["op"] != "fragment"


async def test_emulated_rossharp_subscribes_and_calls_in_fragmented_binary_frames(
    bridge: BridgeEndpoint,
) -> None:
    topic = "/compat/rs_imu"
    published = imu(frame_id="imu_Ölhafen")
    async with wire_peer(bridge.url) as unity, wire_peer(bridge.url) as publisher:
        await send_like_rossharp(
            unity,
            {
                "topic": topic,
                "type": "sensor_msgs/msg/Imu",
                "throttle_rate": 0,
                "queue_length": 1,
                "fragment_size": NEVER_FRAGMENT,
                "compression": "none",
            },
            "subscribe",
            f"{topic}:1",
        )
        await send_like_rossharp(
            unity,
            {
                "service": "/rosapi/get_ros_version",
                "args": {},
                "fragment_size": NEVER_FRAGMENT,
                "compression": "none",
            },
            "call_service",
            "/rosapi/get_ros_version:2",
        )
        version = await unity.expect_op("service_response", id="/rosapi/get_ros_version:2")
        await publisher.send({"op": "publish", "topic": topic, "msg": published})
        frame = await unity.expect_op("publish", topic=topic)

    assert_plain_json_text(version.raw)
    assert version.message["result"] is True
    assert version.message["values"]["version"] == 2
    assert isinstance(version.message["values"]["distro"], str)
    assert_plain_json_text(frame.raw)
    assert frame.message["msg"] == published
    stamp = frame.message["msg"]["header"]["stamp"]
    assert stamp == {"sec": STAMP_SEC, "nanosec": STAMP_NANOSEC}
    assert all(type(value) is int for value in stamp.values()), "integers must be int literals"
    assert "status" not in unity.received_ops()


async def test_emulated_rossharp_advertises_and_publishes_in_fragmented_binary_frames(
    bridge: BridgeEndpoint,
) -> None:
    topic = "/compat/rs_log"
    long_text = "Schleuse Dörverden: " + "wait " * 600  # ~3 kB: several 1024-byte fragments
    async with wire_peer(bridge.url) as listener, wire_peer(bridge.url) as unity:
        await listener.send(
            {"op": "subscribe", "id": "sub:rs_log", "topic": topic, "type": "std_msgs/msg/String"}
        )
        await listener.call_service("/rosapi/get_time")
        await send_like_rossharp(
            unity, {"topic": topic, "type": "std_msgs/msg/String"}, "advertise", topic
        )
        await send_like_rossharp(
            unity, {"topic": topic, "msg": {"data": long_text}}, "publish", topic
        )
        frame = await listener.expect_op("publish", topic=topic)

    assert frame.message["msg"] == {"data": long_text}


async def test_emulated_rossharp_service_provider_with_null_id(bridge: BridgeEndpoint) -> None:
    service = "/compat/rs_trigger"
    async with wire_peer(bridge.url) as unity, wire_peer(bridge.url) as caller:
        await send_like_rossharp(
            unity, {"type": "std_srvs/srv/Trigger", "service": service}, "advertise_service", None
        )
        await wait_until_listed(caller, "/rosapi/services", "services", service)
        call_id = caller.next_id(f"call_service:{service}")
        await caller.send({"op": "call_service", "id": call_id, "service": service, "args": {}})
        request = await unity.expect_op("call_service", service=service)
        assert_plain_json_text(request.raw)
        await send_like_rossharp(
            unity,
            {
                "service": service,
                "values": {"success": True, "message": "Unity says hi"},
                "result": True,
            },
            "service_response",
            request.message["id"],
        )
        response = await caller.expect_op("service_response", id=call_id)

    assert response.message["result"] is True
    assert response.message["values"] == {"success": True, "message": "Unity says hi"}


async def test_emulated_rossharp_get_param_with_ros2_default_value(bridge: BridgeEndpoint) -> None:
    """ROS#'s ROS 2 GetParam request is {name, default_value}; values are JSON text."""
    async with wire_peer(bridge.url) as unity:
        await send_like_rossharp(
            unity,
            {"service": "/rosapi/get_param",
             "args": {"name": "/compat_node:robot_description", "default_value": '"<robot/>"'},
             "fragment_size": NEVER_FRAGMENT, "compression": "none"},
            "call_service", "/rosapi/get_param:1",
        )  # fmt: skip
        reply = await unity.expect_op("service_response", id="/rosapi/get_param:1")

    assert_plain_json_text(reply.raw)
    assert reply.message["result"] is True
    assert json.loads(reply.message["values"]["value"]) == "<robot/>"
