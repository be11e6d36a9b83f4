"""The bridge in a graph of real ROS 2 nodes: rclpy from PyPI (Jazzy and Kilted wheels, on
rmw_fastrtps_cpp, Fast DDS) on one loopback domain with `riverbridge bridge --dds` (Cyclone).

One rclpy process per distribution (tests/dds/ros2_nodes/rclpy_node.py) and one bridge on its
domain serve the whole module; each test connects clients of its own.
"""

from __future__ import annotations

import asyncio
import time

import pytest
import pytest_asyncio
import roslibpy

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from bridge.dds.qos import QosProfile
from clients import RosbridgeClient
from clients.errors import ActionError
from tests.compat import roslibpy_support as rp
from tests.compat.node_runner import run_scenario
from tests.compat.wire import wire_peer
from tests.dds.conftest import take_domain
from tests.dds.rclpy_env import DISTROS, rclpy_script

# One rclpy node and one bridge per distribution serve the whole module (discovery once).
pytestmark = [pytest.mark.slow, pytest.mark.asyncio(loop_scope="module")]

DISCOVERY_TIMEOUT_S = 30.0
GOAL_CANCELED = 5  # action_msgs/msg/GoalStatus


@pytest.fixture(scope="module", params=DISTROS)
def ros2_node(request):
    """(distro, domain id, the running rclpy node) shared by the module's tests."""
    domain = take_domain()
    with rclpy_script(request.param, domain, "rclpy_node.py", "rb_test_node") as node:
        yield request.param, domain, node


@pytest_asyncio.fixture(scope="module", loop_scope="module")
async def bridge(ros2_node):
    """`riverbridge bridge --dds` on the node's domain, shared by the module's tests."""
    _, domain, _ = ros2_node
    async with run_bridge(bridge_config(domain)) as running:
        yield running


async def first(subscription, predicate, timeout_s: float = DISCOVERY_TIMEOUT_S):
    """The first message of `subscription` for which `predicate(msg)` holds."""
    async with asyncio.timeout(timeout_s):
        async for item in subscription:
            if predicate(item.msg):
                return item.msg
    raise AssertionError("subscription ended")


def bridge_config(domain: int) -> BridgeConfig:
    return BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=domain)


async def test_strings_cross_both_ways(ros2_node, bridge, registry):
    distro, _, node = ros2_node
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        chatter = await client.subscribe("/ros_chatter", "std_msgs/msg/String")
        heard = await first(chatter, lambda m: m["data"].startswith("hello "))
        echoes = await client.subscribe("/from_ros", "std_msgs/msg/String")
        await client.advertise("/to_ros", "std_msgs/msg/String")

        async def keep_sending() -> None:
            n = 0
            while True:  # until the node's subscription is matched; the test waits for it
                n += 1
                await client.publish("/to_ros", {"data": f"from {distro} {n}"})
                await asyncio.sleep(0.2)

        sender = asyncio.create_task(keep_sending())
        try:
            echo = await first(echoes, lambda m: m["data"].startswith(f"echo: from {distro}"))
        finally:
            sender.cancel()
    assert heard["data"].startswith("hello ")
    assert echo["data"].startswith(f"echo: from {distro} "), node.output()


async def test_a_best_effort_publisher_is_read_with_default_options(ros2_node, bridge, registry):
    """rclpy's sensor-data QoS (best effort): a subscribe without any QoS still gets it."""
    node = ros2_node[2]
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        sensor = await client.subscribe("/sensor_be", "std_msgs/msg/String")
        first_msg = await first(sensor, lambda m: m["data"].startswith("sensor "))
        second = await first(sensor, lambda m: m["data"] != first_msg["data"])
        async with wire_peer(bridge.url) as raw:
            # the subscribe op's own `qos` (rosbridge's shape) sets the DDS reader's policies
            await raw.send(
                {
                    "op": "subscribe",
                    "topic": "/ros_chatter",
                    "type": "std_msgs/msg/String",
                    "qos": {"reliability": "best_effort", "depth": 100},
                }
            )
            await raw.expect_op("publish", timeout_s=DISCOVERY_TIMEOUT_S, topic="/ros_chatter")
            reader = bridge.plugins["dds"].topics.readers["/ros_chatter"]
    assert second["data"].startswith("sensor "), node.output()
    assert reader.wanted.profile == QosProfile(reliable=False, transient_local=False, depth=100)


def assert_feedback_leads_to(feedback: list[list[int]], final: list[int]) -> None:
    """Feedback arrived, in order, each a growing prefix of the final sequence. (The last
    may come after the result: rcl_action sends them on separate channels, as in ROS 2. The
    first may be missed: feedback is volatile, and a server that has not yet learnt of the
    bridge's feedback reader, adopted just before the goal, writes its first step to nobody,
    as it would to any ROS 2 action client created just before its goal.)"""
    assert feedback and len(feedback[0]) >= 3, feedback
    assert all(f == final[: len(f)] for f in feedback), feedback
    assert [len(f) for f in feedback] == sorted({len(f) for f in feedback}), feedback


