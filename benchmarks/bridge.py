"""Latency through the bridge: publisher -> bridge -> subscriber, all on this host.

Runs `python -m bridge` as its own process (glibc malloc tuned as in
performance-measurements.md, unless --default-malloc) and measures, with one wall clock,
from just before the publisher encodes to just after the subscriber decoded:

1. a 4 MB PointCloud2 (262,144 points x 16 B) published and subscribed as CBOR;
2. the same cloud published and subscribed as JSON (base64 data);
3. a small Imu at 100 Hz while the cloud streams at 5 Hz to a JSON subscriber;
4. the CBOR cloud fanned out to 4 subscribers (latency to the last of them).

Prints median, p90, p99 and max per case.
Usage: python -m benchmarks.bridge [--messages N] [--no-offload] [--default-malloc]
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import json
import os
import re
import statistics
import subprocess
import sys
import time

import numpy as np
import websockets

from benchmarks.malloc import malloc_tuned, rerun_tuned
from schemas import codec_cbor, codec_json
from schemas.pointcloud import pack_points
from schemas.runtime.process import MALLOC_ENV as TUNED_MALLOC

CLOUD_POINTS = 262_144  # x, y, z, intensity float32 -> 4,194,304 B of data


def cloud_message(stamp_ns: int, cloud: dict) -> dict:
    """`cloud` (`schemas.pointcloud.pack_points`, packed once) stamped `stamp_ns`."""
    return {**cloud, "header": {"stamp": stamp(stamp_ns), "frame_id": "lidar"}}


def random_cloud(seed: int) -> dict:
    points = np.random.default_rng(seed).random((CLOUD_POINTS, 4), dtype=np.float32)
    return pack_points(points, 0, "lidar")


def stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def stamp_ns(msg: dict) -> int:
    return msg["header"]["stamp"]["sec"] * 1_000_000_000 + msg["header"]["stamp"]["nanosec"]


def encode(op: dict, binary: bool) -> bytes | str:
    if binary:
        return codec_cbor.dumps(op)
    if isinstance(op["msg"].get("data"), bytes):
        op = {**op, "msg": {**op["msg"], "data": base64.b64encode(op["msg"]["data"]).decode()}}
    return codec_json.dumps(op).decode("ascii")


def decode(frame: bytes | str) -> dict:
    """Decode like a subscriber would, including the cloud's base64 payload."""
    if isinstance(frame, bytes):
        return codec_cbor.loads(frame)
    message = codec_json.loads(frame)
    data = message.get("msg", {}).get("data")
    if isinstance(data, str):
        message["msg"]["data"] = np.frombuffer(base64.b64decode(data), dtype=np.uint8)
    return message


async def start_bridge(tuned: bool, offload: bool) -> tuple[subprocess.Popen, str]:
    env = {**os.environ, **(TUNED_MALLOC if tuned else {})}
    extra = [] if offload else ["--offload-threshold", str(1 << 40)]
    process = subprocess.Popen(
        [sys.executable, "-m", "bridge", "--port", "0", "--log-level", "warning", *extra],
        stderr=subprocess.PIPE,
        env=env,
        text=True,
    )
    assert process.stderr is not None
    while True:
        line = await asyncio.to_thread(process.stderr.readline)
        if not line:
            raise RuntimeError("bridge exited before listening")
        match = re.search(r"listening on (ws://\S+)", line)
        if match:
            return process, match.group(1)


async def subscribe(url: str, topic: str, type_name: str, compression: str):
    ws = await websockets.connect(url, max_size=None, compression=None)
    await ws.send(
        json.dumps(
            {"op": "subscribe", "topic": topic, "type": type_name, "compression": compression}
        )
    )
    await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "s"}))
    while not isinstance(frame := await ws.recv(), str) or '"service_response"' not in frame:
        pass
    return ws


async def cloud_latency(url: str, binary: bool, subscribers: int, count: int) -> list[float]:
    """ms from publish to decoded on the last of `subscribers`, one message in flight."""
    compression = "cbor" if binary else "none"
    subs = [
        await subscribe(url, "/lidar", "sensor_msgs/msg/PointCloud2", compression)
        for _ in range(subscribers)
    ]
    pub = await websockets.connect(url, max_size=None, compression=None)
    cloud = random_cloud(0)
    latencies = []
    for _ in range(count + 2):
        sent_ns = time.time_ns()
        await pub.send(
            encode(
                {"op": "publish", "topic": "/lidar", "msg": cloud_message(sent_ns, cloud)}, binary
            )
        )
        for ws in subs:
            message = decode(await ws.recv())
            assert stamp_ns(message["msg"]) == sent_ns
        latencies.append((time.time_ns() - sent_ns) / 1e6)
        await asyncio.sleep(0.1)
    for ws in [*subs, pub]:
        await ws.close()
    return latencies[2:]


