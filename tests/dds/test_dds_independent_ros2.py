"""Actions, parameters and a best-effort topic of an independent participant (plain
cyclonedds, tests/dds/ros2_action_peer.py: rcl_action's names, rosidl's types and
rmw_cyclonedds's request header written by hand) reached through the bridge by roslibpy and
rosapi. The Fast DDS side of the same is tests/dds/test_dds_rclpy.py."""

from __future__ import annotations

import asyncio
import logging
import time
from contextlib import AbstractAsyncContextManager
from pathlib import Path

import pytest
import roslibpy

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from tests import graph_peers
from tests.compat import roslibpy_support as rp
from tests.dds.test_dds_rclpy import (
    DISCOVERY_TIMEOUT_S,
    assert_feedback_leads_to,
    first,
    wait_for_action,
    wait_for_service,
)
from tests.graph_peers import cyclone_loopback_env, run_json_peer

pytestmark = pytest.mark.slow

PEER = Path(__file__).resolve().parent / "ros2_action_peer.py"
PEER_LIFETIME_S = 120.0
SUCCEEDED = 4  # action_msgs/msg/GoalStatus


def serving_peer(domain: int, *args: str) -> AbstractAsyncContextManager[object]:
    """The peer serving (`serve peer_node`, or `args`) for the block, stopped after."""
    args = args or ("serve", "peer_node", str(PEER_LIFETIME_S))
    return graph_peers.serving_peer(PEER, str(domain), *args, env=cyclone_loopback_env())


async def run_peer(domain: int, *args: str, timeout_s: float = 90.0) -> dict:
    """Run the peer in `client` mode to its end; its JSON line."""
    env = cyclone_loopback_env()
    return await run_json_peer(PEER, str(domain), *args, env=env, timeout_s=timeout_s)


def roslibpy_goals(host: str, port: int) -> dict:
    with rp.connected(host, port) as ros:
        client = roslibpy.ActionClient(
            ros, "/peer_fibonacci", "example_interfaces/action/Fibonacci"
        )
        feedback, results, errors = rp.Inbox(), rp.Inbox(), rp.Inbox()
        client.send_goal(roslibpy.Goal({"order": 4}), results, feedback, errors)
        [done] = results.expect(1, timeout_s=DISCOVERY_TIMEOUT_S)
        canceled = rp.Inbox()
        goal_id = client.send_goal(roslibpy.Goal({"order": 50}), canceled, rp.Inbox(), errors)
        time.sleep(0.3)
        client.cancel_goal(goal_id)
        [stopped] = canceled.expect(1, timeout_s=DISCOVERY_TIMEOUT_S)
    return {
        "done": done,
        "feedback": [list(f["sequence"]) for f in feedback.snapshot()],
        "stopped": stopped,
        "errors": errors.snapshot(),
    }


async def test_an_independent_participants_action_parameters_and_sensor(dds_domain, registry):
    config = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=dds_domain)
    async with (
        serving_peer(dds_domain),
        run_bridge(config) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as client,
    ):
        sensor = await client.subscribe("/peer_sensor", "std_msgs/msg/String")
        await first(sensor, lambda m: m["data"].startswith("peer sensor "))
        await wait_for_action(client, "/peer_fibonacci")
        outcome = await asyncio.to_thread(roslibpy_goals, "127.0.0.1", bridge.port)
        await wait_for_service(client, "/peer_node/set_parameters")
        gain = await client.call_service("/rosapi/get_param", {"name": "/peer_node:gain"})
        changed = await client.call_service(
            "/rosapi/set_param", {"name": "/peer_node:gain", "value": "2.5"}
        )
        refused = await client.call_service(
            "/rosapi/set_param", {"name": "/peer_node:other", "value": "1"}
        )
        again = await client.call_service("/rosapi/get_param", {"name": "/peer_node:gain"})
    assert outcome["done"]["values"] == {"sequence": [0, 1, 1, 2, 3]}
    assert_feedback_leads_to(outcome["feedback"], [0, 1, 1, 2, 3])
    assert outcome["stopped"]["status"] == roslibpy.core.GoalStatus.CANCELED
    assert outcome["errors"] == []
    assert gain == {"value": "1.5", "successful": True, "reason": ""}
    assert changed == {"successful": True, "reason": ""}
    assert refused == {"successful": False, "reason": "only gain, a double"}
    assert again["value"] == "2.5"


