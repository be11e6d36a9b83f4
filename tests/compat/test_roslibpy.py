"""roslibpy 2.1 (PyPI, default Twisted transport) against `python -m bridge`.

Every scenario uses roslibpy's public API exactly as its users and its own integration tests
do (ROS 1 type spellings, `roslibpy.ros2.Header` with secs/nsecs stamps, blocking calls).
A roslibpy that received an op it cannot handle (`status`, a binary frame, an unknown
service-response id) only logs an error, so each test also fails on such log records.
"""

from __future__ import annotations

import asyncio
import base64
import math

import numpy as np
import pytest
import roslibpy
import roslibpy.ros2

from . import roslibpy_support as rp
from .messages import point_cloud
from .wire import wait_until_listed, wire_peer

SENTINEL = "end-of-sequence"
SERVICE_TIMEOUT_S = 20.0


def publish_sequence(topic: roslibpy.Topic, payloads: list[str]) -> None:
    """Publish std_msgs/String payloads followed by the sentinel that marks the end."""
    for payload in [*payloads, SENTINEL]:
        topic.publish(roslibpy.Message({"data": payload}))


def received_until_sentinel(inbox: rp.Inbox, count: int) -> list[str]:
    """Wait for `count` messages plus the sentinel, then return the payloads seen so far."""
    inbox.wait_for(count + 1)
    return [message["data"] for message in inbox.snapshot()]


def test_string_pubsub_delivers_each_message_once_in_order(open_ros) -> None:
    listener_ros, talker_ros = open_ros(), open_ros()
    inbox = rp.Inbox()
    roslibpy.Topic(listener_ros, "/chatter", "std_msgs/String").subscribe(inbox)
    rp.barrier(listener_ros)

    talker = roslibpy.Topic(talker_ros, "/chatter", "std_msgs/String")
    payloads = [f"hello riverbridge {index}" for index in range(3)]
    publish_sequence(talker, payloads)

    assert received_until_sentinel(inbox, 3) == [*payloads, SENTINEL]


def test_point_stamped_with_ros2_header_keeps_stamp_and_frame(open_ros) -> None:
    listener_ros, talker_ros = open_ros(), open_ros()
    inbox = rp.Inbox()
    roslibpy.Topic(listener_ros, "/points", "geometry_msgs/PointStamped").subscribe(inbox)
    rp.barrier(listener_ros)

    header = roslibpy.ros2.Header(stamp={"secs": 1_704_067_200, "nsecs": 5_000}, frame_id="map")
    point = {"x": 1.5, "y": -2.25, "z": 0.125}
    talker = roslibpy.Topic(talker_ros, "/points", "geometry_msgs/PointStamped")
    talker.publish(roslibpy.Message({"header": header, "point": point}))

    [message] = inbox.expect(1)
    assert message["header"]["stamp"] == {"sec": 1_704_067_200, "nanosec": 5_000}
    assert message["header"]["frame_id"] == "map"
    assert message["point"] == point


def test_ros1_header_seq_is_dropped_with_one_line_per_client(bridge, open_ros) -> None:
    """roslibpy's `Header(seq=...)` (ROS 1, as its own test suite still sends): accepted,
    the seq dropped, the client told once in the log however many it sends."""
    listener_ros, talker_ros = open_ros(), open_ros()
    inbox = rp.Inbox()
    roslibpy.Topic(listener_ros, "/points1", "geometry_msgs/PointStamped").subscribe(inbox)
    rp.barrier(listener_ros)
    talker = roslibpy.Topic(talker_ros, "/points1", "geometry_msgs/PointStamped")
    for seq in (1, 2):
        header = roslibpy.Header(seq=seq, stamp=roslibpy.Time(7, 8), frame_id="map")
        talker.publish(roslibpy.Message({"header": header, "point": {"x": 1.0}}))

    first, second = inbox.expect(2)
    assert first["header"] == {"stamp": {"sec": 7, "nanosec": 8}, "frame_id": "map"}
    assert second["point"]["x"] == 1.0
    notes = [line for line in bridge.log.text().splitlines() if "header.seq" in line]
    assert len(notes) == 1 and "op=publish" in notes[0], bridge.log.text()


