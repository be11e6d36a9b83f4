"""rmw_zenoh compatibility shown with an independent participant (tests/zenoh/zenoh_peer.py:
plain eclipse-zenoh written from rmw_zenoh's design.md, its own process, rosbags for CDR).

It sees the bridge's liveliness tokens, reads the simulator's `sensor_msgs/msg/Imu` through
the bridge, steers the simulated vessel with `geometry_msgs/msg/Wrench` on `/cmd_wrench`, and
calls a service a websocket client provides. Bad samples are dropped with one line each.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from tests.graph_peers import RecordingService, light_simulator, speed_while_steering
from tests.zenoh.conftest import run_peer

pytestmark = pytest.mark.slow


def zenoh_config(domain: int, endpoint: str) -> BridgeConfig:
    return BridgeConfig(
        host="127.0.0.1", port=0, zenoh=True, dds_domain=domain, zenoh_listen=(endpoint,)
    )


async def test_participant_sees_tokens_reads_imu_and_steers_the_vessel(
    zenoh_domain, zenoh_endpoint, registry
):
    async with (
        run_bridge(zenoh_config(zenoh_domain, zenoh_endpoint)) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as watcher,
    ):
        odom = await watcher.subscribe("/odom", "nav_msgs/msg/Odometry", maxsize=1)
        async with light_simulator(bridge.url):
            imu = asyncio.create_task(run_peer(zenoh_endpoint, zenoh_domain, "imu", "5", "60"))
            steering = asyncio.create_task(
                run_peer(zenoh_endpoint, zenoh_domain, "wrench", "40", "3000")
            )
            speed = await speed_while_steering(steering, odom, 0.5, timeout_s=60.0)
            nodes = await watcher.call_service("/rosapi/nodes", {})
            publishers = await watcher.call_service("/rosapi/publishers", {"topic": "/cmd_wrench"})
            details = await watcher.call_service("/rosapi/node_details", {"node": "/zenoh_helm"})
            imu_result = await imu
            tokens = await run_peer(zenoh_endpoint, zenoh_domain, "tokens", "riverbridge_", "20")
            steering.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await steering
    assert speed >= 0.5
    assert "/zenoh_helm" in nodes["nodes"]  # rosapi lists the Zenoh graph (its tokens)
    assert "/zenoh_helm" in publishers["publishers"]
    assert details["publishing"] == ["/cmd_wrench"]
    messages = imu_result["messages"]
    assert len(messages) == 5
    assert all(m["frame_id"] == "imu" and m["covariance_length"] == 9 for m in messages)
    assert messages[-1]["accel_z"] == pytest.approx(9.80665, abs=1e-6)
    assert all(m["gid_length"] == 16 for m in messages)
    assert [m["sequence"] for m in messages] == sorted(m["sequence"] for m in messages)
    assert messages[0]["key"].startswith(f"{zenoh_domain}/imu/data/sensor_msgs::msg::dds_::Imu_/")
    assert messages[0]["key"].split("/")[-1].startswith("RIHS01_")
    own = [k.split("/") for k in tokens["tokens"] if "/riverbridge_" in k]
    kinds = {(p[5], p[9] if len(p) > 9 else "") for p in own}
    assert ("NN", "") in kinds
    assert ("MP", "%imu%data") in kinds and ("MS", "%cmd_wrench") in kinds


async def test_participant_calls_a_service_a_client_provides(
    zenoh_domain, zenoh_endpoint, registry
):
    gate = RecordingService({"success": True, "message": "lock gate opening"})
    async with (
        run_bridge(zenoh_config(zenoh_domain, zenoh_endpoint)) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as provider,
    ):
        await provider.advertise_service("/lock_gate", "std_srvs/srv/SetBool", gate)
        result = await run_peer(zenoh_endpoint, zenoh_domain, "call", "/lock_gate", "30")
    assert result["success"] is True and result["message"] == "lock gate opening", result
    assert result["sequence"] == 7 and result["gid_echoed"] is True
    assert gate.requests == [{"data": True}]


async def test_bad_samples_are_dropped_with_one_line_each(
    zenoh_domain, zenoh_endpoint, registry, caplog
):
    caplog.set_level(logging.WARNING, logger="bridge.zenoh")
    async with (
        run_bridge(zenoh_config(zenoh_domain, zenoh_endpoint)) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as reader,
    ):
        chatter = await reader.subscribe("/chatter", "std_msgs/msg/String")
        result = await run_peer(zenoh_endpoint, zenoh_domain, "bad", "/chatter")
        async with asyncio.timeout(20):
            first = await anext(aiter(chatter))
    assert result["sent"] == 4
    assert first.msg == {"data": "good"}
    lines = [r.getMessage() for r in caplog.records if r.name == "bridge.zenoh"]
    assert any("bad attachment on /chatter" in line and "20 bytes" in line for line in lines)
    assert any("unknown type in its key on /chatter" in line for line in lines)
    assert any("undecodable sample on /chatter" in line for line in lines)
