"""The sensor interface (simulator.sensor): every sensor makes its catalogue type from a
capture; a sensor the node has never heard of runs on its schedule just by being passed in,
a worker one on a background thread of its own that skips the ticks it overruns."""

from __future__ import annotations

import asyncio
import contextlib
import os
import threading
import time

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from schemas.catalogue import TOPICS, Role, Topic, by_name
from simulator.config import (
    CameraConfig,
    GroundTruthConfig,
    LidarConfig,
    SimConfig,
)
from simulator.dynamics import StepResult, VesselState
from simulator.node import SimulatorNode
from simulator.sensor import Capture, Generated, Schedule
from simulator.sensors import build_sensors, static_transforms

LIGHT = SimConfig(
    lidar=LidarConfig(horizontal_resolution_deg=2.0, vertical_resolution_deg=2.0, rate_hz=10.0),
    camera=CameraConfig(width_px=80, height_px=60),
)
STAMP_NS = 1_500_000_000


def capture_at_start(scene) -> Capture:
    step = StepResult(VesselState.at(scene.start_pose), (0.2, 0.0), 0.01, False)
    return Capture(step, STAMP_NS)


@pytest.mark.parametrize("truth", [True, False])
def test_every_sensor_makes_its_topics_type_at_the_capture_time(
    small_scene, check_canonical, truth
):
    cfg = LIGHT.model_copy(update={"ground_truth": GroundTruthConfig(enabled=truth)})
    sensors = build_sensors(cfg, small_scene)
    truths = {}
    try:
        for sensor in sensors:
            generated = sensor.generate(capture_at_start(small_scene))
            check_canonical(sensor.topic.type, generated.msg)
            header = generated.msg.get("header") or generated.msg["transforms"][0]["header"]
            assert header["stamp"] == {"sec": 1, "nanosec": 500_000_000}, sensor.topic.key
            truths.update(generated.truth)
    finally:
        for sensor in sensors:
            sensor.close()
    expected = {TOPICS["lidar_truth"].name, TOPICS["radar_truth"].name} if truth else set()
    assert set(truths) == expected
    for name, msg in truths.items():
        check_canonical(by_name(name).type, msg)


def test_static_transforms_cover_every_sensor_frame(small_scene):
    sensors = build_sensors(LIGHT, small_scene)
    try:
        frames = [t["child_frame_id"] for t in static_transforms(sensors, 0)["transforms"]]
    finally:
        for sensor in sensors:
            sensor.close()
    assert frames == ["lidar", "radar", "camera_optical", "imu", "gnss"]


class Probe:
    """A sensor the simulator does not have: a String of its capture stamp, `delay_s` late."""

    frame = None

    def __init__(self, topic: Topic, schedule: Schedule, delay_s: float = 0.0) -> None:
        self.topic, self.schedule, self.delay_s = topic, schedule, delay_s
        self.threads: set[str] = set()
        self.policies: set[int] = set()  # the scheduling policy of the thread it ran on
        self.closed = False

    def generate(self, capture: Capture) -> Generated:
        self.threads.add(threading.current_thread().name)
        self.policies.add(os.sched_getscheduler(0))  # Linux: the calling thread's
        time.sleep(self.delay_s)
        return Generated({"data": str(capture.stamp_ns)})

    def close(self) -> None:
        self.closed = True


def probe_topic(key: str, role: Role, rate_key: str) -> Topic:
    return Topic(
        key,
        f"/test/{key}",
        "std_msgs/msg/String",
        "simulator",
        role,
        "a test probe",
        rate_key=rate_key,
    )


@pytest.mark.slow
async def test_a_new_sensor_runs_on_its_schedule_by_being_passed_to_the_node(small_scene):
    """A timer sensor at the GNSS rate (5 Hz) and a worker sensor at the LIDAR rate (10 Hz)
    that takes 0.25 s: the worker skips the ticks it overruns instead of queueing them."""
    cfg = LIGHT.model_copy(update={"ground_truth": GroundTruthConfig(enabled=False)})
    timer = Probe(probe_topic("timer_probe", "realtime", "gnss.rate_hz"), "timer")
    slow = Probe(probe_topic("slow_probe", "sensor", "lidar.rate_hz"), "worker", delay_s=0.25)
    received: dict[str, list[str]] = {"timer_probe": [], "slow_probe": []}
    stop = asyncio.Event()
    async with (
        run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as bridge,
        RosbridgeClient(bridge.url, name="sim") as client,
        RosbridgeClient(bridge.url, name="listener") as listener,
    ):
        subs = {
            p.topic.key: await listener.subscribe(*p.topic.pair, maxsize=100) for p in (timer, slow)
        }
        node = SimulatorNode(client, cfg, small_scene, sensors=[timer, slow])
        task = asyncio.create_task(node.run(stop))

        async def collect(key: str) -> None:
            async for item in subs[key]:
                received[key].append(item.msg["data"])

        collectors = [asyncio.create_task(collect(key)) for key in subs]
        await asyncio.sleep(2.0)
        stop.set()
        await task
        await asyncio.sleep(0.2)
        for collector in collectors:
            collector.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await collector
    assert 7 <= len(received["timer_probe"]) <= 12  # 5 Hz for 2 s
    times = node.timings["slow_probe"]
    assert 4 <= times.count <= 10  # one per 0.25 s (its work), not one per 0.1 s
    assert times.skipped >= times.count - 1  # every overrun skips the ticks it missed ...
    assert times.count + times.skipped >= 15  # ... and the 10 Hz schedule holds (20 in 2 s)
    assert len(received["slow_probe"]) >= times.count - 1
    assert slow.threads == {"sim-slow_probe_0"}  # a thread of its own
    assert timer.threads == {threading.main_thread().name}  # on the event loop
    assert slow.policies == {os.SCHED_IDLE}  # background priority: idle cores only
    assert timer.closed and slow.closed
    assert node.timings.keys() == {"slow_probe", "physics"}