def test_non_finite_floats_from_roslibpy_arrive_as_null(open_ros) -> None:
    """roslibpy writes bare NaN/Infinity tokens (json.dumps); rosbridge ROS 2 sends null."""
    listener_ros, talker_ros = open_ros(), open_ros()
    inbox = rp.Inbox()
    roslibpy.Topic(listener_ros, "/compat/depth_m", "std_msgs/Float64").subscribe(inbox)
    rp.barrier(listener_ros)

    talker = roslibpy.Topic(talker_ros, "/compat/depth_m", "std_msgs/Float64")
    for value_m in (math.nan, math.inf, 2.5):
        talker.publish(roslibpy.Message({"data": value_m}))

    assert [message["data"] for message in inbox.wait_for(3)] == [None, None, 2.5]


def test_roslibpy_service_called_by_another_roslibpy_client(open_ros) -> None:
    provider_ros, caller_ros = open_ros(), open_ros()
    requests = rp.Inbox()

    def set_flag(request, response) -> bool:
        requests(dict(request))
        response["success"] = True
        response["message"] = f"flag set to {request['data']}"
        return True

    roslibpy.Service(provider_ros, "/compat/set_flag", "std_srvs/SetBool").advertise(set_flag)
    rp.barrier(provider_ros)

    client = roslibpy.Service(caller_ros, "/compat/set_flag", "std_srvs/SetBool")
    result = client.call(roslibpy.ServiceRequest({"data": True}), timeout=SERVICE_TIMEOUT_S)

    assert dict(result) == {"success": True, "message": "flag set to True"}
    assert requests.snapshot() == [{"data": True}]


async def test_roslibpy_calls_a_service_offered_by_a_plain_client(bridge, open_ros) -> None:
    caller_ros = await asyncio.to_thread(open_ros)
    async with wire_peer(bridge.url) as provider:
        await provider.send(
            {
                "op": "advertise_service",
                "type": "std_srvs/srv/Trigger",
                "service": "/compat/trigger",
            }
        )
        await wait_until_listed(provider, "/rosapi/services", "services", "/compat/trigger")

        pending = asyncio.create_task(
            asyncio.to_thread(rp.call_service, caller_ros, "/compat/trigger", {})
        )
        request = (await provider.expect_op("call_service", service="/compat/trigger")).message
        await provider.send(
            {
                "op": "service_response",
                "service": "/compat/trigger",
                "id": request["id"],
                "values": {"success": True, "message": "triggered"},
                "result": True,
            }
        )
        outcome = await pending

    assert outcome == rp.CallOutcome(True, {"success": True, "message": "triggered"})
    assert request["id"].startswith("service_request:")
    assert request.get("args", {}) == {}, "an empty request must be forwarded as {}"


async def test_failed_call_reaches_roslibpy_errback_with_the_message(bridge, open_ros) -> None:
    caller_ros = await asyncio.to_thread(open_ros)
    async with wire_peer(bridge.url) as provider:
        await provider.send(
            {"op": "advertise_service", "type": "std_srvs/srv/Trigger", "service": "/compat/arm"}
        )
        await wait_until_listed(provider, "/rosapi/services", "services", "/compat/arm")

        pending = asyncio.create_task(
            asyncio.to_thread(rp.call_service, caller_ros, "/compat/arm", {})
        )
        request = (await provider.expect_op("call_service", service="/compat/arm")).message
        await provider.send(
            {
                "op": "service_response",
                "service": "/compat/arm",
                "id": request["id"],
                "values": "motor controller offline",
                "result": False,
            }
        )
        outcome = await pending

    assert not outcome.succeeded
    assert "motor controller offline" in outcome.value