async def wait_for_action(client, action: str, timeout_s: float = DISCOVERY_TIMEOUT_S) -> None:
    """Until rosapi lists `action` (the bridge has discovered its server)."""
    async with asyncio.timeout(timeout_s):
        while True:
            listed = await client.call_service("/rosapi/action_servers", {})
            if action in listed["action_servers"]:
                return
            await asyncio.sleep(0.2)


async def test_an_rclpy_action_server_serves_goals_feedback_and_cancel(ros2_node, bridge, registry):
    """riverbridge's own client drives rclpy's ActionServer (test_msgs/action/Fibonacci)."""
    node = ros2_node[2]
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        await wait_for_action(client, "/fibonacci")
        goal = await client.send_action_goal(
            "/fibonacci", "test_msgs/action/Fibonacci", {"order": 5}
        )
        feedback = [list(values["sequence"]) async for values in goal.feedback()]
        result = await goal.result()
        long_goal = await client.send_action_goal(
            "/fibonacci", "test_msgs/action/Fibonacci", {"order": 40}
        )
        async for _ in long_goal.feedback():
            await long_goal.cancel()
            break
        with pytest.raises(ActionError) as canceled:
            await long_goal.result()
    assert list(result["sequence"]) == [0, 1, 1, 2, 3, 5], node.output()
    assert_feedback_leads_to(feedback, [0, 1, 1, 2, 3, 5])
    assert canceled.value.status == GOAL_CANCELED


async def wait_for_service(client, service: str, timeout_s: float = DISCOVERY_TIMEOUT_S) -> None:
    async with asyncio.timeout(timeout_s):
        while service not in (await client.call_service("/rosapi/services", {}))["services"]:
            await asyncio.sleep(0.2)


async def test_rclpy_node_parameters_are_read_and_set_through_rosapi(ros2_node, bridge, registry):
    """rosapi's `node_name:param_name` against the node's rcl_interfaces services; the node
    itself then reads the new value (it publishes what `get_parameter` returns)."""
    node = ros2_node[2]
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        await wait_for_service(client, "/rb_test_node/set_parameters")
        seen = await client.subscribe("/param_seen", "std_msgs/msg/String")
        gain = await client.call_service("/rosapi/get_param", {"name": "/rb_test_node:gain"})
        label = await client.call_service("/rosapi/get_param", {"name": "rb_test_node:label"})
        absent = await client.call_service("/rosapi/has_param", {"name": "/rb_test_node:nope"})
        changed = await client.call_service(
            "/rosapi/set_param", {"name": "/rb_test_node:gain", "value": "2.5"}
        )
        node_saw = await first(seen, lambda m: m["data"].startswith("gain="))
        again = await client.call_service("/rosapi/get_param", {"name": "/rb_test_node:gain"})
    assert gain == {"value": "1.5", "successful": True, "reason": ""}, node.output()
    assert label["value"] == '"riverbridge"' and absent == {"exists": False}
    assert changed == {"successful": True, "reason": ""}
    assert node_saw["data"] == "gain=2.5" and again["value"] == "2.5"


def roslibpy_fibonacci(host: str, port: int) -> dict:
    """roslibpy's ActionClient (PyPI): one goal to the end, one cancelled, two refused."""
    with rp.connected(host, port) as ros:
        client = roslibpy.ActionClient(ros, "/fibonacci", "test_msgs/action/Fibonacci")
        feedback, results, errors = rp.Inbox(), rp.Inbox(), rp.Inbox()
        client.send_goal(roslibpy.Goal({"order": 4}), results, feedback, errors)
        [done] = results.expect(1, timeout_s=DISCOVERY_TIMEOUT_S)
        canceled = rp.Inbox()
        goal_id = client.send_goal(roslibpy.Goal({"order": 40}), canceled, rp.Inbox(), errors)
        time.sleep(0.3)  # a goal under way; the result says whether the cancel reached it
        client.cancel_goal(goal_id)
        [stopped] = canceled.expect(1, timeout_s=DISCOVERY_TIMEOUT_S)
        unknown = roslibpy.ActionClient(ros, "/no_such_action", "test_msgs/action/Fibonacci")
        unknown.send_goal(roslibpy.Goal({"order": 2}), rp.Inbox(), rp.Inbox(), errors)
        mismatch = roslibpy.ActionClient(ros, "/fibonacci", "example_interfaces/action/Fibonacci")
        mismatch.send_goal(roslibpy.Goal({"order": 2}), rp.Inbox(), rp.Inbox(), errors)
        refused = errors.expect(2, timeout_s=DISCOVERY_TIMEOUT_S)
    return {
        "done": done,
        "feedback": [list(f["sequence"]) for f in feedback.snapshot()],
        "stopped": stopped,
        "refused": sorted(str(error["values"]) for error in refused),
    }


