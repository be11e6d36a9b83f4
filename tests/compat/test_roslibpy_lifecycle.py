"""roslibpy across the lifetime of what it talks to: latched topics reaching late subscribers,
providers that vanish mid-call, and ROS 2 actions (roslibpy's ActionClient) served by a
plain client."""

from __future__ import annotations

import asyncio
import time

import roslibpy

from . import roslibpy_support as rp
from .bridge_process import BridgeEndpoint, free_port, running_bridge, stop_bridge
from .wire import WirePeer, wait_until_listed, wire_peer

FIBONACCI = "example_interfaces/action/Fibonacci"
# action_msgs/msg/GoalStatus codes.
STATUS_SUCCEEDED = 4
STATUS_ABORTED = 6
# roslibpy's backoff starts at 1 s and grows 2.7x per failed attempt.
RECONNECT_TIMEOUT_S = 45.0


def test_latched_message_reaches_a_late_subscriber(open_ros) -> None:
    talker_ros, late_ros = open_ros(), open_ros()
    talker = roslibpy.Topic(talker_ros, "/compat/gate_state", "std_msgs/String", latch=True)
    talker.publish(roslibpy.Message({"data": "gate closed"}))
    rp.barrier(talker_ros)

    inbox = rp.Inbox()
    roslibpy.Topic(late_ros, "/compat/gate_state", "std_msgs/String").subscribe(inbox)
    assert [message["data"] for message in inbox.wait_for(1)] == ["gate closed"]


def test_empty_message_arrives_as_empty_object(open_ros) -> None:
    """std_msgs/Empty has no fields; nothing else may appear on the wire."""
    listener_ros, talker_ros = open_ros(), open_ros()
    inbox = rp.Inbox()
    roslibpy.Topic(listener_ros, "/compat/heartbeat", "std_msgs/Empty").subscribe(inbox)
    rp.barrier(listener_ros)
    roslibpy.Topic(talker_ros, "/compat/heartbeat", "std_msgs/Empty").publish(roslibpy.Message())

    assert inbox.wait_for(1) == [{}]


async def test_provider_disconnect_fails_pending_call_and_unlists_service(
    bridge: BridgeEndpoint, open_ros
) -> None:
    service = "/compat/flaky"
    caller = await asyncio.to_thread(open_ros)
    async with wire_peer(bridge.url) as observer:
        async with wire_peer(bridge.url) as provider:
            await provider.send(
                {"op": "advertise_service", "type": "std_srvs/srv/Trigger", "service": service}
            )
            await wait_until_listed(provider, "/rosapi/services", "services", service)
            pending = asyncio.create_task(asyncio.to_thread(rp.call_service, caller, service, {}))
            await provider.expect_op("call_service", service=service)
        outcome = await pending
        services = (await observer.call_service("/rosapi/services"))["values"]["services"]

    assert not outcome.succeeded and isinstance(outcome.value, str)
    assert service not in services


async def serve_fibonacci_goal(server: WirePeer, action: str) -> dict:
    """Answer one goal: one feedback, then a SUCCEEDED result; return the forwarded goal."""
    goal = (await server.expect_op("send_action_goal", action=action)).message
    await server.send(
        {
            "op": "action_feedback",
            "id": goal["id"],
            "action": action,
            "values": {"sequence": [0, 1, 1]},
        }
    )
    await server.send(
        {
            "op": "action_result",
            "id": goal["id"],
            "action": action,
            "values": {"sequence": [0, 1, 1, 2, 3]},
            "status": STATUS_SUCCEEDED,
            "result": True,
        }
    )
    return goal


async def test_roslibpy_action_client_gets_feedback_and_result(
    bridge: BridgeEndpoint, open_ros
) -> None:
    action = "/compat/fibonacci"
    client_ros = await asyncio.to_thread(open_ros)
    feedback, results, errors = rp.Inbox(), rp.Inbox(), rp.Inbox()
    async with wire_peer(bridge.url) as server:
        await server.send({"op": "advertise_action", "type": FIBONACCI, "action": action})
        await wait_until_listed(server, "/rosapi/action_servers", "action_servers", action)
        client = roslibpy.ActionClient(client_ros, action, FIBONACCI)
        client.send_goal(roslibpy.Goal({"order": 4}), results, feedback, errors)
        goal = await serve_fibonacci_goal(server, action)
        [result] = await asyncio.to_thread(results.expect, 1)

    assert goal["args"] == {"order": 4}
    assert goal["action_type"] == FIBONACCI
    assert [dict(item) for item in feedback.snapshot()] == [{"sequence": [0, 1, 1]}]
    assert result["status"] == roslibpy.core.GoalStatus.SUCCEEDED
    assert result["values"] == {"sequence": [0, 1, 1, 2, 3]}
    assert errors.snapshot() == []


async def test_action_server_disconnect_aborts_the_goal(bridge: BridgeEndpoint, open_ros) -> None:
    action = "/compat/doomed"
    client_ros = await asyncio.to_thread(open_ros)
    results, errors = rp.Inbox(), rp.Inbox()
    async with wire_peer(bridge.url) as server:
        await server.send({"op": "advertise_action", "type": FIBONACCI, "action": action})
        await wait_until_listed(server, "/rosapi/action_servers", "action_servers", action)
        client = roslibpy.ActionClient(client_ros, action, FIBONACCI)
        client.send_goal(roslibpy.Goal({"order": 3}), results, rp.Inbox(), errors)
        await server.expect_op("send_action_goal", action=action)

    [error] = await asyncio.to_thread(errors.expect, 1)
    assert error["status"] == roslibpy.core.GoalStatus(STATUS_ABORTED)
    assert results.snapshot() == []


def wait_connected(connections: list[roslibpy.Ros], timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not all(ros.is_connected for ros in connections):
        assert time.monotonic() < deadline, "roslibpy did not reconnect to the restarted bridge"
        time.sleep(0.1)


def test_roslibpy_reconnects_and_resubscribes_after_bridge_restart(log_trap) -> None:
    """roslibpy reconnects by itself and re-sends its stored subscribe and advertise ops;
    a restarted bridge on the same port must accept them as from any new client."""
    port = free_port()
    with (
        running_bridge(port=port) as first,
        rp.connected("127.0.0.1", port) as listener_ros,
        rp.connected("127.0.0.1", port) as talker_ros,
    ):
        inbox = rp.Inbox()
        roslibpy.Topic(listener_ros, "/compat/restart", "std_msgs/String").subscribe(inbox)
        rp.barrier(listener_ros)
        talker = roslibpy.Topic(talker_ros, "/compat/restart", "std_msgs/String")
        talker.publish(roslibpy.Message({"data": "before restart"}))
        assert [m["data"] for m in inbox.wait_for(1)] == ["before restart"]

        stop_bridge(first)
        with running_bridge(port=port):
            wait_connected([listener_ros, talker_ros], RECONNECT_TIMEOUT_S)
            deadline = time.monotonic() + RECONNECT_TIMEOUT_S
            # The re-subscribe goes out about a second after reconnecting, unannounced.
            while not any(m["data"] == "after restart" for m in inbox.snapshot()):
                assert time.monotonic() < deadline, f"nothing after restart: {inbox.snapshot()}"
                talker.publish(roslibpy.Message({"data": "after restart"}))
                inbox.wait_for(2, timeout_s=0.3)
