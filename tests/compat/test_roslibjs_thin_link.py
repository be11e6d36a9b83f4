"""roslibjs 2.x over an emulated thin link (docs/bridge.md, "Over a thin link"): the bridge
interleaves IMU samples between the fragments of a JSON scan; roslibjs reassembles every scan
whole and gets the IMU without waiting for whole scans. (roslibpy and Lichtblick's roslibjs
fork have no `fragment` handler at all: docs/bridge.md says what they should ask instead.)"""

from __future__ import annotations

import asyncio
import hashlib
import time
from typing import Any

import numpy as np

from clients.linkemu import Direction, LinkEmulator, LinkProfile

from .bridge_process import BridgeEndpoint
from .messages import imu, point_cloud
from .node_runner import run_scenario
from .wire import wire_peer

# 8 Mbit/s, 5 ms each way: a 20,000-point JSON scan (~430 kB) takes ~0.45 s to cross
LINK = LinkProfile(
    name="thin",
    to_client=Direction(rate_bps=8e6, delay_ms=5, buffer_bytes=20_000),
    to_server=Direction(rate_bps=8e6, delay_ms=5, buffer_bytes=20_000),
)
SCANS = 4
FRAGMENT = 16_384


def stamped(msg: dict[str, Any]) -> dict[str, Any]:
    ns = time.time_ns()
    header = {**msg["header"], "stamp": {"sec": ns // 10**9, "nanosec": ns % 10**9}}
    return {**msg, "header": header}


async def test_roslibjs_reassembles_scans_whose_fragments_let_the_imu_through(
    bridge: BridgeEndpoint,
) -> None:
    cloud = point_cloud(20_000)
    async with (
        LinkEmulator(LINK, (bridge.host, bridge.port)) as link,
        wire_peer(bridge.url) as publisher,
    ):
        for topic, type_name in (
            ("/compat/thin/scan", "sensor_msgs/msg/PointCloud2"),
            ("/compat/thin/imu", "sensor_msgs/msg/Imu"),
        ):
            await publisher.send({"op": "advertise", "topic": topic, "type": type_name})
        await publisher.call_service("/rosapi/get_time")
        args = (f"ws://127.0.0.1:{link.port}", "/compat/thin/scan", "/compat/thin/imu")
        script = asyncio.create_task(
            asyncio.to_thread(run_scenario, "thin_link.mjs", *args, str(FRAGMENT), str(SCANS))
        )
        tick = 0
        while not script.done():  # the IMU at 50 Hz, a scan at 4 Hz (twice what the link takes)
            await publisher.send(
                {"op": "publish", "topic": "/compat/thin/imu", "msg": stamped(imu())}
            )
            if tick % 12 == 0:
                await publisher.send(
                    {"op": "publish", "topic": "/compat/thin/scan", "msg": cloud.message}
                )
            tick += 1
            await asyncio.wait({script}, timeout=0.02)
        result = script.result()

    assert result["status_ops"] == []
    expected = hashlib.sha256(cloud.points.astype("<f4").tobytes()).hexdigest()
    assert [scan["sha256"] for scan in result["scans"]] == [expected] * SCANS
    assert all(scan["n_points"] == 20_000 for scan in result["scans"])
    # IMU samples arrived while scans were crossing, and not a whole scan late
    assert result["imu_during_scan"] > 0
    assert float(np.percentile(result["imu_ages_ms"], 90)) < 300, result["imu_ages_ms"]
