"""Shore link: one client on one connection over an emulated link (issue 23).

A publisher on the bridge's host sends a full LIDAR scan (`sensor_msgs/PointCloud2`, ~179,000
returns of x, y, z, intensity: 2.86 MB, as the simulator's default) at 2 Hz and a
`sensor_msgs/Imu` at 50 Hz. One client ashore, behind `riverbridge link` (`clients.linkemu`,
default `4g`: 10 Mbit/s to the client, 30 ms each way, jitter, stalls), subscribes on one
connection to `/imu/data` (cbor) and `/lidar/points` (cbor, `queue_length: 1`,
`fragment_size: 65536`). Modes, each a fresh bridge, link and publisher:

- `fresh`: this bridge, those options (conflation, goodput-aware sending, interleaving);
- `plain`: this bridge, the same subscriptions without `queue_length` and `fragment_size`
  (the bridge's mechanisms off: a client that asks nothing gets every message, in order);
- `today`: the bridge of another checkout (`--compare DIR`, e.g. /work/main before issue 23)
  with the options of `fresh`;
- `reduced`: `fresh` plus the scan reduced to fit the measured goodput (`reduce`);
- `alone`: the IMU alone, no scan: the floor the link and the machine's load set.

Per mode: IMU age p50/p99 and the share of IMU samples delivered, scans per second and scan age
p50/p99, over `--seconds` after `--warmup`. Age is from the publisher's stamp to the client's
decoded message, one wall clock. The targets of issue 23 are printed beside the figures. The
reference rosbridge cannot run here (no ROS 2 installation on this machine).

Usage: python -m benchmarks.shore_link [--profile 4g] [--seconds 60] [--warmup 5]
       [--modes fresh,plain,reduced[,today]] [--compare DIR]
"""

from __future__ import annotations

import argparse
import asyncio
import multiprocessing as mp
import os
import re
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from clients import RosbridgeClient
from schemas import codec_cbor
from schemas.pointcloud import pack_points

SCAN_TOPIC, IMU_TOPIC = "/lidar/points", "/imu/data"
SCAN_HZ, IMU_HZ = 2.0, 50.0  # the simulator's defaults (thesis 4.1, 4.2)
TARGETS = {  # issue 23
    "fresh": "IMU p99 <= 150 ms, >= 95 % delivered; scans >= 0.3/s, p99 <= 3 s",
    "reduced": "IMU p99 <= 150 ms, >= 95 % delivered; scans >= 1/s, p99 <= 500 ms",
}


def synthetic_scan() -> np.ndarray:
    """(n, 4) float32 x, y, z, intensity: a 360 x 30 deg grid of rays at 0.25 deg from 3 m
    above calm water (the simulator's default "mesh" water returns every ray that meets it),
    with a few boxes standing in the water: ~170,000 returns, mostly water, like its scans."""
    az = np.deg2rad(np.arange(0, 360, 0.25))
    el = np.deg2rad(-np.arange(0.25, 30.25, 0.25))
    az_grid, el_grid = np.meshgrid(az, el)
    direction = np.stack(
        [np.cos(el_grid) * np.cos(az_grid), np.cos(el_grid) * np.sin(az_grid), np.sin(el_grid)],
        axis=-1,
    ).reshape(-1, 3)
    range_m = 3.0 / -direction[:, 2]
    for centre_x, centre_y in ((40.0, 10.0), (-25.0, 30.0), (15.0, -60.0)):  # 6 m boxes
        bearing = np.arctan2(direction[:, 1], direction[:, 0])
        hit = np.abs(bearing - np.arctan2(centre_y, centre_x)) < np.arctan2(
            3, np.hypot(centre_x, centre_y)
        )
        range_m = np.where(
            hit,
            np.minimum(range_m, np.hypot(centre_x, centre_y) / np.cos(np.arcsin(direction[:, 2]))),
            range_m,
        )
    keep = range_m < 200.0
    points = direction[keep] * range_m[keep, None]
    intensity = np.full((points.shape[0], 1), 0.05, dtype=np.float32)
    return np.hstack([points.astype(np.float32), intensity])


def stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def imu_msg(now_ns: int) -> dict[str, Any]:
    return {
        "header": {"stamp": stamp(now_ns), "frame_id": "imu"},
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        "angular_velocity": {"x": 0.01, "y": 0.02, "z": 0.03},
        "linear_acceleration": {"x": 0.1, "y": 0.2, "z": 9.81},
    }


async def publish(url: str, seconds: float, pipe: Connection) -> None:
    """The vessel's sensors: scans at 2 Hz and IMU at 50 Hz on one CBOR connection."""
    import websockets

    cloud = pack_points(synthetic_scan(), 0, "lidar")
    stamps: dict[str, list[int]] = {SCAN_TOPIC: [], IMU_TOPIC: []}
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        for topic, type_name in (
            (SCAN_TOPIC, "sensor_msgs/msg/PointCloud2"),
            (IMU_TOPIC, "sensor_msgs/msg/Imu"),
        ):
            await ws.send(f'{{"op":"advertise","topic":"{topic}","type":"{type_name}"}}')
        pipe.send("ready")
        pipe.recv()  # the subscriber is in
        start = time.monotonic()

        async def every(topic: str, hz: float, make: Any) -> None:
            n = 0
            while (due := start + n / hz) < start + seconds:
                await asyncio.sleep(max(0.0, due - time.monotonic()))
                now_ns = time.time_ns()
                msg = make(now_ns)
                await ws.send(codec_cbor.dumps({"op": "publish", "topic": topic, "msg": msg}))
                stamps[topic].append(now_ns)
                n += 1

        def scan(now_ns: int) -> dict[str, Any]:
            return {**cloud, "header": {"stamp": stamp(now_ns), "frame_id": "lidar"}}

        await asyncio.gather(every(SCAN_TOPIC, SCAN_HZ, scan), every(IMU_TOPIC, IMU_HZ, imu_msg))
    pipe.send(stamps)


def run_publisher(url: str, seconds: float, pipe: Connection) -> None:
    asyncio.run(publish(url, seconds, pipe))


@dataclass
class Seen:
    """(publisher stamp, client receive time) per message of one topic, and what the bridge
    said it did to the scans."""

    pairs: list[tuple[int, int]] = field(default_factory=list)
    notes: list[dict[str, Any]] = field(default_factory=list)


async def subscribe(url: str, mode: str, seconds: float, seen: dict[str, Seen]) -> None:
    scan_options: dict[str, Any] = {"compression": "cbor"}
    if mode != "plain":
        scan_options.update(queue_length=1, fragment_size=65536)
    if mode == "reduced":
        scan_options.update(reduce={"point_budget": "auto"})
    async with RosbridgeClient(url, encoding="cbor") as client:
        imu = await client.subscribe(
            IMU_TOPIC, "sensor_msgs/msg/Imu", compression="cbor", maxsize=10_000
        )
        scan = await client.subscribe(
            SCAN_TOPIC, None, maxsize=100, bytes_as_numpy=True, **scan_options
        )

        async def drain(sub: Any, topic: str) -> None:
            async for received in sub:
                head = received.msg["header"]["stamp"]
                sent = head["sec"] * 1_000_000_000 + head["nanosec"]
                seen[topic].pairs.append((sent, received.recv_ns))

        tasks = [asyncio.create_task(drain(imu, IMU_TOPIC))]
        if mode != "alone":
            tasks.append(asyncio.create_task(drain(scan, SCAN_TOPIC)))
        else:
            await scan.unsubscribe()
        await asyncio.sleep(seconds)
        for task in tasks:
            task.cancel()


def start_process(
    argv: list[str], pattern: str, root: str | None = None
) -> tuple[subprocess.Popen[str], re.Match[str]]:
    env = dict(os.environ)
    if root is not None:
        env["PYTHONPATH"] = os.path.abspath(root)
    process = subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=root
    )
    assert process.stdout is not None
    for line in process.stdout:
        match = re.search(pattern, line)
        if match:
            threading.Thread(target=_drain_output, args=(process,), daemon=True).start()
            return process, match
    raise RuntimeError(f"{argv[2]} exited before {pattern!r}")


