"""roslibjs 2.x (npm `roslib`, Node 20 with the `ws` transport) against `python -m bridge`.

Each test runs one scenario script from tests/compat/js under Node; the Python side of the
scenario (publisher, service provider, subscriber) is a plain websocket peer. A roslibjs
subscriber cannot tell Python when its subscription is in place, so the Python publisher
repeats its message until the script has reported.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any

import numpy as np
import pytest

from .bridge_process import BridgeEndpoint
from .messages import STAMP_NANOSEC, STAMP_SEC, imu, point_cloud
from .node_runner import publish_while_running, run_scenario
from .wire import WirePeer, wait_until_listed, wire_peer

N_CLOUD_POINTS = 10_000
EXPECTED_STAMP = {"sec": STAMP_SEC, "nanosec": STAMP_NANOSEC}


@pytest.mark.parametrize(("compression", "data_kind"), [("none", "string"), ("cbor", "Uint8Array")])
async def test_pointcloud2_points_decode_in_roslibjs(
    bridge: BridgeEndpoint, compression: str, data_kind: str
) -> None:
    cloud = point_cloud(N_CLOUD_POINTS)
    async with wire_peer(bridge.url) as publisher:
        result = await publish_while_running(
            publisher,
            "/compat/cloud",
            "sensor_msgs/msg/PointCloud2",
            cloud.message,
            "subscribe_pointcloud.mjs",
            bridge.url,
            "/compat/cloud",
            compression,
        )

    assert result["data_kind"] == data_kind
    assert result["byte_length"] == cloud.points.nbytes
    assert result["sha256"] == cloud.data_sha256
    assert result["n_points"] == N_CLOUD_POINTS
    assert result["header"] == {"stamp": EXPECTED_STAMP, "frame_id": "lidar"}
    assert result["fields"] == cloud.message["fields"]
    for key in ("height", "width", "point_step", "row_step", "is_dense", "is_bigendian"):
        assert result[key] == cloud.message[key], key
    for index, values in result["samples"].items():
        assert values == cloud.points[int(index)].tolist(), index
    sums = cloud.points.astype(np.float64).sum(axis=0)
    assert [result["sums"][name] for name in ("x", "y", "z", "intensity")] == pytest.approx(
        sums.tolist(), rel=1e-9, abs=1e-6
    )
    assert result["status_ops"] == []


@pytest.mark.parametrize("compression", ["none", "cbor"])
async def test_imu_fixed_size_covariances_reach_roslibjs(
    bridge: BridgeEndpoint, compression: str
) -> None:
    """rosbridge's CBOR encoder dropped messages with fixed-size arrays (#864/#965)."""
    published = imu()
    async with wire_peer(bridge.url) as publisher:
        result = await publish_while_running(
            publisher,
            "/compat/imu",
            "sensor_msgs/msg/Imu",
            published,
            "subscribe_imu.mjs",
            bridge.url,
            "/compat/imu",
            compression,
        )

    assert result["message"] == published
    assert set(result["covariance_kinds"].values()) == {"Array"}
    assert result["status_ops"] == []


async def serve_one_call(provider: WirePeer, service: str, reply: dict[str, Any]) -> dict:
    """Answer the next forwarded call of `service` with `reply`; return the forwarded call."""
    request = (await provider.expect_op("call_service", service=service)).message
    await provider.send(
        {"op": "service_response", "service": service, "id": request["id"], **reply}
    )
    return request


@pytest.mark.parametrize(
    ("reply", "outcome", "values"),
    [
        (
            {"values": {"success": True, "message": "pump on"}, "result": True},
            "success",
            {"success": True, "message": "pump on"},
        ),
        ({"values": "pump jammed", "result": False}, "failure", "pump jammed"),
    ],
    ids=["success", "failure"],
)
async def test_roslibjs_calls_service_provided_by_another_client(
    bridge: BridgeEndpoint, reply: dict[str, Any], outcome: str, values: Any
) -> None:
    service = "/compat/pump"
    async with wire_peer(bridge.url) as provider:
        await provider.send(
            {"op": "advertise_service", "type": "std_srvs/srv/SetBool", "service": service}
        )
        await wait_until_listed(provider, "/rosapi/services", "services", service)
        scenario = asyncio.create_task(
            asyncio.to_thread(
                run_scenario, "call_service.mjs", bridge.url, service, '{"data": true}'
            )
        )
        request = await serve_one_call(provider, service, reply)
        result = await scenario

    assert request["args"] == {"data": True}
    assert result["outcome"] == outcome
    assert result["values"] == values
    assert result["status_ops"] == []


