"""The vessel's sensor load over a websocket and the ages it arrives with, shared by the
benchmarks that carry it across a graph (benchmarks.dds: A -> DDS -> B; benchmarks.zenoh_shore:
vessel -> shore over an emulated link).

A PointCloud2 scan and a sensor_msgs/Imu are published as CBOR by one websocket client, each
stamped just before encoding; a reader's age of a message is its wall clock after decoding
minus that `header.stamp` (one clock: every process runs on this machine).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import statistics
import time

import numpy as np
import websockets

from schemas import codec_cbor
from schemas.pointcloud import pack_points

TOPICS = (("/lidar/points", "sensor_msgs/msg/PointCloud2"), ("/imu/data", "sensor_msgs/msg/Imu"))
POINT_STEP = 16  # x, y, z, intensity float32


def stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def key_of(topic: str) -> str:
    """The name a topic's ages are kept under: "scan" or "imu"."""
    return "scan" if topic == "/lidar/points" else "imu"


def scan_message(cloud: dict, now_ns: int) -> dict:
    """`cloud` (`schemas.pointcloud.pack_points`, packed once) stamped `now_ns`."""
    return {**cloud, "header": {"stamp": stamp(now_ns), "frame_id": "lidar"}}


def imu_message(now_ns: int) -> dict:
    return {
        "header": {"stamp": stamp(now_ns), "frame_id": "imu"},
        "linear_acceleration": {"x": 0.0, "y": 0.0, "z": 9.80665},
    }


async def publish(
    url: str, seconds: float, scan_points: int, scan_hz: float, imu_hz: float
) -> dict:
    """Scans of `scan_points` at `scan_hz` and IMU at `imu_hz` for `seconds`, each stamped
    just before encoding; how many of each were sent."""
    sent = {"scan": 0, "imu": 0}
    points = np.random.default_rng(0).random((scan_points, 4), dtype=np.float32)
    cloud = pack_points(points, 0, "lidar")  # x, y, z, intensity float32
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        for topic, type_name in TOPICS:
            await ws.send(json.dumps({"op": "advertise", "topic": topic, "type": type_name}))
        end = time.monotonic() + seconds

        async def stream(topic: str, hz: float, make, key: str) -> None:
            next_at = time.monotonic()
            while next_at < end:
                msg = make(time.time_ns())
                await ws.send(codec_cbor.dumps({"op": "publish", "topic": topic, "msg": msg}))
                sent[key] += 1
                next_at += 1.0 / hz
                await asyncio.sleep(max(0.0, next_at - time.monotonic()))

        await asyncio.gather(
            stream("/lidar/points", scan_hz, lambda t: scan_message(cloud, t), "scan"),
            stream("/imu/data", imu_hz, imu_message, "imu"),
        )
    return {"sent": sent}


async def read_ages(
    url: str, seconds: float, warmup_s: float, grace_s: float = 0.0, **subscribe_options: object
) -> dict[str, list[float]]:
    """Ages (ms) of the scans and IMU messages stamped after the first `warmup_s`, read as CBOR
    for `warmup_s + seconds + grace_s`; `subscribe_options` go into each subscribe op (e.g.
    `queue_length=1`). Prints "subscribed" once it has subscribed."""
    ages: dict[str, list[float]] = {"scan": [], "imu": []}
    start_ns = time.time_ns() + int(warmup_s * 1e9)
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        for topic, type_name in TOPICS:
            op = {"op": "subscribe", "topic": topic, "type": type_name, "compression": "cbor"}
            await ws.send(json.dumps({**op, **subscribe_options}))
        print("subscribed", flush=True)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(warmup_s + seconds + grace_s):
                async for frame in ws:
                    now = time.time_ns()
                    op = codec_cbor.loads(frame) if isinstance(frame, bytes) else json.loads(frame)
                    header = op.get("msg", {}).get("header", {}).get("stamp")
                    if op.get("op") != "publish" or header is None:
                        continue
                    sent_ns = header["sec"] * 1_000_000_000 + header["nanosec"]
                    if sent_ns >= start_ns:
                        ages[key_of(op["topic"])].append((now - sent_ns) / 1e6)
    return ages


def summary(ages: list[float], expected: int) -> str:
    """Median, p90, p99 and max of `ages` (ms), and how many of `expected` arrived."""
    if not ages:
        return f"nothing received (of {expected} sent)"
    ordered = sorted(ages)

    def pct(p: float) -> float:
        return ordered[min(len(ordered) - 1, int(p * len(ordered)))]

    return (
        f"median {statistics.median(ordered):8.1f}  p90 {pct(0.9):8.1f}  "
        f"p99 {pct(0.99):8.1f}  max {ordered[-1]:8.1f} ms  n {len(ordered):4d} of {expected}"
    )


def load() -> str:
    return "load " + " ".join(f"{x:.2f}" for x in os.getloadavg())
