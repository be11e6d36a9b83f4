"""Foxglove's `FoxgloveClient` (npm `@foxglove/ws-protocol`) and roslibpy on one bridge port.

The Node scenario (js/foxglove_session.mjs) speaks `foxglove.websocket.v1` and decodes CDR
with `@foxglove/cdr`; roslibpy, on the same port without a subprotocol, publishes what the
Foxglove client subscribes to, subscribes to what it publishes and sets a parameter it
watches: both protocols see one graph.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import roslibpy

from . import roslibpy_support as rp
from .bridge_process import BridgeEndpoint, running_bridge
from .conftest import assert_bridge_survived
from .messages import STAMP_NANOSEC, STAMP_SEC, imu
from .node_runner import run_scenario
from .wire import wait_until_listed, wire_peer

IMU_TOPIC = "/compat/fg_imu"
WRENCH_TOPIC = "/compat/fg_wrench"
MESH = "solid riverbridge\nendsolid riverbridge\n"


@pytest.fixture
def asset_bridge(tmp_path: Path) -> Iterator[tuple[BridgeEndpoint, str]]:
    """A bridge serving the folder `meshes` (one STL) to Foxglove clients."""
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "buoy.stl").write_text(MESH)
    (tmp_path / "secret.stl").write_text("outside the allow-list")
    with running_bridge(["--asset-dir", str(meshes)]) as endpoint:
        yield endpoint, "package://meshes/buoy.stl"
        assert_bridge_survived(endpoint)


def roslibpy_side(ros: roslibpy.Ros, done: threading.Event, wrenches: rp.Inbox) -> None:
    """Publish the IMU and set a parameter until the Foxglove scenario is over."""
    publisher = roslibpy.Topic(ros, IMU_TOPIC, "sensor_msgs/msg/Imu")
    publisher.advertise()
    roslibpy.Topic(ros, WRENCH_TOPIC, "geometry_msgs/msg/Wrench").subscribe(wrenches)
    value = 0
    while not done.wait(0.2):
        publisher.publish(roslibpy.Message(imu()))
        value += 1
        rp.call_service(ros, "/rosapi/set_param", {"name": "/compat:from_ros", "value": str(value)})


async def test_foxglove_client_and_roslibpy_share_the_graph(
    asset_bridge: tuple[BridgeEndpoint, str], log_trap: rp.LogTrap
) -> None:
    bridge, asset_uri = asset_bridge
    wrenches, done = rp.Inbox(), threading.Event()
    with rp.connected(bridge.host, bridge.port) as ros:
        side = asyncio.create_task(asyncio.to_thread(roslibpy_side, ros, done, wrenches))
        try:
            result = await asyncio.to_thread(
                run_scenario,
                "foxglove_session.mjs",
                bridge.url,
                IMU_TOPIC,
                WRENCH_TOPIC,
                asset_uri,
            )
        finally:
            done.set()
            await side
        answer = rp.call_service(ros, "/rosapi/get_param", {"name": "/compat:answer"})

    assert result["protocol"] == "foxglove.websocket.v1"
    assert result["errors"] == []
    info = result["serverInfo"]
    assert {"clientPublish", "parameters", "parametersSubscribe", "services"} <= set(
        info["capabilities"]
    )
    assert {"connectionGraph", "assets"} <= set(info["capabilities"])

    channel = result["channels"][IMU_TOPIC]
    assert channel["encoding"] == "cdr"
    assert channel["schemaName"] == "sensor_msgs/msg/Imu"
    assert channel["schemaEncoding"] == "ros2msg"
    assert "MSG: geometry_msgs/Quaternion" in channel["schema"]

    decoded = result["decoded"]  # the CDR, decoded by @foxglove/cdr along the schema
    sent = imu()
    assert decoded["header"] == {
        "stamp": {"sec": STAMP_SEC, "nanosec": STAMP_NANOSEC},
        "frame_id": sent["header"]["frame_id"],
    }
    assert decoded["orientation"] == sent["orientation"]
    assert decoded["linear_acceleration_covariance"] == sent["linear_acceleration_covariance"]
    assert int(result["timestamp"]) > STAMP_SEC * 10**9  # when it entered the bridge

    messages = [status["message"] for status in result["statuses"]]
    assert all(status["level"] == 2 for status in result["statuses"][:5])
    assert any("not JSON" in m for m in messages)
    assert any("unknown op: 'frobnicate'" in m for m in messages)
    assert any("unknown binary opcode 9" in m for m in messages)
    assert any("unknown channel 987654" in m for m in messages)
    assert any("unknown client channel 4242" in m for m in messages)

    received = wrenches.expect(1)
    assert received[0] == {
        "force": {"x": 120.5, "y": 0.0, "z": 0.0},
        "torque": {"x": 0.0, "y": 0.0, "z": -7.25},
    }

    service = result["services"]["/rosapi/get_time"]
    assert service["type"] == "rosapi_msgs/srv/GetTime"
    assert service["request"]["schemaEncoding"] == "ros2msg"
    assert result["serviceResponse"]["time"]["sec"] > STAMP_SEC
    assert "unknown service 123456" in result["serviceFailure"]["message"]

    set_values = {p["name"]: p["value"] for p in result["setReply"]["parameters"]}
    assert set_values == {"/compat:answer": 42, "/compat:list": [1.5, 2.5]}
    get_values = {p["name"]: p["value"] for p in result["getReply"]["parameters"]}
    assert get_values == set_values
    update = {p["name"]: p["value"] for p in result["update"]["parameters"]}
    assert isinstance(update["/compat:from_ros"], int)
    assert answer.value["value"] == "42"  # what the Foxglove client set, read by roslibpy

    graph = result["graph"]
    published = {t["name"]: t["publisherIds"] for t in graph["publishedTopics"]}
    assert IMU_TOPIC in published and WRENCH_TOPIC in published
    assert "/rosapi/get_time" not in {s["name"] for s in graph["advertisedServices"]}

    assert result["assetOk"] == {"status": 0, "text": MESH}
    assert result["assetRefused"]["status"] == 1
    assert "package://" in result["assetRefused"]["error"]


async def test_foxglove_parameters_of_a_node_that_does_not_answer() -> None:
    """`/silent.x` is a node's parameter (its `get_parameters` is in the graph) whose
    services never answer: the Foxglove client gets its reply without it after the bridge's
    call timeout and a status naming the failure, for the get and the set; a value no ROS 2
    parameter can hold is refused at once. The bridge keeps serving."""
    with running_bridge(["--call-timeout", "1"]) as bridge:
        async with wire_peer(bridge.url) as silent:
            for service in ("get_parameters", "set_parameters"):
                await silent.send(
                    {
                        "op": "advertise_service",
                        "service": f"/silent/{service}",
                        "type": f"rcl_interfaces/srv/{service.title().replace('_', '')}",
                    }
                )
            await wait_until_listed(
                silent, "/rosapi/services", "services", "/silent/set_parameters"
            )
            result = await asyncio.to_thread(
                run_scenario, "foxglove_params.mjs", bridge.url, "-", "/silent"
            )
            asked = [
                r.message["service"] for r in silent.history if r.message["op"] == "call_service"
            ]
        assert_bridge_survived(bridge)
    assert result["getSilent"] == []
    assert sorted(asked) == ["/silent/get_parameters", "/silent/set_parameters"]
    statuses = sorted(result["statuses"])
    assert statuses[0].startswith("getting /silent.x failed: Service /silent/get_parameters")
    assert "timed out after 1 s" in statuses[0]
    assert statuses[1].startswith("setting '/silent.y' failed: a ROS 2 parameter cannot hold")
    assert statuses[2] == (
        "setting /silent.x failed: Service /silent/set_parameters call timed out after 1 s"
    )
