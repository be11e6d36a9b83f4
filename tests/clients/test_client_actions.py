"""Actions between two clients through a real bridge: feedback, result, cancel, failure."""

from __future__ import annotations

import asyncio

import numpy as np
import orjson
import pytest

from clients import ActionError
from clients.events import GoalCancel, GoalRequest, Ignored
from clients.protocol import ClientProtocol

FIB = "example_interfaces/action/Fibonacci"


async def fibonacci(args: dict, feedback) -> dict:
    sequence = [0, 1]
    for _ in range(args["order"] - 2):
        sequence.append(sequence[-1] + sequence[-2])
        await feedback({"sequence": sequence})
    return {"sequence": sequence}


async def goal_when_available(caller, action: str, args: dict, timeout_s: float = 5.0):
    """Send a goal, retrying while the bridge does not know the action yet."""
    async with asyncio.timeout(timeout_s):
        while True:
            goal = await caller.send_action_goal(action, FIB, args)
            try:
                return goal, await goal.result()
            except ActionError as exc:
                if "does not exist" not in str(exc):
                    raise
                await asyncio.sleep(0.02)


def test_protocol_routes_goals_and_cancels_for_advertised_actions():
    proto = ClientProtocol(encoding="json", spec_lookup=lambda name: None)
    frame = proto.advertise_action("/fib", FIB)
    assert orjson.loads(frame.data) == {"op": "advertise_action", "type": FIB, "action": "/fib"}
    request = {
        "op": "send_action_goal",
        "id": "action_goal:/fib:1",
        "action": "/fib",
        "action_type": FIB,
        "args": {"order": 3},
        "feedback": True,
    }
    [goal] = proto.receive(orjson.dumps(request).decode(), recv_ns=0)
    assert goal == GoalRequest("action_goal:/fib:1", "/fib", FIB, {"order": 3})
    cancel = {"op": "cancel_action_goal", "id": "action_goal:/fib:1", "action": "/fib"}
    assert proto.receive(orjson.dumps(cancel).decode(), recv_ns=0) == [
        GoalCancel("action_goal:/fib:1", "/fib")
    ]
    assert orjson.loads(
        ClientProtocol.action_result(goal, {"sequence": [0, 1]}, status=4, result=True).data
    ) == {
        "op": "action_result",
        "id": "action_goal:/fib:1",
        "action": "/fib",
        "values": {"sequence": [0, 1]},
        "status": 4,
        "result": True,
    }
    assert [orjson.loads(f.data)["op"] for f in proto.resume_frames()] == ["advertise_action"]
    proto.unadvertise_action("/fib")
    [ignored] = proto.receive(orjson.dumps(request).decode(), recv_ns=0)
    assert isinstance(ignored, Ignored)


@pytest.mark.parametrize("encoding", ["json", "cbor"])
async def test_goal_feedback_and_result(bridge, make_client, encoding):
    server = await make_client(bridge.url, name="action-server", encoding=encoding)
    caller = await make_client(bridge.url, name="caller", encoding=encoding)
    await server.advertise_action("/fibonacci", FIB, fibonacci)
    _, result = await goal_when_available(caller, "/fibonacci", {"order": 2})
    assert np.asarray(result["sequence"]).tolist() == [0, 1]

    goal = await caller.send_action_goal("/fibonacci", FIB, {"order": 6})
    feedback = [np.asarray(values["sequence"]).tolist() async for values in goal.feedback()]
    result = await goal.result()
    assert isinstance(result["sequence"], np.ndarray), "canonical form: int32[] -> ndarray"
    assert result["sequence"].tolist() == [0, 1, 1, 2, 3, 5]
    assert feedback[-1] == [0, 1, 1, 2, 3, 5] and len(feedback) == 4


async def test_goal_cancel_reports_canceled(bridge, make_client):
    started = asyncio.Event()

    async def endless_unless_zero(args: dict, feedback) -> dict:
        if args["order"] > 0:
            started.set()
            await asyncio.sleep(60)
        return {"sequence": []}

    server = await make_client(bridge.url)
    caller = await make_client(bridge.url)
    await server.advertise_action("/endless", FIB, endless_unless_zero)
    await goal_when_available(caller, "/endless", {"order": 0})
    goal = await caller.send_action_goal("/endless", FIB, {"order": 1})
    await asyncio.wait_for(started.wait(), 5)
    await goal.cancel()
    with pytest.raises(ActionError) as info:
        await asyncio.wait_for(goal.result(), 5)
    assert info.value.status == 5


async def test_goal_handler_failure_is_an_action_error(bridge, make_client):
    async def broken(args: dict, feedback) -> dict:
        raise RuntimeError("no fuel")

    server = await make_client(bridge.url)
    caller = await make_client(bridge.url)
    await server.advertise_action("/broken", FIB, broken)
    with pytest.raises(ActionError, match="no fuel"):
        await goal_when_available(caller, "/broken", {"order": 3})
