"""Real clients on both ends: roslibjs provides a service and an action, roslibpy uses them."""

from __future__ import annotations

import asyncio

import pytest
import roslibpy

from . import roslibpy_support as rp
from .bridge_process import BridgeEndpoint
from .node_runner import run_scenario
from .wire import wait_until_listed, wire_peer


@pytest.mark.parametrize("mode", ["async", "sync"])
async def test_roslibpy_calls_service_provided_by_roslibjs(
    bridge: BridgeEndpoint, open_ros, mode: str
) -> None:
    """`advertiseAsync` fails with result:false and the error text; the sync `advertise`
    fails with result:false and no values at all, which must still reach roslibpy's errback
    as a string (rosbridge itself left that caller hanging)."""
    service = "/compat/lock_gate"
    provider = asyncio.create_task(
        asyncio.to_thread(run_scenario, "provide_service.mjs", bridge.url, service, "2", mode)
    )
    async with wire_peer(bridge.url) as observer:
        await wait_until_listed(observer, "/rosapi/services", "services", service)
        type_reply = await observer.call_service("/rosapi/service_type", {"service": service})
    caller = await asyncio.to_thread(open_ros)
    opened = await asyncio.to_thread(rp.call_service, caller, service, {"data": True})
    refused = await asyncio.to_thread(rp.call_service, caller, service, {"data": False})
    served = await provider

    assert type_reply["values"] == {"type": "std_srvs/srv/SetBool"}
    assert opened == rp.CallOutcome(True, {"success": True, "message": "lock gate opening"})
    assert not refused.succeeded and isinstance(refused.value, str)
    if mode == "async":
        assert "refusing to open the lock gate" in refused.value
    assert served["requests"] == [{"data": True}, {"data": False}]
    assert served["status_ops"] == []


async def test_roslibpy_action_client_with_roslibjs_action_server(
    bridge: BridgeEndpoint, open_ros
) -> None:
    action, action_type = "/compat/fibonacci", "example_interfaces/action/Fibonacci"
    server = asyncio.create_task(
        asyncio.to_thread(run_scenario, "action_server.mjs", bridge.url, action, "3")
    )
    async with wire_peer(bridge.url) as observer:
        await wait_until_listed(observer, "/rosapi/action_servers", "action_servers", action)
    client_ros = await asyncio.to_thread(open_ros)
    client = roslibpy.ActionClient(client_ros, action, action_type)
    feedback, results, errors = rp.Inbox(), rp.Inbox(), rp.Inbox()
    client.send_goal(roslibpy.Goal({"order": 4}), results, feedback, errors)
    [result] = await asyncio.to_thread(results.expect, 1)
    client.send_goal(roslibpy.Goal({"order": -1}), results, rp.Inbox(), errors)
    [error] = await asyncio.to_thread(errors.expect, 1)
    long_feedback, cancelled = rp.Inbox(), rp.Inbox()
    long_goal = client.send_goal(roslibpy.Goal({"order": 5000}), cancelled, long_feedback, errors)
    await asyncio.to_thread(long_feedback.expect, 1)
    client.cancel_goal(long_goal)
    [cancel_result] = await asyncio.to_thread(cancelled.expect, 1)
    served = await server

    assert result["status"] == roslibpy.core.GoalStatus.SUCCEEDED
    assert result["values"] == {"sequence": [0, 1, 1, 2, 3]}
    assert [dict(item)["sequence"] for item in feedback.snapshot()] == [
        [0, 1, 1], [0, 1, 1, 2], [0, 1, 1, 2, 3],
    ]  # fmt: skip
    assert error["status"] == roslibpy.core.GoalStatus.ABORTED
    assert cancel_result["status"] == roslibpy.core.GoalStatus.CANCELED
    assert cancel_result["values"] == {"sequence": [0, 1]}
    assert served["goals"] == [{"order": 4}, {"order": -1}, {"order": 5000}]
    assert served["status_ops"] == []