async def imu_under_load(url: str, seconds: float) -> list[float]:
    """ms per Imu (100 Hz) while a 4 MB cloud streams at 5 Hz to a JSON subscriber."""
    cloud_sub = await subscribe(url, "/lidar", "sensor_msgs/msg/PointCloud2", "none")
    imu_sub = await subscribe(url, "/imu", "sensor_msgs/msg/Imu", "none")
    pub = await websockets.connect(url, max_size=None, compression=None)
    imu_pub = await websockets.connect(url, compression=None)
    cloud = random_cloud(1)
    latencies: list[float] = []
    end = time.monotonic() + seconds

    async def stream_cloud() -> None:
        while time.monotonic() < end:
            await pub.send(
                encode(
                    {
                        "op": "publish",
                        "topic": "/lidar",
                        "msg": cloud_message(time.time_ns(), cloud),
                    },
                    True,
                )
            )
            await asyncio.sleep(0.2)

    async def drain_cloud() -> None:
        while True:  # no decoding here: this process must not delay the Imu reader itself
            await cloud_sub.recv(decode=False)

    async def stream_imu() -> None:
        while time.monotonic() < end:
            msg = {"header": {"stamp": stamp(time.time_ns()), "frame_id": "imu"}}
            await imu_pub.send(encode({"op": "publish", "topic": "/imu", "msg": msg}, False))
            await asyncio.sleep(0.01)

    async def read_imu() -> None:
        while True:
            message = decode(await imu_sub.recv())
            latencies.append((time.time_ns() - stamp_ns(message["msg"])) / 1e6)

    readers = [asyncio.create_task(drain_cloud()), asyncio.create_task(read_imu())]
    await asyncio.gather(stream_cloud(), stream_imu())
    await asyncio.sleep(0.5)
    for task in readers:
        task.cancel()
    for ws in (cloud_sub, imu_sub, pub, imu_pub):
        await ws.close()
    return latencies[10:]


def summary(name: str, latencies: list[float]) -> str:
    p90, p99 = (float(np.percentile(latencies, q)) for q in (90, 99))
    return (
        f"{name:<52} median {statistics.median(latencies):7.2f}  p90 {p90:7.2f}  "
        f"p99 {p99:7.2f}  max {max(latencies):7.2f} ms  n={len(latencies)}"
    )


async def run(count: int, tuned: bool, offload: bool) -> None:
    process, url = await start_bridge(tuned, offload)
    try:
        print(
            f"bridge at {url}: {'tuned' if tuned else 'default'} malloc, large codec work "
            f"{'in worker threads' if offload else 'on the event loop'}; "
            f"cloud {CLOUD_POINTS * 16 / 1e6:.2f} MB"
        )
        print(summary("PointCloud2 4 MB, CBOR -> CBOR", await cloud_latency(url, True, 1, count)))
        print(summary("PointCloud2 4 MB, JSON -> JSON", await cloud_latency(url, False, 1, count)))
        print(
            summary(
                "Imu 100 Hz while 4 MB cloud streams 5 Hz to JSON sub",
                await imu_under_load(url, max(5.0, count / 5)),
            )
        )
        print(
            summary(
                "PointCloud2 4 MB, CBOR fan-out to 4 (last one)",
                await cloud_latency(url, True, 4, count),
            )
        )
    finally:
        process.terminate()
        process.wait(10)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=30, help="clouds per case")
    parser.add_argument(
        "--no-offload",
        action="store_true",
        help="encode and decode everything on the bridge's event loop",
    )
    parser.add_argument(
        "--default-malloc",
        action="store_true",
        help="run the bridge without the tuned glibc malloc thresholds",
    )
    args = parser.parse_args(argv)
    tuned = not args.default_malloc
    if tuned and argv is None and not malloc_tuned():
        # The clients in this process allocate 4 MB buffers too: restart with the same tuning.
        rerun_tuned(__spec__.name, sys.argv[1:])
    asyncio.run(run(args.messages, tuned, not args.no_offload))
    return 0


if __name__ == "__main__":
    sys.exit(main())