async def test_an_independent_action_client_drives_a_websocket_clients_action(dds_domain, registry):
    """The other way: a websocket client's advertise_action is an action server on DDS."""
    config = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=dds_domain)
    goals = []

    async def fibonacci(args, feedback):
        goals.append(args)
        sequence = [0, 1]
        for _ in range(1, args["order"]):
            sequence.append(sequence[-1] + sequence[-2])
            await feedback({"sequence": sequence})
        return {"sequence": sequence}

    async with (
        run_bridge(config) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as provider,
    ):
        await provider.advertise_action(
            "/ws_fibonacci", "example_interfaces/action/Fibonacci", fibonacci
        )
        answer = await run_peer(dds_domain, "client", "/ws_fibonacci", "5", "60")
    assert [dict(g) for g in goals] == [{"order": 5}]
    assert answer["accepted"] is True and answer["status"] == SUCCEEDED
    assert answer["sequence"] == [0, 1, 1, 2, 3, 5]
    assert_feedback_leads_to(answer["feedback"], [0, 1, 1, 2, 3, 5])
    assert answer["statuses"][-1] == [[list(range(1, 17)), SUCCEEDED]]


async def publishers_of(client, topic: str, timeout_s: float = DISCOVERY_TIMEOUT_S) -> list:
    """rosapi's publishers of `topic` once it has any."""
    async with asyncio.timeout(timeout_s):
        while True:
            found = await client.call_service("/rosapi/publishers", {"topic": topic})
            if found["publishers"]:
                return found["publishers"]
            await asyncio.sleep(0.2)


@pytest.mark.parametrize(
    ("distro", "named"), [("humble", True), ("jazzy", False)], ids=["humble", "jazzy"]
)
async def test_ros_distro_selects_the_discovery_info_layout(
    dds_domain, registry, distro, named, caplog
):
    """A Humble node's ros_discovery_info (24-byte GIDs) names its node for a bridge started
    with --ros-distro humble; a Jazzy bridge cannot read it (this peer sends XTypes type
    information, so its 24-byte layout does not even match a Jazzy reader; a real Humble node
    sends none and the bridge warns once) and names the endpoint after its participant.
    Topics cross either way."""
    config = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=dds_domain, distro=distro)
    caplog.set_level(logging.INFO, "bridge.dds")
    async with (
        serving_peer(dds_domain, "humble_node", str(PEER_LIFETIME_S)),
        run_bridge(config) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as client,
    ):
        chatter = await client.subscribe("/humble_chatter", "std_msgs/msg/String")
        await first(chatter, lambda m: m["data"].startswith("humble "))
        publishers = await publishers_of(client, "/humble_chatter")
        version = await client.call_service("/rosapi/get_ros_version", {})
    assert version == {"version": 2, "distro": distro}
    layout_notes = [r for r in caplog.records if "ros_discovery_info sample" in r.getMessage()]
    if named:
        assert publishers == ["/humble_talker"] and layout_notes == []
    else:
        assert len(publishers) == 1 and publishers[0].startswith("/dds_participant_")
        assert len(layout_notes) <= 1
    # its writer never matches this reader: no use reading the topic again for it
    assert not [r for r in caplog.records if "reading it again" in r.getMessage()]


async def test_the_bridges_own_parameters_are_a_ros2_nodes(dds_domain, registry):
    """`ros2 param`'s services on the bridge's node, answered from the rosapi parameters."""
    config = BridgeConfig(
        host="127.0.0.1",
        port=0,
        dds=True,
        dds_domain=dds_domain,
        dds_node="rb_bridge",
        dds_parameters=True,
    )
    async with (
        run_bridge(config) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as client,
    ):
        await client.call_service("/rosapi/set_param", {"name": "preset", "value": "7"})
        answer = await run_peer(dds_domain, "params", "rb_bridge", "60")
        gain = await client.call_service("/rosapi/get_param", {"name": "gain"})
    assert answer["set"] == [[True, ""]]
    assert answer["names"] == ["gain", "preset"]
    assert answer["values"] == [[3, 2.5, 0], [2, 0.0, 7], [0, 0.0, 0]]
    assert answer["descriptors"] == [["gain", 3], ["preset", 2], ["missing", 0]]
    assert answer["types"] == [3, 2, 0]
    assert gain["value"] == "2.5"
