"""`riverbridge report --link`: shore clients through the link emulator, one per mode, against
a real bridge and a publisher of IMU samples and small scans; then the report's table."""

from __future__ import annotations

import asyncio
import time

import numpy as np
import websockets

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients.report.results import Run
from clients.report.shore import IMU, LIDAR, MODES, ShoreWatch
from clients.report.text import render_run
from schemas import codec_cbor
from schemas.pointcloud import pack_points

SECONDS = 2.0


async def publish(url: str) -> None:
    """IMU at 50 Hz and a 20,000-point scan at 4 Hz for SECONDS, stamped when sent."""
    rng = np.random.default_rng(3)
    points = rng.uniform(-50, 50, (20_000, 4)).astype(np.float32)
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        for topic, type_name in (IMU, LIDAR):
            await ws.send(codec_cbor.dumps({"op": "advertise", "topic": topic, "type": type_name}))
        start = time.monotonic()
        for tick in range(int(SECONDS * 50)):
            await asyncio.sleep(max(0.0, start + tick / 50 - time.monotonic()))
            now_ns = time.time_ns()
            stamp = {"sec": now_ns // 10**9, "nanosec": now_ns % 10**9}
            imu = {"header": {"stamp": stamp, "frame_id": "imu"}}
            await ws.send(codec_cbor.dumps({"op": "publish", "topic": IMU[0], "msg": imu}))
            if tick % 12 == 0:
                scan = pack_points(points, now_ns, "lidar")
                await ws.send(codec_cbor.dumps({"op": "publish", "topic": LIDAR[0], "msg": scan}))


async def test_each_mode_reads_the_imu_and_scans_through_its_own_link(registry):
    async with run_bridge(BridgeConfig(port=0), registry) as bridge:
        shore = ShoreWatch("wifi", ("127.0.0.1", bridge.port))
        async with shore:
            await asyncio.sleep(0.5)  # subscribed through the links
            start_ns = time.time_ns()
            await publish(f"ws://127.0.0.1:{bridge.port}")
            end_ns = time.time_ns()
            await asyncio.sleep(1.0)  # the last ones cross
            link = shore.summary(start_ns, end_ns)
    assert link.profile == "wifi"
    assert [mode.mode for mode in link.modes] == list(MODES)
    for mode in link.modes:
        assert mode.imu.delivered_share == 1.0, mode
        assert mode.imu.age_p50_ms is not None and mode.imu.age_p50_ms >= 10  # 10 ms each way
        assert mode.lidar.received > 0, mode
    # wifi carries these scans: only "reduced" thins them once the goodput is measured
    plain = next(m for m in link.modes if m.mode == "plain")
    assert plain.points_kept_p50 == 20_000 and plain.lidar.delivered_share == 1.0

    text = render_run(Run(encoding="cbor", duration_s=SECONDS, shore_link=link))
    assert "ashore over the emulated wifi link" in text
    assert '"fragment_size": 65536' in text and "/lidar/points" in text