def test_call_to_missing_service_fails_promptly_with_a_string(open_ros) -> None:
    caller_ros = open_ros()
    outcome = rp.call_service(caller_ros, "/compat/nobody_home", {})
    assert not outcome.succeeded
    assert isinstance(outcome.value, str)
    assert "/compat/nobody_home" in outcome.value and "does not exist" in outcome.value


def test_blocking_call_to_missing_service_raises_service_exception(open_ros) -> None:
    caller_ros = open_ros()
    client = roslibpy.Service(caller_ros, "/compat/nobody_home", "std_srvs/Trigger")
    with pytest.raises(roslibpy.core.ServiceException, match="does not exist"):
        client.call(roslibpy.ServiceRequest(), timeout=SERVICE_TIMEOUT_S)


def test_params_set_then_get_round_trip_json_values(open_ros) -> None:
    ros = open_ros()
    speed = roslibpy.Param(ros, "/compat_node:max_speed_mps")
    speed.set(4.5, timeout=SERVICE_TIMEOUT_S)
    assert speed.get(timeout=SERVICE_TIMEOUT_S) == 4.5

    assert roslibpy.Param(ros, "/compat_node:never_set").get(timeout=SERVICE_TIMEOUT_S) is None

    route = {"waypoints": [[51.9, 4.4], [51.8, 4.6]], "name": "Waal"}
    ros.set_param("/compat_node:route", route)
    assert ros.get_param("/compat_node:route") == route


def test_two_connections_on_one_topic_each_receive_every_message_once(open_ros) -> None:
    first_ros, second_ros, talker_ros = open_ros(), open_ros(), open_ros()
    first, second = rp.Inbox(), rp.Inbox()
    roslibpy.Topic(first_ros, "/compat/shared", "std_msgs/String").subscribe(first)
    roslibpy.Topic(second_ros, "/compat/shared", "std_msgs/String").subscribe(second)
    rp.barrier(first_ros)
    rp.barrier(second_ros)

    payloads = [f"fan-out {index}" for index in range(5)]
    publish_sequence(roslibpy.Topic(talker_ros, "/compat/shared", "std_msgs/String"), payloads)

    assert received_until_sentinel(first, 5) == [*payloads, SENTINEL]
    assert received_until_sentinel(second, 5) == [*payloads, SENTINEL]


def test_two_topic_objects_on_one_connection_get_one_delivery_fanned_out(open_ros) -> None:
    """roslibpy fans one `publish` out to every callback of that topic name, so a bridge
    delivering per subscribe id would show up here as duplicates."""
    listener_ros, talker_ros = open_ros(), open_ros()
    first, second = rp.Inbox(), rp.Inbox()
    roslibpy.Topic(listener_ros, "/compat/twice", "std_msgs/String").subscribe(first)
    roslibpy.Topic(listener_ros, "/compat/twice", "std_msgs/String").subscribe(second)
    rp.barrier(listener_ros)

    payloads = ["one", "two", "three"]
    publish_sequence(roslibpy.Topic(talker_ros, "/compat/twice", "std_msgs/String"), payloads)

    assert received_until_sentinel(first, 3) == [*payloads, SENTINEL]
    assert received_until_sentinel(second, 3) == [*payloads, SENTINEL]


