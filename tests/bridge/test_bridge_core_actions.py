"""Client-provided actions in the core: goal forwarding, feedback, results, cancel, clean-up."""

from __future__ import annotations

from tests.bridge.bridge_harness import CoreHarness

FIB = "example_interfaces/action/Fibonacci"


def setup_goal(h: CoreHarness, feedback: bool = True) -> tuple[int, int, str]:
    provider, caller = h.connect(), h.connect()
    h.send(provider, {"op": "advertise_action", "action": "/fibonacci", "type": FIB})
    h.send(
        caller,
        {
            "op": "send_action_goal",
            "action": "fibonacci",
            "action_type": FIB,
            "args": {"order": 5},
            "feedback": feedback,
            "id": "goal-1",
        },
    )
    goal = h.outbox(provider)
    assert goal == [
        {
            "op": "send_action_goal",
            "id": "action_goal:/fibonacci:1",
            "action": "/fibonacci",
            "action_type": FIB,
            "args": {"order": 5},
            "feedback": True,
        }
    ]
    return provider, caller, goal[0]["id"]


def test_feedback_and_result_are_routed_back_to_the_caller(harness):
    provider, caller, goal_id = setup_goal(harness)
    harness.send(
        provider,
        {
            "op": "action_feedback",
            "action": "/fibonacci",
            "id": goal_id,
            "values": {"sequence": [0, 1, 1]},
        },
    )
    harness.send(
        provider,
        {
            "op": "action_result",
            "action": "/fibonacci",
            "id": goal_id,
            "values": {"sequence": [0, 1, 1, 2, 3, 5]},
            "status": 4,
            "result": True,
        },
    )
    feedback, result = harness.outbox(caller)
    assert feedback["op"] == "action_feedback" and feedback["id"] == "goal-1"
    assert feedback["action"] == "fibonacci"
    assert feedback["values"]["sequence"] == [0, 1, 1]
    assert result == {
        "op": "action_result",
        "action": "fibonacci",
        "values": {"sequence": [0, 1, 1, 2, 3, 5]},
        "status": 4,
        "result": True,
        "id": "goal-1",
    }
    assert harness.state.pending_goals == {}


def test_feedback_is_withheld_when_not_requested(harness):
    provider, caller, goal_id = setup_goal(harness, feedback=False)
    harness.send(
        provider,
        {
            "op": "action_feedback",
            "action": "/fibonacci",
            "id": goal_id,
            "values": {"sequence": [0]},
        },
    )
    assert harness.outbox(caller) == []


def test_cancel_is_forwarded_to_the_provider(harness):
    provider, caller, goal_id = setup_goal(harness)
    harness.send(caller, {"op": "cancel_action_goal", "action": "fibonacci", "id": "goal-1"})
    assert harness.outbox(provider) == [
        {"op": "cancel_action_goal", "id": goal_id, "action": "/fibonacci"}
    ]
    harness.send(
        provider,
        {
            "op": "action_result",
            "action": "/fibonacci",
            "id": goal_id,
            "values": {"sequence": []},
            "status": 5,
            "result": True,
        },
    )
    assert harness.outbox(caller)[0]["status"] == 5


def test_unknown_action_fails_promptly(harness):
    caller = harness.connect()
    harness.send(
        caller,
        {"op": "send_action_goal", "action": "/nothing", "action_type": FIB, "args": {}, "id": 3},
    )
    result = harness.outbox(caller)[0]
    assert result["op"] == "action_result" and result["result"] is False
    assert result["status"] == 6 and result["id"] == 3


def test_provider_disconnect_aborts_pending_goals(harness):
    provider, caller, _ = setup_goal(harness)
    harness.disconnect(provider)
    result = harness.outbox(caller)[0]
    assert (result["result"], result["status"], result["id"]) == (False, 6, "goal-1")
    assert harness.state.graph.actions == {}


def test_caller_disconnect_cancels_its_goals(harness):
    provider, caller, goal_id = setup_goal(harness)
    harness.disconnect(caller)
    assert harness.outbox(provider) == [
        {"op": "cancel_action_goal", "id": goal_id, "action": "/fibonacci"}
    ]
    assert harness.state.pending_goals == {}


def test_unadvertise_action_aborts_goals(harness):
    provider, caller, _ = setup_goal(harness)
    harness.send(provider, {"op": "unadvertise_action", "action": "/fibonacci"})
    assert harness.outbox(caller)[0]["values"] == "Action /fibonacci was unadvertised"


def test_failed_result_reaches_the_caller_as_failure(harness):
    provider, caller, goal_id = setup_goal(harness)
    harness.send(
        provider,
        {
            "op": "action_result",
            "action": "/fibonacci",
            "id": goal_id,
            "values": {},
            "status": 6,
            "result": False,
        },
    )
    result = harness.outbox(caller)[0]
    assert result["result"] is False and result["status"] == 6