async def test_roslibpy_drives_the_rclpy_action_server(ros2_node, bridge, registry):
    node = ros2_node[2]
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        await wait_for_action(client, "/fibonacci")
        outcome = await asyncio.to_thread(roslibpy_fibonacci, "127.0.0.1", bridge.port)
    assert outcome["done"]["values"] == {"sequence": [0, 1, 1, 2, 3]}, node.output()
    assert outcome["done"]["status"] == roslibpy.core.GoalStatus.SUCCEEDED
    assert_feedback_leads_to(outcome["feedback"], [0, 1, 1, 2, 3])
    assert outcome["stopped"]["status"] == roslibpy.core.GoalStatus.CANCELED
    assert outcome["refused"] == [
        "Action /fibonacci is test_msgs/action/Fibonacci, not example_interfaces/action/Fibonacci",
        "Action /no_such_action does not exist",
    ]


async def test_roslibjs_drives_the_rclpy_action_server(ros2_node, bridge, registry):
    node = ros2_node[2]
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        await wait_for_action(client, "/fibonacci")
        outcome = await asyncio.to_thread(
            run_scenario,
            "action_client.mjs",
            bridge.url,
            "/fibonacci",
            "test_msgs/action/Fibonacci",
        )
    assert outcome["result"] == {"sequence": [0, 1, 1, 2, 3, 5]}, node.output()
    assert_feedback_leads_to([f["sequence"] for f in outcome["feedback"]], [0, 1, 1, 2, 3, 5])
    assert outcome["canceled"].startswith("GoalError: Action was canceled")


async def test_foxglove_client_reads_and_sets_the_rclpy_node_parameters(
    ros2_node, bridge, registry
):
    """Foxglove's FoxgloveClient (npm) names the node's parameters as foxglove_bridge does
    (`/rb_test_node.gain`): read with their types, set (the node itself sees the new value),
    the update sent to the subscribed client, a change made through rosapi seen through
    `/parameter_events`, and listed by getParameters with no names."""
    node = ros2_node[2]
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        await wait_for_service(client, "/rb_test_node/list_parameters")
        await wait_for_service(client, "/rb_test_node/set_parameters")
        before = await client.call_service("/rosapi/get_param", {"name": "/rb_test_node:gain"})
        seen = await client.subscribe("/param_seen", "std_msgs/msg/String")
        scenario = asyncio.create_task(
            asyncio.to_thread(run_scenario, "foxglove_params.mjs", bridge.url, "/rb_test_node")
        )
        n = 0
        while not scenario.done():  # until the scenario, subscribed to `enabled`, sees one
            n += 1
            enabled = {"name": "/rb_test_node:enabled", "value": "true" if n % 2 else "false"}
            await client.call_service("/rosapi/set_param", enabled)
            await asyncio.wait({scenario}, timeout=0.3)
        outcome = scenario.result()
        node_saw = await first(seen, lambda m: m["data"] == "gain=3.25")
        after = await client.call_service("/rosapi/get_param", {"name": "/rb_test_node:gain"})
    assert outcome["statuses"] == [] and outcome["errors"] == [], node.output()
    assert outcome["get"] == [
        {"name": "/rb_test_node.gain", "value": float(before["value"]), "type": "float64"},
        {"name": "/rb_test_node.label", "value": "riverbridge"},
    ]
    assert outcome["enabled"]["value"] in (True, False)  # set through rosapi meanwhile
    gain = {"name": "/rb_test_node.gain", "value": 3.25, "type": "float64"}
    assert outcome["set"] == [gain] and outcome["update"] == [gain]
    assert node_saw["data"] == "gain=3.25" and after["value"] == "3.25"
    assert {"/rb_test_node.gain", "/rb_test_node.use_sim_time"} <= set(outcome["all"])
    assert outcome["external"]["name"] == "/rb_test_node.enabled"
    assert isinstance(outcome["external"]["value"], bool)  # only rosapi set it


async def test_get_param_names_lists_the_rclpy_nodes_parameters(ros2_node, bridge, registry):
    """rosapi's get_param_names: the bridge's own names, then `node:param` of the rclpy node
    (from its list_parameters)."""
    node = ros2_node[2]
    async with RosbridgeClient(bridge.url, registry=registry) as client:
        await wait_for_service(client, "/rb_test_node/list_parameters")
        await client.call_service("/rosapi/set_param", {"name": "rate_hz", "value": "2.5"})
        listed = await client.call_service("/rosapi/get_param_names", {})
    names = listed["names"]
    assert names[0] == "rate_hz", node.output()
    wanted = {"/rb_test_node:gain", "/rb_test_node:label", "/rb_test_node:use_sim_time"}
    assert wanted <= set(names)