def test_roslibjs_call_to_missing_service_gets_failed_callback_string(
    bridge: BridgeEndpoint,
) -> None:
    result = run_scenario("call_service.mjs", bridge.url, "/compat/nobody_home", "{}")
    assert result["outcome"] == "failure"
    assert isinstance(result["values"], str)
    assert "/compat/nobody_home" in result["values"] and "does not exist" in result["values"]


POSE_STAMPED_DECODED = {
    "header": {"stamp": {"sec": "int32", "nanosec": "uint32"}, "frame_id": "string"},
    "pose": {
        "position": {"x": "double", "y": "double", "z": "double"},
        "orientation": {"x": "double", "y": "double", "z": "double", "w": "double"},
    },
}


async def test_roslibjs_rosapi_helpers_with_relative_names(bridge: BridgeEndpoint) -> None:
    topic = "/compat/js_chatter"
    async with wire_peer(bridge.url) as publisher:
        await publisher.send({"op": "advertise", "topic": topic, "type": "std_msgs/msg/String"})
        await wait_until_listed(publisher, "/rosapi/topics", "topics", topic)
        result = await asyncio.to_thread(
            run_scenario, "rosapi.mjs", bridge.url, topic, "geometry_msgs/PoseStamped"
        )

    listed = dict(zip(result["topics"]["topics"], result["topics"]["types"], strict=True))
    assert listed[topic] == "std_msgs/msg/String"
    assert listed["/rosout"] == "rcl_interfaces/msg/Log"
    assert result["topic_type"] == "std_msgs/msg/String"
    assert "/rosapi/topics" in result["services"]
    assert result["nodes"] and all(node.startswith("/") for node in result["nodes"])
    assert result["typedefs"][0]["type"] == "geometry_msgs/PoseStamped"
    assert result["decoded"] == POSE_STAMPED_DECODED
    assert result["decode_errors"] == []
    assert result["status_ops"] == []


async def test_roslibjs_publish_reaches_python_subscriber(bridge: BridgeEndpoint) -> None:
    topic, count = "/compat/from_js", 20
    async with wire_peer(bridge.url) as subscriber:
        await subscriber.send(
            {"op": "subscribe", "id": "sub:from_js", "topic": topic, "type": "std_msgs/msg/String"}
        )
        await subscriber.call_service("/rosapi/get_time")
        result = await asyncio.to_thread(run_scenario, "publish.mjs", bridge.url, topic, str(count))
        frames = [await subscriber.expect_op("publish", topic=topic) for _ in range(count)]

    assert [frame.message["msg"]["data"] for frame in frames] == result["sent"]
    assert all(isinstance(frame.raw, str) and frame.raw.isascii() for frame in frames)
    assert "barrier_error" not in result
    assert result["status_ops"] == []


def test_roslibjs_params_set_get_list_delete(bridge: BridgeEndpoint) -> None:
    name = "/compat_node:route"
    value = {"waypoints": [[51.9, 4.4], [51.8, 4.6]], "name": "Waal"}
    result = run_scenario("params.mjs", bridge.url, name, json.dumps(value))

    assert result["got"] == value
    assert name in result["names"]
    assert name not in result["names_after_delete"]
    assert result["status_ops"] == []


def test_two_roslibjs_topic_objects_on_one_connection(bridge: BridgeEndpoint) -> None:
    result = run_scenario("two_topics.mjs", bridge.url, "/compat/js_twice")

    def without_probes(received: list[str]) -> list[str]:
        return [data for data in received if data != "probe"]

    assert without_probes(result["first"]) == ["one", "two", "three"]
    assert without_probes(result["second"]) == ["one", "two", "three", "four"]
    assert result["status_ops"] == []


async def test_png_compressed_subscription_decodes_in_roslibjs(bridge: BridgeEndpoint) -> None:
    published = {"data": "Binnenschiff Rhein km 863 – Pegel 3,12 m"}
    async with wire_peer(bridge.url) as publisher:
        result = await publish_while_running(
            publisher,
            "/compat/png_text",
            "std_msgs/msg/String",
            published,
            "subscribe_first.mjs",
            bridge.url,
            "/compat/png_text",
            "std_msgs/msg/String",
            "png",
        )

    assert result["message"] == published
    assert result["status_ops"] == []
