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
from simulator.config import CameraConfig, LidarConfig, SceneConfig, SimConfig
from simulator.node import serve
from simulator.scene import build_scene
from tests.graph_peers import RecordingService, cyclone_loopback_env, run_json_peer
from tests.receiving import surge_speed_reaches

pytestmark = pytest.mark.slow

PEER = Path(__file__).resolve().parent / "ros2_peer.py"
# Coarse terrain and a sparse LIDAR keep the simulator light on two shared cores.
LIGHT = SimConfig(
    scene=SceneConfig(terrain_cells=80, trees=10, houses=3),
    lidar=LidarConfig(horizontal_resolution_deg=2.0, vertical_resolution_deg=2.0, rate_hz=4.0),
    camera=CameraConfig(width_px=160, height_px=120, rate_hz=4.0),
)


async def run_peer(domain: int, *args: str, timeout_s: float = 90.0) -> dict:
    """Run ros2_peer.py in its own process with a loopback-only Cyclone configuration."""
    env = cyclone_loopback_env()
    return await run_json_peer(PEER, str(domain), *args, env=env, timeout_s=timeout_s)


async def test_independent_participant_reads_imu_and_steers_the_vessel(dds_domain, registry):
    scene = await asyncio.to_thread(build_scene, LIGHT.scene, seed=LIGHT.seed)
    stop = asyncio.Event()
    config = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=dds_domain)
    async with (
        run_bridge(config) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as watcher,
    ):
        odom = await watcher.subscribe("/odom", "nav_msgs/msg/Odometry", maxsize=1)
        sim = asyncio.create_task(serve(bridge.url, LIGHT, stop, scene=scene))
        try:
            imu = asyncio.create_task(run_peer(dds_domain, "imu", "5", "60"))
            steering = asyncio.create_task(run_peer(dds_domain, "wrench", "40", "3000"))
            moving = asyncio.create_task(surge_speed_reaches(odom, 0.5, timeout_s=60.0))
            await asyncio.wait({moving, steering}, return_when=asyncio.FIRST_COMPLETED)
            if steering.done():
                steering.result()  # the peer failed: its output is in the assertion
            speed = await moving
            imu_result = await imu
            steering.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await steering
        finally:
            stop.set()
            await sim
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
