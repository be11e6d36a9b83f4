"""The bridge restarts under a running `python -m navigation`: the same process reconnects,
re-subscribes and re-advertises by itself, and every `/nav/*` output flows again as soon as
sensor data does."""

from __future__ import annotations

import asyncio
import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from navigation.messages import stamp_ns_of
from navigation.node import IMU_INPUT, SENSOR_INPUTS
from navigation.processors import OUTPUT_TYPES, TOPIC_DIAGNOSTICS, TOPIC_MAP, TOPIC_MARKERS
from schemas.pointcloud import pack_points
from tests.navigation.nav_scenes import (
    camera_line_msg,
    default_scene,
    imu_msg,
    lidar_directions,
    radar_image_msg,
    raycast,
)

pytestmark = pytest.mark.slow

REPO_ROOT = Path(__file__).resolve().parents[2]
STARTUP_TIMEOUT_S = 90.0  # numpy, scikit-learn, OpenCV and rosbags on a loaded 2-core machine
WAIT_S = 30.0
FEED_PERIOD_S = 0.5  # the sensors' 2 Hz
BEFORE_SEC, AFTER_SEC = 1_000, 2_000  # stamp epochs (s) of the data fed before / after
# outputs that carry the stamp of the input they came from
STAMPED = [topic for topic in OUTPUT_TYPES if topic not in (TOPIC_MARKERS, TOPIC_DIAGNOSTICS)]


class NavigationProcess:
    """`python -m navigation` with its log in a file (no pipe to keep drained)."""

    def __init__(self, url: str, log_path: Path) -> None:
        self.log_path = log_path
        env = {**os.environ, "PYTHONPATH": str(REPO_ROOT), "PYTHONUNBUFFERED": "1"}
        with log_path.open("w") as log:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "navigation", "--bridge", url, "--log-level", "INFO"],
                cwd=REPO_ROOT,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
            )

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    async def wait_for_log(self, pattern: str, count: int = 1) -> None:
        """Until `pattern` occurs `count` times in the log; AssertionError with the log."""
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while len(re.findall(pattern, self.log())) < count:
            if self.process.poll() is not None or time.monotonic() > deadline:
                raise AssertionError(f"navigation never logged {pattern!r} x{count}:\n{self.log()}")
            await asyncio.sleep(0.1)

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=20.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=20.0)
        return self.process.returncode


@contextlib.contextmanager
def running_navigation(url: str, log_path: Path) -> Iterator[NavigationProcess]:
    nav = NavigationProcess(url, log_path)
    try:
        yield nav
    finally:
        nav.stop()


def sensor_messages(stamp_ns: int, scan_points: np.ndarray) -> dict[str, dict[str, Any]]:
    """One message per navigation input, all stamped `stamp_ns`."""
    radar = radar_image_msg(stamp_ns, n_cells=200, range_step_m=0.5, target_cell=100)
    return {
        SENSOR_INPUTS["lidar"][0]: pack_points(scan_points, stamp_ns, "lidar"),
        SENSOR_INPUTS["radar"][0]: radar,
        SENSOR_INPUTS["camera"][0]: camera_line_msg(stamp_ns, width_px=320, height_px=240),
        IMU_INPUT[0]: imu_msg(stamp_ns),
    }


async def feed(peer: RosbridgeClient, epoch_sec: int, scan_points: np.ndarray) -> None:
    """Publish every input at 2 Hz, stamps counting up from `epoch_sec`, until cancelled."""
    for k in range(10_000):
        stamp_ns = epoch_sec * 10**9 + int(k * FEED_PERIOD_S * 1e9)
        for topic, msg in sensor_messages(stamp_ns, scan_points).items():
            await peer.publish(topic, msg)
        await asyncio.sleep(FEED_PERIOD_S)


async def outputs_from_epoch(
    peer: RosbridgeClient, epoch_sec: int, scan_points: np.ndarray
) -> dict[str, dict]:
    """Feed data of `epoch_sec` until every /nav/* output has answered; the first message
    of each output (stamped outputs: the first stamped in that epoch)."""
    subs = {
        topic: await peer.subscribe(topic, type_name, maxsize=10)
        for topic, type_name in OUTPUT_TYPES.items()
    }

    async def first(topic: str) -> tuple[str, dict]:
        async for received in subs[topic]:
            if topic not in STAMPED or (stamp_ns_of(received.msg["header"]) >= epoch_sec * 10**9):
                return topic, received.msg
        raise AssertionError(f"{topic}: subscription ended")

    feeder = asyncio.create_task(feed(peer, epoch_sec, scan_points))
    try:
        async with asyncio.timeout(WAIT_S):
            return dict(await asyncio.gather(*(first(topic) for topic in subs)))
    finally:
        feeder.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await feeder
        for sub in subs.values():
            await sub.unsubscribe()


async def test_navigation_resumes_its_outputs_after_the_bridge_restarts(tmp_path):
    scan_points, _ = raycast(default_scene(), lidar_directions(1.0, 1.0))
    reconnected = r"navigation connected to \S+ \(\d+ registrations restored\)"
    async with contextlib.AsyncExitStack() as stack:
        async with run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as first_bridge:
            url, port = first_bridge.url, first_bridge.port
            peer = await stack.enter_async_context(
                RosbridgeClient(url, connect_timeout=WAIT_S, backoff_max=0.5, name="peer")
            )
            for topic, type_name in [*SENSOR_INPUTS.values(), IMU_INPUT]:
                await peer.advertise(topic, type_name)
            nav = stack.enter_context(running_navigation(url, tmp_path / "navigation.log"))
            await nav.wait_for_log(reconnected)
            before = await outputs_from_epoch(peer, BEFORE_SEC, scan_points)
        await asyncio.sleep(1.0)  # no bridge: both clients keep retrying
        assert nav.process.poll() is None, nav.log()
        async with run_bridge(BridgeConfig(host="127.0.0.1", port=port)):
            await peer.wait_connected(WAIT_S)
            await nav.wait_for_log(reconnected, count=2)
            after = await outputs_from_epoch(peer, AFTER_SEC, scan_points)
            assert nav.process.poll() is None, nav.log()
    assert set(before) == set(after) == set(OUTPUT_TYPES)
    for topic in STAMPED:  # answers to the data fed after the restart, not older ones
        assert stamp_ns_of(after[topic]["header"]) >= AFTER_SEC * 10**9, topic
    assert len(after["/nav/boxes"]["boxes"]) > 0
    assert (after[TOPIC_MAP]["data"] == 100).any()