def _drain_output(process: subprocess.Popen[str]) -> None:
    """Read a child's output to its end, so that a full pipe never stalls it."""
    assert process.stdout is not None
    for _ in process.stdout:
        pass


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def run_mode(mode: str, args: argparse.Namespace) -> dict[str, float]:
    root = args.compare if mode == "today" else None
    bridge, found = start_process(
        [sys.executable, "-m", "bridge", "--port", "0", "--log-level", "info"],
        r"listening on ws://[^:]+:(\d+)",
        root,
    )
    link, linked = start_process(
        [
            sys.executable,
            "-m",
            "clients.linkemu",
            "--profile",
            args.profile,
            "--upstream",
            f"127.0.0.1:{found.group(1)}",
            "--seed",
            str(args.seed),
        ],
        r"listening on \S+:(\d+) ->",
    )
    total_s = args.warmup + args.seconds
    ours, theirs = mp.Pipe()
    publisher = mp.Process(
        target=run_publisher, args=(f"ws://127.0.0.1:{found.group(1)}", total_s, theirs)
    )
    publisher.start()
    try:
        assert ours.recv() == "ready"
        seen = {SCAN_TOPIC: Seen(), IMU_TOPIC: Seen()}

        async def client() -> None:
            task = asyncio.create_task(
                subscribe(f"ws://127.0.0.1:{linked.group(1)}", mode, total_s + 3.0, seen)
            )
            await asyncio.sleep(1.0)  # subscribed before the first message
            ours.send("go")
            await task

        asyncio.run(client())
        stamps = ours.recv()
    finally:
        publisher.join(10)
        for process in (link, bridge):
            process.terminate()
            process.wait(10)
    return summarize(seen, stamps, args)


def summarize(
    seen: dict[str, Seen], stamps: dict[str, list[int]], args: argparse.Namespace
) -> dict[str, float]:
    first_ns = min(stamps[IMU_TOPIC]) + int(args.warmup * 1e9)
    last_ns = first_ns + int(args.seconds * 1e9)

    def window(topic: str) -> list[tuple[int, int]]:
        return [(s, r) for s, r in seen[topic].pairs if first_ns <= s < last_ns]

    imu, scans = window(IMU_TOPIC), window(SCAN_TOPIC)
    imu_sent = sum(1 for s in stamps[IMU_TOPIC] if first_ns <= s < last_ns)
    scans_sent = sum(1 for s in stamps[SCAN_TOPIC] if first_ns <= s < last_ns)
    imu_ages = [(r - s) / 1e6 for s, r in imu]
    scan_ages = [(r - s) / 1e6 for s, r in scans]
    return {
        "imu_p50_ms": percentile(imu_ages, 50),
        "imu_p99_ms": percentile(imu_ages, 99),
        "imu_max_ms": max(imu_ages, default=float("nan")),
        "imu_delivered_pct": 100.0 * len({s for s, _ in imu}) / max(1, imu_sent),
        "scans_per_s": len(scans) / args.seconds,
        "scans_sent": float(scans_sent),
        "scan_p50_ms": percentile(scan_ages, 50),
        "scan_p99_ms": percentile(scan_ages, 99),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.shore_link", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--profile", default="4g")
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--warmup", type=float, default=5.0)
    parser.add_argument("--modes", default="fresh,plain,reduced")
    parser.add_argument(
        "--compare", default=None, help="checkout whose bridge runs the mode 'today'"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the link's jitter and stalls")
    args = parser.parse_args(argv)
    modes = args.modes.split(",")
    if "today" in modes and args.compare is None:
        parser.error("--modes today needs --compare DIR")
    load = os.getloadavg()[0]
    window = f"{args.seconds:g} s after {args.warmup:g} s"
    print(f"shore link over {args.profile}, {window}; load {load:.2f}", flush=True)
    for mode in modes:
        result = run_mode(mode, args)
        imu = f"IMU p50 {result['imu_p50_ms']:7.1f} ms  p99 {result['imu_p99_ms']:7.1f} ms  "
        print(
            f"{mode:<8} {imu}"
            f"max {result['imu_max_ms']:7.1f} ms  delivered {result['imu_delivered_pct']:5.1f} %   "
            f"scans {result['scans_per_s']:.2f}/s of {result['scans_sent'] / args.seconds:.1f}  "
            f"p50 {result['scan_p50_ms']:7.0f} ms  p99 {result['scan_p99_ms']:7.0f} ms",
            flush=True,
        )
        if mode in TARGETS:
            print(f"{'':<8} target: {TARGETS[mode]}", flush=True)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
