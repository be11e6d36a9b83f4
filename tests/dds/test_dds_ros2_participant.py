"""ROS 2 compatibility shown with an independent participant (tests/dds/ros2_peer.py: plain
cyclonedds, types declared by hand as rosidl does, its own process and configuration).

It reads the simulator's `sensor_msgs/msg/Imu` from `rt/imu/data` through the bridge and
decodes the CDR with rosbags, and it steers the simulated vessel by publishing
`geometry_msgs/msg/Wrench` on `rt/cmd_wrench`, the command topic the simulator subscribes to.
"""

from __future__ import annotations

import asyncio
import contextlib
from pathlib import Path

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from tests.graph_peers import (
    RecordingService,
    cyclone_loopback_env,
    light_simulator,
    run_json_peer,
    speed_while_steering,
)

pytestmark = pytest.mark.slow

PEER = Path(__file__).resolve().parent / "ros2_peer.py"


async def run_peer(domain: int, *args: str, timeout_s: float = 90.0) -> dict:
    """Run ros2_peer.py in its own process with a loopback-only Cyclone configuration."""
    env = cyclone_loopback_env()
    return await run_json_peer(PEER, str(domain), *args, env=env, timeout_s=timeout_s)


async def test_independent_participant_reads_imu_and_steers_the_vessel(dds_domain, registry):
    config = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=dds_domain)
    async with (
        run_bridge(config) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as watcher,
    ):
        odom = await watcher.subscribe("/odom", "nav_msgs/msg/Odometry", maxsize=1)
        async with light_simulator(bridge.url):
            imu = asyncio.create_task(run_peer(dds_domain, "imu", "5", "60"))
            steering = asyncio.create_task(run_peer(dds_domain, "wrench", "40", "3000"))
            speed = await speed_while_steering(steering, odom, 0.5, timeout_s=60.0)
            imu_result = await imu
            steering.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await steering
    assert speed >= 0.5
    messages = imu_result["messages"]
    assert len(messages) == 5
    assert all(m["frame_id"] == "imu" and m["covariance_length"] == 9 for m in messages)
    assert messages[-1]["accel_z"] == pytest.approx(9.80665, abs=1e-6)
    # Distinct samples (their order is the simulator's: a late physics tick may stamp a
    # caught-up step earlier than the previous tick's last one).
    assert len({m["stamp_ns"] for m in messages}) == 5


async def test_independent_participant_calls_a_service_a_client_provides(dds_domain, registry):
    """The service request/reply layout written independently in ros2_peer.py (rmw
    cyclonedds's header, `clientid` user data) meets the bridge's DDS service server."""
    config = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=dds_domain)
    gate = RecordingService({"success": True, "message": "lock gate opening"})
    async with (
        run_bridge(config) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as provider,
    ):
        await provider.advertise_service("/lock_gate", "std_srvs/srv/SetBool", gate)
        answer = await run_peer(dds_domain, "call", "/lock_gate", "60")
    assert answer == {"ok": True, "success": True, "message": "lock gate opening"}
    assert gate.requests == [{"data": True}]
