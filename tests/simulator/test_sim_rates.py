"""`python -m bridge` + `python -m simulator` as real processes: every sensor topic arrives at
its configured rate (within 10 %), measured from `header.stamp`s over a ~10 s window.

The simulator runs its default configuration: the full thesis LIDAR (345,600 rays, 2 Hz), the
640 x 480 camera and the radar at 2 Hz, IMU / odometry / tf at the 50 Hz physics rate and GNSS
at 5 Hz. Measured on the 2-core machine with this very test subscribed to everything, all of
them hold their rate (LIDAR scan ~50 ms, camera frame ~50 ms of their 500 ms periods).
"""

from __future__ import annotations

import asyncio
import os
import re

import pytest

from clients import RosbridgeClient
from schemas.catalogue import TOPICS as CATALOGUE
from schemas.catalogue import published_by
from simulator.config import SimConfig
from simulator.sensor import config_value
from tests.child_process import running
from tests.simulator.sim_processes import header_stamp_s, running_bridge, simulator_argv

pytestmark = pytest.mark.slow

# Every sensor topic the simulator streams (schemas.catalogue): key -> (name, type)
TOPICS = {t.key: t.pair for t in published_by("simulator", "sensor", "realtime")}
WARMUP_S = 2.0  # the first scans pay for Embree's and OpenCV's lazy set-up
WINDOW_S = 10.0
TOLERANCE = 0.10


def configured_rates_hz(cfg: SimConfig) -> dict[str, float]:
    """Each topic's rate in `cfg`, from the catalogue's rate keys (IMU, odometry and tf: the
    physics rate)."""
    return {key: config_value(cfg, CATALOGUE[key].rate_key) for key in TOPICS}


async def record_stamps(
    url: str, registry, warmup_s: float, window_s: float
) -> dict[str, list[float]]:
    """Capture stamps (s) of every simulator topic received during `window_s` after
    `warmup_s`; every subscription queue is deep enough never to drop."""
    stamps: dict[str, list[float]] = {name: [] for name in TOPICS}
    async with RosbridgeClient(url, registry=registry, connect_timeout=30) as listener:
        subs = {
            name: await listener.subscribe(topic, type_name, maxsize=10_000)
            for name, (topic, type_name) in TOPICS.items()
        }
        recording = asyncio.Event()

        async def consume(name: str) -> None:
            async for received in subs[name]:
                if recording.is_set():
                    stamps[name].append(header_stamp_s(received.msg))

        tasks = [asyncio.create_task(consume(name)) for name in subs]
        try:
            await asyncio.sleep(warmup_s)
            recording.set()
            await asyncio.sleep(window_s)
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
    return stamps


def rate_hz(stamps_s: list[float]) -> float:
    """Messages per second between the first and the last stamp (0 for fewer than two)."""
    if len(stamps_s) < 2 or stamps_s[-1] <= stamps_s[0]:
        return 0.0
    return (len(stamps_s) - 1) / (stamps_s[-1] - stamps_s[0])


async def test_every_sensor_topic_arrives_at_its_configured_rate(registry):
    expected = configured_rates_hz(SimConfig())
    with running_bridge() as (_, url), running(simulator_argv(url)) as sim:
        await asyncio.to_thread(sim.wait_for_line, re.compile("simulator connected"))
        stamps = await record_stamps(url, registry, WARMUP_S, WINDOW_S)
        assert sim.process.poll() is None, sim.text()
    measured = {name: rate_hz(stamps[name]) for name in expected}
    report = {
        name: f"{measured[name]:.2f}/{expected[name]:g} Hz ({len(stamps[name])} msgs)"
        for name in expected
    }
    report["load average"] = f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    for name, hz in expected.items():
        assert measured[name] == pytest.approx(hz, rel=TOLERANCE), report
        # and the window really was covered: no long silence at either end
        assert len(stamps[name]) >= (1 - TOLERANCE) * hz * WINDOW_S, report
        assert all(b > a for a, b in zip(stamps[name], stamps[name][1:], strict=False)), name
