"""Protocol round trips between the client library and the bridge core, in memory: what one
side writes, the other reads (tests/memory_pair.py), with no socket in between."""

import numpy as np
import pytest

from clients.events import Ignored, ServiceReply, ServiceRequest, TopicMessage
from clients.protocol import ClientProtocol
from clients.wire import json_frame

IMU = "sensor_msgs/msg/Imu"


def imu_msg(yaw_rate: float) -> dict:
    return {
        "header": {"stamp": {"sec": 7, "nanosec": 5}, "frame_id": "imu"},
        "angular_velocity": {"x": 0.0, "y": 0.0, "z": yaw_rate},
        "orientation_covariance": np.arange(9, dtype=np.float64),
    }


@pytest.mark.parametrize("publisher_encoding", ["json", "cbor"])
@pytest.mark.parametrize("subscriber_encoding", ["json", "cbor"])
def test_a_publish_reaches_a_typed_subscriber_in_canonical_form(
    memory_pair, check_canonical, publisher_encoding, subscriber_encoding
):
    talker, listener = (
        memory_pair.client(publisher_encoding),
        memory_pair.client(subscriber_encoding),
    )
    sub_id, subscribe = listener.protocol.subscribe("/imu", IMU)
    memory_pair.send(listener, subscribe)
    memory_pair.send(talker, talker.protocol.advertise("/imu", IMU))
    memory_pair.send(talker, talker.protocol.encode_publish("/imu", imu_msg(0.25)))

    (event,) = memory_pair.events_of(listener, TopicMessage)
    assert event.sub_ids == (sub_id,)
    msg = event.received.msg
    assert msg["angular_velocity"]["z"] == 0.25
    assert msg["header"]["stamp"] == {"sec": 7, "nanosec": 5}
    np.testing.assert_array_equal(msg["orientation_covariance"], np.arange(9.0))
    check_canonical(IMU, msg)
    assert event.received.wire_bytes > 0


def test_after_unsubscribe_nothing_more_arrives(memory_pair):
    talker, listener = memory_pair.client(), memory_pair.client("cbor")
    sub_id, subscribe = listener.protocol.subscribe("/imu", IMU)
    memory_pair.send(listener, subscribe)
    memory_pair.send(talker, talker.protocol.advertise("/imu", IMU))
    memory_pair.send(talker, talker.protocol.encode_publish("/imu", imu_msg(1.0)))
    assert len(memory_pair.events_of(listener, TopicMessage)) == 1

    memory_pair.send(listener, listener.protocol.unsubscribe(sub_id))
    memory_pair.send(talker, talker.protocol.encode_publish("/imu", imu_msg(2.0)))
    assert memory_pair.events(listener) == []


def test_a_service_call_reaches_the_provider_and_its_answer_the_caller(memory_pair):
    provider, caller = memory_pair.client(), memory_pair.client()
    memory_pair.send(provider, provider.protocol.advertise_service("/arm", "std_srvs/srv/SetBool"))
    call_id, call = caller.protocol.call_service("/arm", {"data": True})
    memory_pair.send(caller, call)

    (request,) = memory_pair.events_of(provider, ServiceRequest)
    assert (request.service, request.args) == ("/arm", {"data": True})
    answer = ClientProtocol.service_response(
        request, {"success": True, "message": "armed"}, result=True
    )
    memory_pair.send(provider, answer)

    (reply,) = memory_pair.events_of(caller, ServiceReply)
    assert (reply.call_id, reply.service, reply.result) == (call_id, "/arm", True)
    assert reply.values == {"success": True, "message": "armed"}


def test_a_call_to_a_missing_service_fails_with_the_bridges_reason(memory_pair):
    caller = memory_pair.client()
    call_id, call = caller.protocol.call_service("/nobody", {})
    memory_pair.send(caller, call)

    (reply,) = memory_pair.events_of(caller, ServiceReply)
    assert (reply.call_id, reply.result) == (call_id, False)
    assert "/nobody" in str(reply.values)


def test_a_status_the_client_waits_for_no_one_is_reported_ignored(memory_pair):
    client = memory_pair.client()
    memory_pair.send(client, json_frame({"op": "set_level", "level": "error"}))
    memory_pair.send(client, client.protocol.encode_publish("/never_advertised", {"data": 1}))
    events = memory_pair.events(client)
    assert events, "the bridge answers the bad publish with a status"
    assert all(isinstance(event, Ignored) and event.op == "status" for event in events), events