def test_unsubscribing_one_id_keeps_the_other_subscription(open_ros) -> None:
    listener_ros, talker_ros, witness_ros = open_ros(), open_ros(), open_ros()
    kept = roslibpy.Topic(listener_ros, "/compat/keep", "std_msgs/String")
    dropped = roslibpy.Topic(listener_ros, "/compat/keep", "std_msgs/String")
    kept.subscribe(rp.Inbox())
    dropped.subscribe(rp.Inbox())
    # roslibpy's unsubscribe removes every local callback for the name, so listen again
    # through Ros.on to observe what the bridge still sends for the remaining id.
    dropped.unsubscribe()
    after_first = rp.Inbox()
    listener_ros.on("/compat/keep", after_first)
    witness = rp.Inbox()
    roslibpy.Topic(witness_ros, "/compat/keep", "std_msgs/String").subscribe(witness)
    rp.barrier(listener_ros)
    rp.barrier(witness_ros)

    talker = roslibpy.Topic(talker_ros, "/compat/keep", "std_msgs/String")
    publish_sequence(talker, ["still here"])
    assert received_until_sentinel(after_first, 1) == ["still here", SENTINEL]

    kept.unsubscribe()
    after_both = rp.Inbox()
    listener_ros.on("/compat/keep", after_both)
    rp.barrier(listener_ros)
    publish_sequence(talker, ["nobody listening"])
    assert received_until_sentinel(witness, 3)[-2:] == ["nobody listening", SENTINEL]
    after_both.wait_for(1, timeout_s=1.0)  # grace period for a stray delivery
    assert after_both.snapshot() == []


async def test_roslibpy_never_gets_status_or_binary_frames(bridge, open_ros, log_trap) -> None:
    """Errors caused by roslibpy are only logged by the bridge (roslibpy cannot handle
    `status`), and a CBOR subscriber on the same topic never leaks binary frames to it."""
    ros = await asyncio.to_thread(open_ros)
    inbox = rp.Inbox()

    def misbehave() -> None:
        roslibpy.Topic(ros, "/compat/never_advertised", None).subscribe(rp.Inbox())
        roslibpy.Topic(ros, "/compat/bogus", "no_such_pkg/Bogus").publish(roslibpy.Message({}))
        roslibpy.Topic(ros, "/compat/mixed", "std_msgs/String").publish(
            roslibpy.Message({"data": 42})
        )
        roslibpy.Topic(ros, "/compat/mixed", "std_msgs/String").subscribe(inbox)
        rp.barrier(ros)

    await asyncio.to_thread(misbehave)
    async with wire_peer(bridge.url) as cbor_listener:
        await cbor_listener.send(
            {"op": "subscribe", "id": "cbor:1", "topic": "/compat/mixed",
             "type": "std_msgs/msg/String", "compression": "cbor"}
        )  # fmt: skip
        await cbor_listener.call_service("/rosapi/get_time")
        await cbor_listener.send(
            {"op": "publish", "topic": "/compat/mixed", "msg": {"data": "mixed audience"}}
        )
        cbor_copy = await cbor_listener.expect_op("publish", topic="/compat/mixed")

    assert cbor_copy.binary and cbor_copy.message["msg"] == {"data": "mixed audience"}
    received = await asyncio.to_thread(inbox.expect, 1)
    assert [message["data"] for message in received] == ["mixed audience"]
    await asyncio.to_thread(rp.barrier, ros)
    assert log_trap.errors() == []


async def test_roslibpy_receives_a_large_cloud_whole(bridge, open_ros) -> None:
    """roslibpy cannot reassemble `fragment` ops or read binary frames: a 200,000-point
    cloud (~4.3 MB of JSON) must reach it as one JSON text message with base64 data."""
    cloud = point_cloud(200_000)
    listener_ros = await asyncio.to_thread(open_ros)
    inbox = rp.Inbox()
    topic = roslibpy.Topic(listener_ros, "/compat/big_cloud", "sensor_msgs/PointCloud2")
    topic.subscribe(inbox)
    await asyncio.to_thread(rp.barrier, listener_ros)
    async with wire_peer(bridge.url) as publisher:
        await publisher.send(
            {"op": "publish", "topic": "/compat/big_cloud", "msg": cloud.message,
             "type": "sensor_msgs/msg/PointCloud2"}
        )  # fmt: skip
        [message] = await asyncio.to_thread(inbox.expect, 1, 60.0)

    points = np.frombuffer(base64.b64decode(message["data"]), dtype="<f4").reshape(-1, 4)
    np.testing.assert_array_equal(points, cloud.points)
    assert message["width"] == 200_000
